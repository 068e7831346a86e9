"""``scripts/reproduce_paper.sh`` (``aamgym study``): the paper's whole study, run tiny end to end."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rlbridge.experiment.study import DEFAULT_RATES, StudyPlan, estimate_hours

ROOT = Path(__file__).resolve().parent.parent
TINY = "tests/data/tiny_conflict.scn"


def run_script(args: list[str], timeout: float) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([str(ROOT / "scripts" / "reproduce_paper.sh"), *args], env=env, check=False,
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def test_plan_states_the_study_and_its_time_from_the_throughput():
    plan = StudyPlan()
    assert len(plan.runs()) == 3 * 2 * 2  # contenders x use-case configurations x seeds
    est = estimate_hours(plan, DEFAULT_RATES)
    assert est["d2mava_a per run"] == pytest.approx(15e6 / DEFAULT_RATES["d2mava_a"] / 3600)
    assert est["all training runs"] == pytest.approx(
        4 * sum(15e6 / DEFAULT_RATES[a] / 3600 for a in ("d2mava_a", "d2mava_a_shared", "ddqn")))
    proc = run_script(["--plan"], timeout=120)
    assert "12 training runs of 15,000,000 aircraft-states" in proc.stdout
    assert "48 evaluations of 100 episodes" in proc.stdout
    assert f"this machine: {os.cpu_count()} CPUs, learner on " in proc.stdout


def test_plan_states_what_the_committed_runs_took_and_what_is_left(tmp_path):
    """--plan reads the finished runs' wall clock: 15 M aircraft-states in 27,000 s is 555.6 per second,
    7.5 h a run; 11 runs are left, 3 of them D2MAV-A's (22.5 h), and D2MAV-A Shared was never measured."""
    from rlbridge.experiment.study import measured_line

    run = tmp_path / "runs" / "corridor_sa" / "d2mava_a_s0"
    run.mkdir(parents=True)
    (run / "training_summary.json").write_text(json.dumps(
        {"algorithm": "d2mava_a", "aircraft_states": 15_000_000, "wall_s": 27_000.0}))
    for name in ("policy.npz", "policy.json", "learning_curve.csv", "resolved_config.yaml"):
        (run / name).write_text("")
    ddqn = tmp_path / "runs" / "corridor_sa_v1" / "ddqn_s1"  # unfinished export: measured, not done
    ddqn.mkdir(parents=True)
    (ddqn / "training_summary.json").write_text(json.dumps(
        {"algorithm": "ddqn", "aircraft_states": 15_000_000, "wall_s": 10_800.0}))
    line = measured_line(StudyPlan(), tmp_path)
    assert "d2mava_a 1 run, 556 aircraft-states/s, 7.5 h per run" in line
    assert "ddqn 1 run, 1,389 aircraft-states/s, 3.0 h per run" in line
    assert "the 11 runs not finished: 34.5 h plus those of d2mava_a_shared" in line  # 3 x 7.5 + 4 x 3.0
    assert measured_line(StudyPlan(), tmp_path / "nothing") is None
    assert measured_line(StudyPlan(contenders=["d2mava_a"], usecases=["corridor_sa"], seeds=[0]),
                         tmp_path).endswith("; every run finished")


def test_plan_states_what_the_committed_evaluations_took_and_what_is_left(tmp_path):
    """--plan reads the committed evaluations' episode times: on nyc_eval_678 the policy's 100 episodes took
    1,200 s and 1,800 s (median 1,500 s: 25 min), the baselines' 3,000 s (50 min, only where every baseline
    played); 2 of 48 are committed, 46 left, 22 of them on nyc_eval_678 (22 x 25 min = 9.2 h) and 24 on
    nyc_train_100, where nothing was measured."""
    from rlbridge.experiment.study import measured_evaluations_line

    def write(run: str, actions: str, policies: dict) -> None:
        d = tmp_path / "evaluations" / "corridor_sa" / run / f"nyc_eval_678_{actions}"
        d.mkdir(parents=True)
        (d / "evaluation.json").write_text(json.dumps({"episodes": 100, "policies": policies}))

    write("d2mava_a_s0", "greedy", {"d2mava_a": {"learned": True, "wall_s": 1200.0},
                                    "unequipped": {"learned": False, "wall_s": 1000.0},
                                    "mvp_speed": {"learned": False, "wall_s": 800.0},
                                    "daa": {"learned": False, "wall_s": 1200.0}})
    write("d2mava_a_s0", "sampled", {"d2mava_a": {"learned": True, "wall_s": 1800.0},
                                     "unequipped": {"learned": False, "wall_s": 1000.0}})
    line = measured_evaluations_line(StudyPlan(), tmp_path)
    assert "(2 of 48, their episodes' time): nyc_eval_678 25 min for the policy's 100 episodes, 50 min for " \
           "the baselines'; the 46 evaluations left: 9.2 h" in line
    assert line.endswith("and those on nyc_train_100 (no evaluation of it committed yet)")
    assert measured_evaluations_line(StudyPlan(), tmp_path / "nothing") is None


def test_machine_estimate_is_the_slower_of_rollouts_and_learner():
    from rlbridge.experiment.machine import CUDA_LEARNER_RATES, ROLLOUT_PER_CORE, machine_estimate

    kinds = {"d2mava_a": "d2mava", "ddqn": "dqn"}
    cpu_rates = {"d2mava_a": 5000.0, "ddqn": 20000.0}
    gpu = machine_estimate(kinds, "cuda", 15, cpu_rates, cores=16)
    # D2MAV-A: 15 workers play 124,500 states/s, the H200 learner updates 73,794: the learner bounds it;
    # DDQN (RLlib ratio): 220,500 against 989,238: the rollouts do.
    assert CUDA_LEARNER_RATES["d2mava_a"] == 73794.0 < 15 * ROLLOUT_PER_CORE["d2mava"]
    assert gpu.rates == {"d2mava_a": 73794.0, "ddqn": 15 * ROLLOUT_PER_CORE["dqn"]}
    assert gpu.bound == {"d2mava_a": "learner, measured alone on an H200", "ddqn": "rollouts"}
    few = machine_estimate(kinds, "cuda", 2, cpu_rates, cores=3)  # 2 workers: the rollouts bound both
    assert few.rates == {"d2mava_a": 2 * 8300.0, "ddqn": 2 * 14700.0}
    unmeasured = machine_estimate({"new_algo": "d2mava"}, "cuda", 4, {}, cores=5)
    assert unmeasured.rates == {"new_algo": 4 * 8300.0}
    assert unmeasured.bound == {"new_algo": "rollouts (GPU learner not measured: assumed to keep up)"}
    cpu = machine_estimate(kinds, "cpu", 1, cpu_rates, cores=2)  # one worker: the rollouts bound DDQN
    assert cpu.rates == {"d2mava_a": 5000.0, "ddqn": ROLLOUT_PER_CORE["dqn"]}
    assert cpu.bound == {"d2mava_a": "measured on 2 cores", "ddqn": "rollouts"}


def test_workers_auto_is_a_study_plan_the_report_and_evaluations_understand(monkeypatch):
    """`reproduce_paper.sh --workers auto` (the GPU machine's command): the departures under every table
    name it, and evaluations take every core but the driver's (was: TypeError comparing 'auto' with 1)."""
    from rlbridge.experiment.study import departures, eval_overrides, evaluation_workers

    monkeypatch.setattr(os, "cpu_count", lambda: 16)
    plan = StudyPlan(workers="auto")
    assert evaluation_workers(plan) == 15 and evaluation_workers(StudyPlan(workers=3)) == 3
    text = " ".join(departures(plan))
    assert "workers=auto (the cores the learner leaves" in text
    assert "1 rollout worker(s), one episode per iteration" in " ".join(departures(StudyPlan(workers=0)))
    assert "workers=15" in eval_overrides(plan, Path("r"), "nyc_eval_678", "greedy", "x")


@pytest.mark.skipif(__import__("torch").cuda.is_available(), reason="checks the error of a machine without CUDA")
def test_study_with_device_cuda_without_cuda_fails_before_anything_starts(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([str(ROOT / "scripts" / "reproduce_paper.sh"), "--work", str(tmp_path / "w"), "device=cuda"],
                          env=env, check=False, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "device=cuda: CUDA is not available on this machine" in proc.stderr
    assert not (tmp_path / "w").exists()


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_smoke_study_runs_the_whole_pipeline(tmp_path):
    work = tmp_path / "study"
    run_script(["usecase.params.n_intruders=4", "env.time_limit_s=600", "--smoke", "--work", str(work),
                "--workers", "0", "--budget", "60", "--train-scenario", TINY, "--eval-scenarios", TINY], timeout=1800)
    out = work / "report"
    labels = {"D2MAV-A No Shared Layers", "D2MAV-A Shared Layers", "DDQN (RLlib update ratio)"}
    for sfx in ("", "_v1"):  # the paper's use case and the corrected variant, in separate tables
        table = rows(out / f"risk_ratio{sfx}.csv")
        names = {r["Algorithm"].split(" — ")[0] for r in table}
        sampled = {"D2MAV-A No Shared Layers, sampled actions", "D2MAV-A Shared Layers, sampled actions",
                   "DDQN (RLlib update ratio), epsilon-greedy 0.05"}  # a value-based policy's "sampled" evaluation is named as what it is
        assert names == labels | sampled | {"MVP speed-only (rule-based)", "DAA speed-only (DO-365/DAIDALUS)"}
        for r in table:  # two training seeds x two evaluation episodes per learned row
            expected = "(n=2)" if r["Algorithm"].startswith(("MVP", "DAA")) else "(n=4)"
            assert expected in r["Risk Ratio - tiny_conflict"]
            assert r["parked at time limit - tiny_conflict"] != "n/a"
    training = rows(out / "training.csv")
    assert sorted(r["Algorithm"] for r in training) == sorted(
        [lb for lb in labels for _ in range(2)] + [f"{lb} [v1]" for lb in labels for _ in range(2)])
    for r in training:  # the equal budget: no run stops before it (iterations are whole episodes)
        assert int(r["aircraft-states"].replace(",", "")) >= 60
    assert (out / "reward_curve.png").read_bytes()[:4] == b"\x89PNG"
    report = (out / "report.md").read_text()  # every departure from the paper named where the ratios are read
    assert report.count("**Departures from the paper in these results:**") == 4  # 2 ratio tables x 2 variants
    assert "training budget: 60 aircraft-states per run" in report and "epsilon 0.05" in report
    paper = (out / "paper.md").read_text()
    assert "quoted, not measured here" in paper and "0.0107 ± 0.0343" in paper and "0.4875 ± 0.0303" in paper
    index = json.loads((out / "study.json").read_text())
    assert index["plan"]["smoke"] and len(index["training_runs"]) == 12 and len(index["evaluations"]) == 24
    configs = sorted((out / "configs").rglob("resolved_config.yaml"))
    assert len(configs) == 12 + 24
    for f in out.rglob("*"):  # nothing written for committing names a path of this machine
        if f.is_file() and f.suffix in (".md", ".csv", ".json", ".yaml"):
            text = f.read_text()
            assert str(tmp_path) not in text and str(ROOT) not in text, f
    # A second start finds every run done and only rewrites the report.
    proc = run_script(["usecase.params.n_intruders=4", "env.time_limit_s=600", "--smoke", "--work", str(work),
                       "--workers", "0", "--budget", "60", "--train-scenario", TINY, "--eval-scenarios", TINY],
                      timeout=600)
    assert "training d2mava_a" not in proc.stderr + proc.stdout


def _tiny_plan(**kw) -> StudyPlan:
    plan = StudyPlan(contenders=["d2mava_a"], usecases=["corridor_sa"], seeds=[0], budget=200,
                     train_scenario=str(ROOT / TINY), eval_scenarios=[str(ROOT / TINY)], episodes=1, baselines=[],
                     actions=["greedy"], workers=0, best_window=2, smooth=1,
                     overrides=["usecase.params.n_intruders=4", "env.time_limit_s=300", "train.checkpoint_every=1",
                                "train.baseline_episodes=1"])
    for k, v in kw.items():
        setattr(plan, k, v)
    return plan


def _train_until_the_session_ends(monkeypatch, plan: StudyPlan, work: Path, out: Path) -> None:
    """The study's training stage, cut right after the last checkpoint of iteration 2 (the slice ends)."""
    from rlbridge.experiment import study as study_module
    from rlbridge.experiment import train as train_module

    real_save = train_module.save_checkpoint

    def save_then_stop(path, learner, state, meta):
        real_save(path, learner, state, meta)
        if path.name == "last.pt" and state.iteration == 2:
            raise KeyboardInterrupt  # the session ends here
    with monkeypatch.context() as m:
        m.setattr(train_module, "save_checkpoint", save_then_stop)
        with pytest.raises(KeyboardInterrupt):
            study_module.run_study(plan, work, out, ("train",))


def test_a_study_interrupted_inside_a_training_run_continues_it_exactly(tmp_path, monkeypatch):
    """A slice of the study ends in the middle of a run; the next slice continues from its last checkpoint
    and ends where an uninterrupted run ends (same curve, same best policy); finished runs are exported."""
    import numpy as np

    from rlbridge.experiment import study as study_module

    plan = _tiny_plan()
    whole = study_module.run_study(plan, tmp_path / "whole", tmp_path / "whole_out", ("train",))
    assert whole["training_runs"] == ["train/corridor_sa/d2mava_a_s0"] and whole["evaluations"] == []
    curve_whole = rows(tmp_path / "whole" / "train/corridor_sa/d2mava_a_s0/learning_curve.csv")
    assert len(curve_whole) >= 3

    _train_until_the_session_ends(monkeypatch, plan, tmp_path / "cut", tmp_path / "cut_out")
    run = tmp_path / "cut" / "train/corridor_sa/d2mava_a_s0"
    assert not (run / "training_summary.json").exists() and len(rows(run / "learning_curve.csv")) == 2
    study_module.run_study(plan, tmp_path / "cut", tmp_path / "cut_out", ("train",))
    curve_cut = rows(run / "learning_curve.csv")
    assert [r["iteration"] for r in curve_cut] == [r["iteration"] for r in curve_whole]
    for a, b in zip(curve_cut, curve_whole):
        assert a["reward_mean"] == b["reward_mean"] and a["aircraft_states_total"] == b["aircraft_states_total"]
    exported = tmp_path / "cut_out" / "runs/corridor_sa/d2mava_a_s0"
    assert {p.name for p in exported.iterdir()} >= {"policy.npz", "policy.json", "learning_curve.csv",
                                                     "training_summary.json", "resolved_config.yaml"}
    config = (exported / "resolved_config.yaml").read_text()
    assert "resume: null" in config and str(tmp_path) not in config
    with np.load(exported / "policy.npz") as cut, \
            np.load(tmp_path / "whole_out" / "runs/corridor_sa/d2mava_a_s0" / "policy.npz") as ref:
        assert sorted(cut.files) == sorted(ref.files)
        for k in ref.files:
            np.testing.assert_array_equal(cut[k], ref[k])
    provenance = json.loads((exported / "policy.json").read_text())["provenance"]
    assert provenance["seed"] == 0 and provenance["aircraft_states_budget"] == 200
    assert provenance["training_scenario"] == "tiny_conflict"


def _strings(x) -> list[str]:
    if isinstance(x, dict):
        return [s for v in x.values() for s in _strings(v)]
    if isinstance(x, (list, tuple)):
        return [s for v in x for s in _strings(v)]
    return [x] if isinstance(x, str) else []


def _without_wall_time(path: Path) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows(path)]


def test_a_study_continues_on_a_new_machine_from_its_committed_files(tmp_path, monkeypatch):
    """A session's work directory dies with its machine; the next session has only what was committed
    under --out. A run parked in the middle (--park) continues from there exactly; a finished run's export
    is evaluated from its plain-data weights with the figures its checkpoint gives; an exported evaluation
    is not played again, and the report reads every cost column from the committed files."""
    import shutil

    import numpy as np

    from rlbridge.experiment import evaluate as evaluate_module
    from rlbridge.experiment import study as study_module
    from rlbridge.experiment import train as train_module
    from rlbridge.experiment.train import load_checkpoint

    plan = _tiny_plan()
    whole = tmp_path / "whole"  # the reference: one machine, start to end, evaluated from its checkpoint
    study_module.run_study(plan, whole, tmp_path / "whole_out", ("train", "evaluate"))
    out = tmp_path / "committed"

    _train_until_the_session_ends(monkeypatch, plan, tmp_path / "machine1", out)
    proc = run_script(["--park", "--work", str(tmp_path / "machine1"), "--out", str(out), "--contenders", "d2mava_a",
                       "--usecases", "corridor_sa", "--seeds", "0", "--train-scenario", TINY], timeout=600)
    parked = out / "in_progress/corridor_sa/d2mava_a_s0"
    assert "parked corridor_sa/d2mava_a_s0" in proc.stdout
    assert sorted(str(p.relative_to(parked)) for p in parked.rglob("*") if p.is_file()) == [
        "baseline.json", "checkpoints/best.pt", "checkpoints/last.pt", "learning_curve.csv", "resolved_config.yaml"]
    for name in ("last.pt", "best.pt"):  # no path of this machine, in the files or in the checkpoints
        ckpt = load_checkpoint(parked / "checkpoints" / name)
        assert not [t for t in _strings(ckpt) if str(tmp_path) in t or str(ROOT) in t], name
        assert ckpt["run_dir"] == "train/corridor_sa/d2mava_a_s0"
    assert load_checkpoint(parked / "checkpoints" / "last.pt")["state"]["iteration"] == 2
    for name in ("baseline.json", "learning_curve.csv", "resolved_config.yaml"):
        assert str(tmp_path) not in (parked / name).read_text()
    shutil.rmtree(tmp_path / "machine1")

    study_module.run_study(plan, tmp_path / "machine2", out, ("train",))  # continues from the parked copy
    run_id = "corridor_sa/d2mava_a_s0"
    curve, curve_whole = (rows(d / "train" / run_id / "learning_curve.csv") for d in (tmp_path / "machine2", whole))
    assert [(r["iteration"], r["reward_mean"], r["aircraft_states_total"]) for r in curve] == \
        [(r["iteration"], r["reward_mean"], r["aircraft_states_total"]) for r in curve_whole]
    assert not parked.exists()  # the export replaces the parked copy
    with np.load(out / "runs" / run_id / "policy.npz") as got, \
            np.load(tmp_path / "whole_out" / "runs" / run_id / "policy.npz") as ref:
        for k in ref.files:
            np.testing.assert_array_equal(got[k], ref[k])
    shutil.rmtree(tmp_path / "machine2")

    index = study_module.run_study(plan, tmp_path / "machine3", out, ("evaluate",))  # from the export only
    assert index["training_runs"] == [f"train/{run_id}"] and index["evaluations"] == [f"eval/{run_id}/tiny_conflict_greedy"]
    assert _without_wall_time(out / "evaluations" / run_id / "tiny_conflict_greedy" / "episodes.csv") == \
        _without_wall_time(whole / "eval" / run_id / "tiny_conflict_greedy" / "episodes.csv")
    shutil.rmtree(tmp_path / "machine3")

    def must_not_run(*args, **kwargs):
        raise AssertionError("played again what is committed")
    monkeypatch.setattr(evaluate_module, "run_evaluation", must_not_run)
    monkeypatch.setattr(train_module, "run_training", must_not_run)
    index = study_module.run_study(plan, tmp_path / "machine4", out, ("train", "evaluate", "report"))
    assert index["evaluations"] == [f"eval/{run_id}/tiny_conflict_greedy"]
    # The tables from the committed files are the tables from the per-episode folders of the reference.
    from rlbridge.experiment.report import make_report

    make_report([whole / "eval" / run_id / "tiny_conflict_greedy"], [whole / "train" / run_id], tmp_path / "ref")
    for name in ("risk_ratio.csv", "lowc_ratio.csv", "operational.csv", "nmac_encounters.csv"):
        assert (out / name).read_text() == (tmp_path / "ref" / name).read_text(), name
    learned = next(r for r in rows(out / "risk_ratio.csv") if r["Algorithm"].startswith("D2MAV-A No Shared"))
    assert learned["flights holding [%] - tiny_conflict"] == "50.0"  # not in episodes.csv: from episode_metrics.csv
    assert learned["parked at time limit - tiny_conflict"] == "1.00"


def test_a_parked_checkpoint_names_a_shipped_scenario_by_name(tmp_path):
    """A study run from another checkout (a worktree) trains on that checkout's copy of a shipped scenario:
    the parked checkpoint names it by its name, which every machine resolves, not by that checkout's path."""
    from aamsim.scenarios import resolve_scenario
    from rlbridge.experiment.study import _portable_scenario

    copy = tmp_path / "other-checkout" / "aamsim" / "scn" / "nyc_train_100.scn"
    copy.parent.mkdir(parents=True)
    copy.write_bytes(Path(resolve_scenario("nyc_train_100")).read_bytes())
    assert _portable_scenario(tmp_path / "work", str(copy)) == "nyc_train_100"
    copy.write_text(copy.read_text() + "\n00:00:00.00>ECHO edited\n")  # no longer the shipped file
    assert _portable_scenario(tmp_path / "work", str(copy)) == str(copy)


def test_baseline_episodes_are_played_once_per_study_and_ddqn_sampled_means_epsilon_005(tmp_path, monkeypatch):
    """The greedy and the sampled evaluation of a run share the unequipped episodes (cached, keyed by the code's
    commit); a DDQN's sampled evaluation is epsilon-greedy 0.05 (before: its training's final 1e-4, i.e. greedy)."""
    from rlbridge.experiment import study as study_module
    from rlbridge.experiment import train as train_module

    monkeypatch.setattr(train_module, "code_version", lambda: {"aamsim": "test", "commit": "f" * 40})
    plan = _tiny_plan(contenders=["ddqn"], actions=["greedy", "sampled"], baselines=["mvp_speed"], episodes=2)
    index = study_module.run_study(plan, tmp_path / "work", tmp_path / "out", ("train", "evaluate"))
    assert len(index["evaluations"]) == 2
    greedy, sampled = (json.loads((tmp_path / "work" / e / "evaluation.json").read_text()) for e in index["evaluations"])
    assert greedy["explore"] == {"epsilon": 0.0} and sampled["explore"] == {"epsilon": 0.05}
    assert sampled["policies"]["ddqn"]["label"] == "DDQN (RLlib update ratio), epsilon-greedy 0.05"
    cache = tmp_path / "work" / "baselines"
    kinds = sorted(d.name.split("-")[0] for d in cache.iterdir())
    # One entry per baseline (the sampled evaluation reused unequipped); the policy's greedy and sampled
    # episodes are two (they act differently).
    assert kinds == ["dqn", "dqn", "mvp_speed", "unequipped"]
    for e in index["evaluations"]:  # the very same unequipped episodes in both evaluations
        assert (tmp_path / "work" / e / "episodes/unequipped/seed-0000/summary.json").read_text() == \
            (tmp_path / "work" / index["evaluations"][0] / "episodes/unequipped/seed-0000/summary.json").read_text()
    assert len(list(next(d for d in cache.iterdir() if d.name.startswith("unequipped")).glob("seed-*.json"))) == 2
    # Each finished evaluation is exported for committing: its summary, episode table and configuration,
    # naming no path of this machine, and the summary's figures are the work directory's.
    for e in index["evaluations"]:
        exported = tmp_path / "out" / "evaluations" / Path(e).relative_to("eval")
        assert sorted(p.name for p in exported.iterdir()) == ["episode_metrics.csv", "episodes.csv",
                                                              "evaluation.json", "resolved_config.yaml"]
        for f in exported.iterdir():
            assert str(tmp_path) not in f.read_text(), f
        assert exported.joinpath("episodes.csv").read_text() == (tmp_path / "work" / e / "episodes.csv").read_text()
        ours, theirs = (json.loads(p.read_text()) for p in (exported / "evaluation.json",
                                                             tmp_path / "work" / e / "evaluation.json"))
        assert ours["policies"] == theirs["policies"] and ours["checkpoint"] != theirs["checkpoint"]


def test_an_interrupted_evaluation_resumes_with_the_episodes_it_had_finished(tmp_path, monkeypatch):
    """A slice of the study ends inside an evaluation, after two of the policy's three episodes: the next
    slice plays only the third (and what had not started), and both evaluations end exactly as an
    uninterrupted study's do, the sampled one included (each episode draws from its own seed)."""
    import shutil

    import numpy as np

    from rlbridge.experiment import evaluate as evaluate_module
    from rlbridge.experiment import study as study_module
    from rlbridge.experiment import train as train_module
    from rlbridge.experiment.workers import InProcessPool

    monkeypatch.setattr(train_module, "code_version", lambda: {"aamsim": "test", "commit": "e" * 40})
    plan = _tiny_plan(actions=["greedy", "sampled"], episodes=3)
    study_module.run_study(plan, tmp_path / "whole", tmp_path / "whole_out", ("train",))
    shutil.copytree(tmp_path / "whole", tmp_path / "cut")  # the same trained run in both work folders
    whole = study_module.run_study(plan, tmp_path / "whole", tmp_path / "whole_out", ("evaluate",))

    real_store, stored = evaluate_module.store_cached_episode, []

    def store_then_stop(cache, stats):
        real_store(cache, stats)
        stored.append(cache.name.split("-")[0])
        if stored.count("d2mava") == 2:
            raise KeyboardInterrupt  # the session ends here
    with monkeypatch.context() as m:
        m.setattr(evaluate_module, "store_cached_episode", store_then_stop)
        with pytest.raises(KeyboardInterrupt):
            study_module.run_study(plan, tmp_path / "cut", tmp_path / "cut_out", ("evaluate",))

    played: list[tuple[str, list[int]]] = []
    real_map = InProcessPool.map_episodes

    def record(self, seeds, actor, *args, **kw):
        played.append((actor, list(seeds)))
        return real_map(self, seeds, actor, *args, **kw)
    monkeypatch.setattr(InProcessPool, "map_episodes", record)
    cut = study_module.run_study(plan, tmp_path / "cut", tmp_path / "cut_out", ("evaluate",))
    assert played == [("d2mava_a", [2]), ("unequipped", [0, 1, 2]),  # the greedy evaluation, resumed
                      ("d2mava_a", [0, 1, 2])]  # the sampled one: its own episodes; unequipped's reused
    assert cut["evaluations"] == whole["evaluations"] == ["eval/corridor_sa/d2mava_a_s0/tiny_conflict_greedy",
                                                          "eval/corridor_sa/d2mava_a_s0/tiny_conflict_sampled"]
    for e in whole["evaluations"]:
        assert _without_wall_time(tmp_path / "cut" / e / "episodes.csv") == \
            _without_wall_time(tmp_path / "whole" / e / "episodes.csv")
    greedy = rows(tmp_path / "whole" / whole["evaluations"][0] / "episodes.csv")
    assert [r["seed"] for r in greedy if r["policy"] == "d2mava_a"] == ["0", "1", "2"]
    # Changed weights are another policy: nothing of the old one is reused.
    weights = {"w": np.zeros(3, dtype=np.float32)}
    spec = {"kind": "d2mava"}
    assert evaluate_module.episode_cache_spec(spec, weights, {"greedy": True}) != \
        evaluate_module.episode_cache_spec(spec, {"w": np.ones(3, dtype=np.float32)}, {"greedy": True})
    assert evaluate_module.episode_cache_spec(spec, weights, {"greedy": True}) != \
        evaluate_module.episode_cache_spec(spec, weights, {"greedy": False})
    assert evaluate_module.episode_cache_spec(spec, None, {}) == spec  # a baseline's key as before


def test_the_reference_scores_table_has_every_use_case_its_baselines_and_intervals(tmp_path):
    """`aamgym scores` as a user runs it (tiny traffic, 2 seeds): one row per contender that fits each use case."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "scores", "--usecases", "corridor_sa",
                           "reach_destination", "--scenario", str(ROOT / TINY), "--episodes", "2",
                           "--work", str(tmp_path / "work"), "--out", str(tmp_path / "out")],
                          env=env, capture_output=True, text=True, timeout=1800, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    table = rows(tmp_path / "out" / "scores.csv")
    got = [(r["environment"], r["contender"]) for r in table]
    from rlbridge.pretrained import available, load

    def learned(usecase: str) -> list[tuple[str, str]]:  # the shipped policies' rows, as the package holds them
        env_name = {"corridor_sa": "aamgym/CorridorSA-v1", "reach_destination": "aamgym/ReachDestination-v1"}[usecase]
        return [(env_name, f"{load(n).exported.label} (pretrained `{n}`)") for n in available()
                if load(n).usecase == usecase]

    assert learned("corridor_sa") and learned("reach_destination")  # at least one learned contender each
    assert got == [("aamgym/CorridorSA-v1", "Unequipped"), ("aamgym/CorridorSA-v1", "MVP speed-only (rule-based)"),
                   ("aamgym/CorridorSA-v1", "DAA speed-only (DO-365/DAIDALUS)"), *learned("corridor_sa"),
                   ("aamgym/ReachDestination-v1", "Unequipped"),
                   ("aamgym/ReachDestination-v1", "DAA speed-only (DO-365/DAIDALUS)"), *learned("reach_destination")]
    assert all(r["episodes"] == "2" for r in table)
    # Every scheduled flight in a column: no planner here, so none is left on the ground.
    assert all(r["flights not departed"] == "0.0 ± 0.0" for r in table)
    assert " ± " in table[0]["NMAC / episode"] or table[0]["NMAC / episode"].count(".") == 1
    md = (tmp_path / "out" / "scores.md").read_text()
    assert "aamgym scores --usecases corridor_sa reach_destination" in md and str(tmp_path) not in md
    bad = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "scores", "--usecases", "nope"], env=env,
                         capture_output=True, text=True, timeout=300, check=False)
    assert bad.returncode == 2 and "unknown use case(s) nope" in bad.stderr

    # One more row, a researcher's exported policy (here a copy of a shipped one), on the table's own seeds:
    # inserted after its environment's rows, the others kept as they were, its figures those of the same
    # weights' row (same seeds, same episodes).
    import shutil

    from rlbridge.pretrained import policy_dir

    mine = tmp_path / "my_policy"
    shutil.copytree(policy_dir("d2mava_a"), mine)
    add = [sys.executable, "-m", "rlbridge.experiment", "scores", "--work", str(tmp_path / "work"),
           "--out", str(tmp_path / "out"), "--add"]
    proc = subprocess.run([*add, str(mine)], env=env, capture_output=True, text=True, timeout=1800, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    after = rows(tmp_path / "out" / "scores.csv")
    corridor = [k for k, r in enumerate(table) if r["environment"] == "aamgym/CorridorSA-v1"]
    new_row = after[corridor[-1] + 1]
    assert new_row["contender"] == "D2MAV-A No Shared Layers (`my_policy`)"
    assert after[:corridor[-1] + 1] + after[corridor[-1] + 2:] == table
    shipped = next(r for r in table if r["contender"] == "D2MAV-A No Shared Layers (pretrained `d2mava_a`)")
    assert {k: v for k, v in new_row.items() if k != "contender"} == \
        {k: v for k, v in shipped.items() if k != "contender"}
    md = (tmp_path / "out" / "scores.md").read_text()
    assert "by `aamgym scores --add <exported policy folder my_policy>`" in md and str(tmp_path) not in md
    # Added again: replaced, not doubled.
    proc = subprocess.run([*add, str(mine)], env=env, capture_output=True, text=True, timeout=1800, check=False)
    assert proc.returncode == 0 and rows(tmp_path / "out" / "scores.csv") == after
    assert (tmp_path / "out" / "scores.md").read_text().count("Row added later") == 1
    # Nothing to add to, or conditions of its own: refused with what to do.
    none = subprocess.run([*add[:-3], "--out", str(tmp_path / "empty"), "--add", str(mine)], env=env,
                          capture_output=True, text=True, timeout=300, check=False)
    assert none.returncode == 2 and "no scores table to add a row to" in none.stderr
    own = subprocess.run([*add, str(mine), "--episodes", "5"], env=env, capture_output=True, text=True,
                         timeout=300, check=False)
    assert own.returncode == 2 and "the table's own scenario, seeds and episodes" in own.stderr


def test_code_version_is_dirty_for_changed_package_sources_not_for_results_written_beside_them(tmp_path):
    """A study writes its results into the checkout it runs from; those files (and a removed parked
    checkpoint) must not mark its runs "+dirty" or switch the baseline cache off. A changed source file must."""
    from rlbridge.experiment.train import code_version

    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(tmp_path), *args], capture_output=True, text=True,
                              check=True).stdout.strip()

    git("init", "-q")
    (tmp_path / "aamsim").mkdir()
    (tmp_path / "aamsim" / "kernel.py").write_text("x = 1\n")
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "study.json").write_text("{}\n")
    (tmp_path / "docs" / "parked.pt").write_text("weights\n")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@example.org", "commit", "-q", "-m", "start")
    head = git("rev-parse", "HEAD")
    assert code_version(tmp_path)["commit"] == head

    (tmp_path / "docs" / "study.json").write_text('{"runs": 1}\n')
    (tmp_path / "docs" / "parked.pt").unlink()
    (tmp_path / "docs" / "new_eval.json").write_text("{}\n")
    assert code_version(tmp_path)["commit"] == head

    (tmp_path / "aamsim" / "kernel.py").write_text("x = 2\n")
    assert code_version(tmp_path)["commit"] == head + "+dirty"
