"""The experiment runner: Hydra configuration, training runs, checkpoints, evaluation, reports, Ray."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from rlbridge.agents import make_learner, usecase_dims
from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.train import TrainState, find_checkpoint, load_checkpoint, run_training, save_checkpoint

ROOT = Path(__file__).resolve().parent.parent
TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
# Small and quick: tiny scenario, 4 intruders, 10-minute episodes, in-process worker.
QUICK = [f"scenario={TINY}", "workers=0", "env.time_limit_s=600", "usecase.params.n_intruders=4",
         "train.baseline_episodes=1", "train.best_window=2", "train.checkpoint_every=1"]


def compose_train(overrides: list[str]):
    return compose_config("config", overrides=QUICK + overrides)


def cli(args: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", *args], cwd=cwd, env=env, check=False,
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def curve_rows(run: Path) -> list[dict[str, str]]:
    with open(run / "learning_curve.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("train") / "d2mava"
    run_training(compose_train(["algorithm=d2mava_a", "train.iterations=3"]), run)
    return run


# --------------------------------------------------------------------------- configuration
def test_defaults_are_the_papers_tables():
    cfg = compose_config("config")
    ddqn = compose_config("config", overrides=["algorithm=ddqn"])
    assert cfg.algorithm.name == "d2mava_a" and cfg.usecase.name == "corridor_sa"
    p = cfg.algorithm.params
    assert (p.lr, p.batch_size, p.epochs, p.ent_coef, p.clip, p.hidden, p.gamma, p.lam, p.leaky_slope, p.shared) == \
        (1e-5, 512, 6, 1e-4, 0.1, 128, 0.99, 0.95, 0.2, False)
    q = ddqn.algorithm.params
    assert (q.batch_size, q.hidden, q.gamma, q.eps_decay_steps, q.eps_start, q.eps_end, q.replay_size, q.lr,
            q.target_update, q.double) == (512, 128, 0.99, 500000, 0.999, 0.0001, 5000000, 1e-4, 50000, True)
    # RLlib's DQN as the paper ran it: a step per 4 x 40 environment steps, counts in environment steps.
    assert (q.schedule, q.rollout_fragment_length, q.rllib_num_workers, q.learning_starts) == ("rllib", 4, 40, 1000)
    assert ddqn.algorithm.label == "DDQN (RLlib update ratio)"
    old = compose_config("config", overrides=["algorithm=ddqn_per_transition"]).algorithm
    assert (old.params.schedule, old.params.train_freq, old.params.learning_starts) == ("per_transition", 4, 10000)
    assert old.label == "DDQN (1 step per 4 transitions)"
    u = cfg.usecase.params
    assert (u.nmac_m, u.lowc_m, u.n_wpt, u.n_intruders, u.d_max_m, u.alpha, u.delta, u.psi, u.omega) == \
        (None, None, 2, 30, 3000.0, 1.0, 0.0003, 0.001, 0.001)  # None: the simulation's separation standard


def test_config_overrides_reach_the_algorithm_and_use_case(tmp_path):
    cfg = compose_train(["algorithm=ddqn", "algorithm.params.lr=0.0123", "algorithm.params.hidden=32",
                         "usecase.params.n_intruders=3", "train.iterations=1", "seed=7"])
    run_training(cfg, tmp_path)
    ckpt = load_checkpoint(tmp_path / "checkpoints" / "last.pt")
    assert ckpt["algorithm"]["params"]["lr"] == 0.0123
    assert ckpt["learner"]["optimizer"]["param_groups"][0]["lr"] == 0.0123
    w = ckpt["learner"]["model"]["net.0.weight"]
    assert tuple(w.shape) == (32, 9 + 3 * 11)  # hidden 32; ownship 9 + 3 intruders x 11
    resolved = (tmp_path / "resolved_config.yaml").read_text()
    assert "lr: 0.0123" in resolved and "n_intruders: 3" in resolved and "seed: 7" in resolved


def test_ddqn_gradient_steps_follow_the_runs_environment_steps(tmp_path):
    """The workers' environment steps reach the learner: one step per fragment x workers of them."""
    summary = run_training(compose_train(
        ["algorithm=ddqn", "train.iterations=2", "train.baseline_episodes=0", "algorithm.params.batch_size=8",
         "algorithm.params.rollout_fragment_length=2", "algorithm.params.rllib_num_workers=2",
         "algorithm.params.learning_starts=10", "algorithm.params.eps_decay_steps=100"]), tmp_path)
    env = summary["env_steps"]
    assert 12 < env < summary["aircraft_states"]  # two aircraft share most environment steps
    last = curve_rows(tmp_path)[-1]
    assert float(last["gradient_steps"]) == len(range(12, env + 1, 4))  # at 12, 16, ... <= env
    assert float(last["epsilon"]) == pytest.approx(0.999 + env / 100 * (0.0001 - 0.999), rel=1e-5)


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the error of a machine without CUDA")
def test_device_cuda_without_cuda_is_one_clear_error_before_anything_starts(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    run = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "train", "device=cuda", f"scenario={TINY}",
                           "workers=0", f"hydra.run.dir={run}"], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.returncode != 0
    assert "device=cuda: CUDA is not available on this machine" in proc.stderr
    # Nothing started: no configuration, curve or checkpoint written (Hydra's own .hydra/ and log aside).
    assert {p.name for p in run.iterdir()} <= {".hydra", "train.log"}


def test_unknown_algorithm_parameter_is_rejected(tmp_path):
    cfg = compose_train(["+algorithm.params.learning_rat=0.1", "train.iterations=1"])
    with pytest.raises(TypeError, match="learning_rat"):
        run_training(cfg, tmp_path)


# ------------------------------------------------------------------------------ checkpoints
@pytest.mark.parametrize("kind", ["d2mava", "dqn"])
def test_checkpoint_round_trip(tmp_path, kind):
    d = usecase_dims("corridor_sa", {"n_intruders": 4})
    a = make_learner(kind, {"learning_starts": 0} if kind == "dqn" else {}, d, seed=1)
    # Give the optimiser a state, then save.
    params = list(a.model.parameters()) if kind == "d2mava" else list(a.q.parameters())
    sum(p.sum() for p in params).backward()
    a.optimizer.step()
    state = TrainState(iteration=5, transitions=123, rewards=[1.0, 2.0], best=1.5, best_iteration=4)
    save_checkpoint(tmp_path / "c.pt", a, state, {"algorithm": {"kind": kind}})
    ckpt = load_checkpoint(tmp_path / "c.pt")
    b = make_learner(kind, {"learning_starts": 0} if kind == "dqn" else {}, d, seed=99)
    b.load_state_dict(ckpt["learner"])
    assert TrainState(**ckpt["state"]) == state
    for (ka, va), (kb, vb) in zip(a.state_dict()["model"].items(), b.state_dict()["model"].items()):
        assert ka == kb and torch.equal(va, vb)
    assert b.optimizer.state_dict()["state"].keys() == a.optimizer.state_dict()["state"].keys()
    np.testing.assert_equal(a.weights(), b.weights())


def test_training_run_outputs(trained_run):
    for name in ("resolved_config.yaml", "learning_curve.csv", "baseline.json", "training_summary.json",
                 "checkpoints/last.pt", "checkpoints/best.pt"):
        assert (trained_run / name).exists(), name
    rows = curve_rows(trained_run)
    assert [int(r["iteration"]) for r in rows] == [1, 2, 3]
    assert all(float(r["states_per_s"]) > 0 and int(r["aircraft_states"]) > 0 for r in rows)
    summary = json.loads((trained_run / "training_summary.json").read_text())
    assert summary["iterations"] == 3 and summary["aircraft_states"] == sum(int(r["aircraft_states"]) for r in rows)
    best = load_checkpoint(trained_run / "checkpoints" / "best.pt")
    assert best["state"]["best_iteration"] in (2, 3)  # window 2: first candidate at iteration 2


def test_train_cli_and_resume(tmp_path):
    base = ["train", *QUICK, "algorithm=d2mava_a", "out_dir=runs"]
    cli(base + ["train.iterations=2", "hydra.run.dir=runs/first"], tmp_path)
    first = tmp_path / "runs" / "first"
    assert len(curve_rows(first)) == 2
    proc = cli(base + ["train.iterations=4", f"train.resume={first}", "hydra.run.dir=runs/second"], tmp_path)
    second = tmp_path / "runs" / "second"
    assert "resumed from" in proc.stdout + proc.stderr
    assert [int(r["iteration"]) for r in curve_rows(second)] == [1, 2, 3, 4]
    assert load_checkpoint(find_checkpoint(second))["state"]["iteration"] == 4
    # The resumed iterations 3-4 are those an uninterrupted run would have produced.
    cli(base + ["train.iterations=4", "hydra.run.dir=runs/straight"], tmp_path)
    straight = curve_rows(tmp_path / "runs" / "straight")
    resumed = curve_rows(second)
    for k in (2, 3):
        assert straight[k]["episode_rewards"] == resumed[k]["episode_rewards"]


def test_a_resumed_run_shorter_than_the_rolling_window_stands_in_its_final_weights_for_the_best(tmp_path):
    """A session shorter than ``best_window`` writes its final weights as ``best.pt``; resumed (here in its own
    directory) and again ended before the window filled, the new final weights replace that stand-in."""
    quick = [o for o in QUICK if not o.startswith("train.best_window")] + ["train.best_window=10"]
    base = ["train", *quick, "algorithm=d2mava_a", "out_dir=runs", "hydra.run.dir=runs/short"]
    cli(base + ["train.iterations=2"], tmp_path)
    run = tmp_path / "runs" / "short"
    assert load_checkpoint(run / "checkpoints" / "best.pt")["state"]["best_iteration"] == 2
    cli(base + ["train.iterations=3", f"train.resume={run}"], tmp_path)
    best = load_checkpoint(run / "checkpoints" / "best.pt")
    last = load_checkpoint(run / "checkpoints" / "last.pt")
    assert best["state"]["iteration"] == best["state"]["best_iteration"] == 3
    assert all(torch.equal(best["learner"]["model"][k], v) for k, v in last["learner"]["model"].items())
    assert json.loads((run / "training_summary.json").read_text())["best_iteration"] == 3


def test_multirun_sweep(tmp_path):
    cli(["train", "--multirun", *QUICK, "algorithm=d2mava_a_shared,ddqn", "train.iterations=1", "out_dir=runs",
         "hydra.sweep.dir=runs/sweep"], tmp_path)
    runs = sorted(p.name for p in (tmp_path / "runs" / "sweep").iterdir() if p.is_dir())
    assert runs == ["0_d2mava_a_shared_s0", "1_ddqn_s0"]
    for r in runs:
        assert len(curve_rows(tmp_path / "runs" / "sweep" / r)) == 1


# ---------------------------------------------------------------------- evaluation, report
def test_evaluate_compare_and_report(tmp_path, trained_run):
    cli(["evaluate", f"run={trained_run}", "episodes=3", "workers=0", "env.time_limit_s=600",
         "hydra.run.dir=eval"], tmp_path)
    ev_dir = tmp_path / "eval"
    ev = json.loads((ev_dir / "evaluation.json").read_text())
    assert ev["scenario"] == "tiny_conflict" and ev["episodes"] == 3 and ev["seeds"] == [0, 1, 2]
    assert set(ev["policies"]) == {"d2mava_a", "unequipped", "mvp_speed", "daa"}
    # tiny_conflict: unequipped, the pair meets at the merge fix (one NMAC per episode); MVP's speed
    # change sequences them (none), so its risk ratio is 0 / 1 on every seed.
    assert ev["policies"]["unequipped"]["nmac_events"] == {"mean": 1.0, "std": 0.0}
    assert ev["policies"]["mvp_speed"]["nmac_events"]["mean"] == 0.0
    assert ev["policies"]["mvp_speed"]["risk_ratio"]["mean"] == 0.0
    for policy in ev["policies"]:
        summaries = sorted((ev_dir / "episodes" / policy).glob("seed-*/summary.json"))
        assert len(summaries) == 3
        s = json.loads(summaries[0].read_text())
        assert {"scenario", "scenario_sha256", "seed", "safety", "operational"} <= set(s)
    # `aamsim compare` reads the same files.
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "aamsim", "compare", str(ev_dir / "episodes" / "mvp_speed"),
                           str(ev_dir / "episodes" / "unequipped")], check=False, capture_output=True, text=True,
                          env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "risk ratio" in proc.stdout.lower()
    cli(["report", str(ev_dir), "--train", str(trained_run), "-o", "report"], tmp_path)
    rep = tmp_path / "report"
    for name in ("risk_ratio.csv", "risk_ratio.md", "lowc_ratio.csv", "lowc_ratio.md", "operational.csv",
                 "operational.md", "training.md", "report.md", "reward_curve.png", "nmac_curve.png",
                 "states_per_hour.png"):
        assert (rep / name).stat().st_size > 0, name
    with open(rep / "risk_ratio.csv", newline="") as fh:
        table = list(csv.reader(fh))
    # Every ratio beside what it cost (issue 13: safety never without its cost).
    assert table[0] == ["Algorithm", "Risk Ratio - tiny_conflict", "flights completed - tiny_conflict",
                        "airborne holding [s] - tiny_conflict", "flights holding [%] - tiny_conflict",
                        "parked at time limit - tiny_conflict", "mean delay [s] - tiny_conflict",
                        "advisories / flight hour - tiny_conflict"]
    assert [r[0].split(" — ")[0] for r in table[1:]] == ["D2MAV-A No Shared Layers", "MVP speed-only (rule-based)",
                                                        "DAA speed-only (DO-365/DAIDALUS)"]
    assert "±" in table[1][1]
    episodes = {p: [json.loads(f.read_text()) for f in sorted((ev_dir / "episodes" / p).glob("seed-*/summary.json"))]
                for p in ("d2mava_a", "mvp_speed")}
    for row, policy in zip(table[1:], ("d2mava_a", "mvp_speed")):
        ops = [e["operational"] for e in episodes[policy]]
        assert float(row[2]) == pytest.approx(np.mean([o["flights_completed"] for o in ops]), abs=0.05)
        parked = np.mean([o["parked_at_time_limit"] for o in ops])
        assert float(row[5]) == pytest.approx(parked, abs=0.005)
        assert ("PARKS AIRCRAFT" in row[0]) == (parked > 0)
    # No path of this machine in a report meant to be committed (only run names).
    assert str(tmp_path) not in (rep / "report.md").read_text()
    assert f"Evaluation runs: {ev_dir.name}" in (rep / "report.md").read_text()
    assert (rep / "reward_curve.png").read_bytes()[:4] == b"\x89PNG"
    with open(rep / "nmac_encounters.csv", newline="") as fh:
        enc = list(csv.DictReader(fh))
    assert {r["Algorithm"] for r in enc} >= {"Unequipped", "D2MAV-A No Shared Layers"}
    for r in enc:  # every NMAC has exactly one geometry
        kinds = ("same-direction", "head-on", "crossing", "vertical", "hover")
        assert sum(float(r[k].split(" ± ")[0]) for k in kinds) == pytest.approx(
            float(r["NMAC / episode"].split(" ± ")[0]), abs=0.02)
    unequipped = next(r for r in enc if r["Algorithm"] == "Unequipped")
    assert float(unequipped["NMAC / episode"].split(" ± ")[0]) > 0


def test_aamgym_usage():
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "--help"], check=False, capture_output=True,
                          text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=60)
    assert proc.returncode == 0 and "train" in proc.stdout and "report" in proc.stdout
    assert "aamgym = rlbridge.experiment.cli:main" in (ROOT / "setup.cfg").read_text()


# ------------------------------------------------------------------------------------ Ray
@pytest.mark.slow
def test_ray_workers_produce_the_same_transitions_as_in_process():
    import ray

    from rlbridge.agents.core import episode_seed
    from rlbridge.agents.rollout import EnvSpec
    from rlbridge.experiment.workers import InProcessPool, RayPool

    d = usecase_dims("corridor_sa", {"n_intruders": 4})
    learner = make_learner("d2mava", {}, d, seed=0)
    env = EnvSpec(TINY, params={"n_intruders": 4, "alt_noise_ft": 100.0}, time_limit_s=600.0)
    actors = {"policy": learner.actor_spec("d2mava")}
    lists = [[episode_seed(0, 1, w)] for w in range(2)]  # iteration 1 of a 2-worker run
    local = InProcessPool(env, actors).collect(lists, "policy", learner.weights(), {"greedy": False})
    pool = RayPool(2, env, actors, num_cpus=2)
    try:
        remote = pool.collect(lists, "policy", learner.weights(), {"greedy": False})
    finally:
        pool.shutdown()
    assert not ray.is_initialized()
    assert [len(b) for part in remote for b in part] == [len(b) for part in local for b in part]
    assert sum(len(b) for part in remote for b in part) > 0
    for part_l, part_r in zip(local, remote):
        for bl, br in zip(part_l, part_r):
            np.testing.assert_array_equal(bl.actions, br.actions)
            np.testing.assert_array_equal(bl.rewards, br.rewards)


class _RunsCode:
    """Unpickling this object would call ``Path.touch(marker)``: stands for any code in a hostile file."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (Path.touch, (self.marker,))


def test_checkpoint_with_a_pickled_object_is_refused_without_running_it(tmp_path):
    marker = tmp_path / "code-ran"
    path = tmp_path / "hostile.pt"
    torch.save({"format": 1, "algorithm": {"kind": "d2mava"}, "learner": _RunsCode(marker)}, path)
    with pytest.raises(ValueError, match=r"hostile\.pt: refused"):
        load_checkpoint(path)
    assert not marker.exists()


def test_checkpoint_is_plain_data_loadable_with_weights_only(tmp_path):
    d = usecase_dims("corridor_sa", {"n_intruders": 4})
    a = make_learner("dqn", {}, d, seed=1)
    meta = {"algorithm": {"kind": "dqn"}, "dims": {"n": np.int64(3)}, "env": {"metrics": ("safety",)},
            "where": tmp_path, "array": np.arange(3.0)}
    save_checkpoint(tmp_path / "c.pt", a, TrainState(), meta)
    raw = torch.load(tmp_path / "c.pt", weights_only=True)
    assert raw["dims"]["n"] == 3 and type(raw["dims"]["n"]) is int
    assert raw["where"] == str(tmp_path) and torch.equal(raw["array"], torch.arange(3.0, dtype=torch.float64))
    with pytest.raises(TypeError, match=r"checkpoint\.bad"):
        save_checkpoint(tmp_path / "d.pt", a, TrainState(), {"bad": object()})


@pytest.mark.bluesky
def test_evaluate_on_bluesky_agrees_with_aamsim_and_the_report_shows_both(tmp_path, trained_run):
    """``aamgym evaluate backend=bluesky``: BlueSky flies the aircraft; the report puts its columns beside aamsim's."""
    common = [f"run={trained_run}", "episodes=2", "workers=0", "env.time_limit_s=600"]
    cli(["evaluate", *common, "hydra.run.dir=eval_local"], tmp_path)
    cli(["evaluate", *common, "backend=bluesky", "hydra.run.dir=eval_bluesky"], tmp_path)
    local = json.loads((tmp_path / "eval_local" / "evaluation.json").read_text())
    blue = json.loads((tmp_path / "eval_bluesky" / "evaluation.json").read_text())
    assert (local["backend"], blue["backend"]) == ("local", "bluesky")
    assert set(blue["policies"]) == {"d2mava_a", "unequipped", "mvp_speed", "daa"}
    for policy, p in local["policies"].items():
        q = blue["policies"][policy]
        # The same events, and rewards within 1e-6: the kinematics agree to millimetres, and the
        # per-episode altitude noise is applied to BlueSky's aircraft too.
        assert (q["nmac_events"], q["lowc_events"]) == (p["nmac_events"], p["lowc_events"]), policy
        assert q["reward_per_aircraft"]["mean"] == pytest.approx(p["reward_per_aircraft"]["mean"], abs=1e-6), policy
    cli(["report", "eval_local", "eval_bluesky", "-o", "report"], tmp_path)
    with open(tmp_path / "report" / "risk_ratio.csv", newline="") as fh:
        header = next(csv.reader(fh))
    assert any(h.endswith("tiny_conflict") for h in header)
    assert any(h.endswith("tiny_conflict (on BlueSky)") for h in header)


def test_rollouts_refuse_a_backend_they_cannot_run_on():
    from rlbridge.agents.rollout import EnvSpec

    with pytest.raises(ValueError, match="'local', 'zmq', 'bluesky'"):
        EnvSpec(TINY, backend="ray")
    with pytest.raises(ValueError, match='backend "zmq" needs the address of a simulation server'):
        EnvSpec(TINY, backend="zmq")


def test_evaluation_keeps_the_training_runs_time_limit_and_dt_unless_overridden():
    from rlbridge.agents.rollout import EnvSpec
    from rlbridge.experiment.evaluate import evaluation_env

    trained = EnvSpec(TINY, params={"n_intruders": 4}, time_limit_s=600.0, dt=0.5)
    default = compose_config("evaluate", overrides=["run=x"])
    override = compose_config("evaluate", overrides=["run=x", "env.time_limit_s=90", "env.dt=0.25"])
    env = evaluation_env(default, trained)
    assert (env.time_limit_s, env.dt, env.scenario) == (600.0, 0.5, TINY)
    assert env.params["n_intruders"] == 4 and env.params["alt_noise_ft"] == 100.0
    env = evaluation_env(override, trained)
    assert (env.time_limit_s, env.dt) == (90.0, 0.25)
    # A training run on the engine's default stays on it.
    assert evaluation_env(default, EnvSpec(TINY)).time_limit_s is None


def test_d2mava_on_a_flat_observation_is_refused_naming_the_algorithm_that_fits():
    # reach_destination observes its own aircraft only: no intruders for D2MAV-A's attention to read.
    dims = usecase_dims("reach_destination", {})
    with pytest.raises(ValueError, match="needs an observation of an ownship and its intruders.*algorithm=ddqn"):
        make_learner("d2mava", {}, dims, "cpu", 0)


def test_ddqn_trains_on_a_use_case_with_one_observation_format(tmp_path):
    # reach_destination has no obs_format parameter: DDQN's flat observation is its only one.
    cfg = compose_config("config", overrides=["usecase=reach_destination", "algorithm=ddqn_per_transition",
                                               f"scenario={TINY}", "workers=0", "train.iterations=2",
                                               "env.time_limit_s=300", "train.baseline_episodes=1"])
    run_training(cfg, tmp_path)
    rows = list(csv.DictReader((tmp_path / "learning_curve.csv").open()))
    assert len(rows) == 2 and int(rows[-1]["aircraft_states_total"]) > 0
