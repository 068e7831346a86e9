"""aamgym checks every job's configuration against the dataclasses before anything starts (issue 30).

A wrong type or an unknown key is one line naming the key, exit status 2, no Ray, no run directory.
The checks come from the dataclasses' fields, so a field added to a learner's or a use case's
dataclass is accepted and type-checked with no other edit.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import typing
from pathlib import Path

import pytest

pytest.importorskip("hydra", reason="aamgym needs the rl extra")
pytest.importorskip("torch", reason="aamgym needs the rl extra")

from rlbridge.agents.d2mava import D2MAVAConfig
from rlbridge.agents.ddqn import DDQNConfig
from rlbridge.experiment.preflight import check_job, preflight, sweep_points
from rlbridge.experiment.schema import check_mapping, check_value, describe
from rlbridge.usecases.registry import available, usecase_spec

ROOT = Path(__file__).resolve().parent.parent
TINY = str(ROOT / "tests" / "data" / "tiny_conflict.scn")


def aamgym(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "rlbridge.experiment", *args], cwd=cwd, capture_output=True,
                          text=True, env=env, timeout=600, check=False)


# ---- end to end: the command line ------------------------------------------------------------------


def test_a_wrong_type_is_one_error_naming_the_key_before_anything_starts(tmp_path):
    proc = aamgym("train", "algorithm=ddqn", "train.iterations=abc", f"out_dir={tmp_path / 'runs'}", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == ["aamgym train: error: train.iterations=abc: expected an integer or null"]
    assert list(tmp_path.iterdir()) == []  # no run directory, no outputs/ of Hydra's
    assert "Ray" not in proc.stdout + proc.stderr


def test_an_unknown_learner_parameter_lists_the_learners_keys_and_a_sweep_is_checked_point_by_point(tmp_path):
    proc = aamgym("train", "--multirun", "algorithm=d2mava_a,ddqn", "algorithm.params.epochs=3",
                  f"out_dir={tmp_path / 'runs'}", cwd=tmp_path)
    assert proc.returncode == 2
    (line,) = proc.stderr.strip().splitlines()
    known = ", ".join(sorted(f.name for f in dataclasses.fields(DDQNConfig)))
    assert line == f"aamgym train: error: algorithm.params.epochs: unknown key; known: {known}"
    assert list(tmp_path.iterdir()) == []


def test_evaluate_names_the_missing_scenario_and_run(tmp_path):
    proc = aamgym("evaluate", f"run={tmp_path / 'nothing'}", "scenario=no_such_scenario", cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert "aamgym evaluate: error: scenario=no_such_scenario: not found" in lines[0]
    assert lines[1] == f"aamgym evaluate: error: run={tmp_path / 'nothing'}: no such training run or checkpoint file"


# ---- in process: composition and schema ---------------------------------------------------------------


@pytest.mark.parametrize("algorithm", ["d2mava_a", "d2mava_a_shared", "ddqn", "ddqn_per_transition", "dqn"])
def test_every_shipped_configuration_passes(algorithm):
    for usecase in ("corridor_sa", "corridor_sa_v1", "reach_destination", "strategic_planning", "hierarchical"):
        assert check_job("config", [f"algorithm={algorithm}", f"usecase={usecase}", "workers=0"]) == []
    assert check_job("evaluate", ["baseline=daa", f"scenario={TINY}", "workers=0"]) == []


@pytest.mark.parametrize(("override", "problem"), [
    ("train.foo=1", ("train.foo: unknown key; known: aircraft_states, baseline_episodes, best_window, "
                     "checkpoint_every, episodes_per_worker, hours, iterations, mode, resume, static_learner, "
                     "torch_threads")),
    ("+usecase.params.n_intruder=3", "usecase.params.n_intruder: unknown key; known: "),
    ("usecase.params.n_intruders=3.5", "usecase.params.n_intruders=3.5: expected an integer"),
    ("usecase.params.alt_noise_lanes_ft=[1,x]", "usecase.params.alt_noise_lanes_ft=[1, 'x']: expected a list of numbers"),
    ("usecase.params.variant=v9", "usecase.params: variant must be one of"),
    ("train.mode=fast", "train.mode=fast: expected one of serial, overlap"),
    ("train.torch_threads=many", "train.torch_threads=many: expected an integer or one of auto"),
    ("workers=null", "workers=null: expected an integer or one of auto"),
    ("train.static_learner=maybe", "train.static_learner=maybe: expected true or false or one of auto"),
    ("algorithm.params.lr=fast", "algorithm.params.lr=fast: expected a number"),
    ("algorithm=nope", "Could not find 'algorithm/nope'; available in 'algorithm': d2mava_a, d2mava_a_shared, ddqn, ddqn_per_transition, dqn"),
])
def test_a_bad_override_is_one_line_naming_the_key(override, problem):
    problems = check_job("config", ["workers=0", override])
    assert len(problems) == 1, problems
    assert problem in problems[0]


def test_evaluate_takes_exactly_one_subject_and_checks_a_pretrained_policy(tmp_path):
    # main's evaluate.yaml keys (policy, sampled_epsilon) are in the schema; the subject is one of three.
    base = [f"scenario={TINY}", "workers=0", "greedy=false", "sampled_epsilon=0.1"]
    assert check_job("evaluate", ["baseline=daa", *base]) == []
    exported = tmp_path / "exported"
    exported.mkdir()
    (exported / "policy.json").write_text("{}")
    assert check_job("evaluate", [f"policy={exported}", *base]) == []
    (problem,) = check_job("evaluate", ["baseline=daa", f"policy={exported}", *base])
    assert "exactly one of them is needed, not policy and baseline" in problem
    (problem,) = check_job("evaluate", [f"policy={tmp_path}", *base])
    assert problem.startswith(f"policy={tmp_path}: no pretrained policy")
    (problem,) = check_job("evaluate", ["sampled_epsilon=some", "baseline=daa", *base[:2]])
    assert problem == "sampled_epsilon=some: expected a number"
    # An unknown baseline, as the subject or among the comparisons, is a line naming it before Hydra starts.
    known = "unequipped, mvp_speed, daa, mvp, no_planning, fcfs"
    assert check_job("evaluate", ["baseline=foo", *base]) == [f"baseline=foo: unknown baseline; known: {known}"]
    assert check_job("evaluate", ["baseline=daa", "baselines=[mvp_speed,bar]", *base]) == [
        f"baselines=bar: unknown baseline; known: {known}"]
    assert check_job("evaluate", ["baseline=daa", "baselines=[mvp_speed]", *base]) == []
    # The altitude noise is evaluate's own key: the use case's would be replaced without a word.
    assert check_job("evaluate", ["baseline=daa", "usecase.params.alt_noise_ft=0", *base]) == [
        ("usecase.params.alt_noise_ft: evaluate gives the use case its own alt_noise_ft (default 100); "
         "set alt_noise_ft=... instead")]
    assert check_job("evaluate", ["baseline=daa", "usecase.params.alt_noise_lanes_ft=[500]", *base]) == [
        ("usecase.params.alt_noise_lanes_ft: evaluate gives the use case its own alt_noise_lanes_ft (default 500, "
         "1200, 1900); set alt_noise_lanes_ft=... instead")]
    assert check_job("evaluate", ["baseline=daa", "alt_noise_ft=0", *base]) == []
    assert check_job("config", ["usecase.params.alt_noise_ft=0", f"scenario={TINY}", "workers=0"]) == []
    # A trained policy plays in the use case it was trained in (its checkpoint): usecase overrides would be ignored.
    run = tmp_path / "run"
    run.mkdir()
    for subject in (f"run={run}", f"policy={exported}"):
        (problem,) = check_job("evaluate", [subject, "usecase.params.n_intruders=8", *base])
        assert problem.startswith(f"usecase.params.n_intruders: {subject.split('=')[0]}=... is evaluated in the use "
                                  "case and parameters it was trained with"), problem
    (problem,) = check_job("evaluate", [f"run={run}", "usecase=strategic_planning", *base])
    assert problem.startswith("usecase: run=... is evaluated in the use case")
    assert check_job("evaluate", [f"run={run}", "alt_noise_ft=0", *base]) == []


def test_good_overrides_of_every_kind_pass():
    assert check_job("config", ["workers=auto", "train.static_learner=true"]) == []  # main's keys and values
    assert check_job("config", ["workers=0", "train.torch_threads=auto", "train.hours=0.5", "train.iterations=3",
                                "algorithm=ddqn", "algorithm.params.lr=3e-5", "algorithm.params.double=false",
                                "usecase=reach_destination", "usecase.params.speeds_kts=[20,40]",
                                f"scenario={TINY}", "seed=7", "env.time_limit_s=600"]) == []


def test_sweeps_expand_to_every_point():
    points = sweep_points(["algorithm=ddqn,d2mava_a", "seed=0,1,2", "workers=0"], multirun=True)
    assert len(points) == 6 and ["algorithm=d2mava_a", "seed=2", "workers=0"] in points
    assert sweep_points(["seed=0,1"], multirun=False) == [["seed=0,1"]]


def test_printing_commands_and_hydra_keys_are_left_to_hydra():
    assert preflight("config", ["--cfg", "job", "train.iterations=abc"]) == []
    assert preflight("config", ["--help"]) == []
    assert preflight("config", ["hydra.run.dir=somewhere", "workers=0"]) == []


def test_what_a_job_needs_is_checked_with_the_configuration(monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # how an install without the video extra looks
    problems = check_job("evaluate", ["baseline=daa", f"scenario={TINY}", "workers=0", "video=true"])
    assert problems == [('video=true (MP4 videos) needs imageio_ffmpeg, which is not installed: '
                         'pip install "aamsim[video]"')]


# ---- generic over the dataclasses' fields -------------------------------------------------------------


WRONG = {int: "abc", float: "abc", bool: "yes", str: ["a", "list"]}


def param_classes() -> list[type]:
    classes = [DDQNConfig, D2MAVAConfig]
    classes += [usecase_spec(n).params_class for n in available()]
    return classes


@pytest.mark.parametrize("cls", param_classes(), ids=lambda c: c.__name__)
def test_every_field_accepts_its_default_and_refuses_a_wrong_type(cls):
    hints = typing.get_type_hints(cls)
    for field in dataclasses.fields(cls):
        default = field.default if field.default is not dataclasses.MISSING else (
            field.default_factory() if field.default_factory is not dataclasses.MISSING else None)
        tp = hints[field.name]
        assert check_value(default if not isinstance(default, tuple) else list(default), tp, field.name) == [], field
        if tp in WRONG:
            (problem,) = check_mapping({field.name: WRONG[tp]}, cls, "p.")
            assert problem.startswith(f"p.{field.name}=") and describe(tp) in problem


def test_a_field_added_to_a_dataclass_is_checked_with_no_other_edit():
    extended = dataclasses.make_dataclass("DDQNWithRatio", [("updates_per_step", float, 1.0)], bases=(DDQNConfig,))
    assert check_mapping({"updates_per_step": 0.25, "lr": 1e-4}, extended) == []
    assert check_mapping({"updates_per_step": "many"}, extended) == ["updates_per_step=many: expected a number"]
    assert check_mapping({"updates_per_step": 0.25}, DDQNConfig)[0].startswith("updates_per_step: unknown key")


# ---- aamgym train on a simulation server (issue 29) ---------------------------------------------------


def test_train_with_backend_zmq_refuses_a_bad_address_naming_it(tmp_path):
    proc = aamgym("train", "backend=zmq", "address=localhost:5555", f"scenario={TINY}", "workers=0",
                  f"out_dir={tmp_path / 'runs'}", cwd=tmp_path)
    assert proc.returncode == 2
    expected = ("aamgym train: error: address=localhost:5555: backend=zmq needs the simulation server's address, "
                "tcp://host:port (as `aamsim serve` prints it)")
    assert proc.stderr.strip().splitlines() == [expected]
    assert list(tmp_path.iterdir()) == []


def test_train_runs_over_a_real_simulation_server(tmp_path):
    import shutil

    from bridge_util import spawn_server, stop_process

    shutil.copy(TINY, tmp_path / "tiny_conflict.scn")
    proc, endpoint = spawn_server("--log-level", "ERROR", cwd=tmp_path)
    try:
        run = aamgym("train", "backend=zmq", f"address={endpoint}", "scenario=tiny_conflict.scn", "workers=0",
                     "train.iterations=2", "train.baseline_episodes=1", "env.time_limit_s=300", "timeout_s=600",
                     f"hydra.run.dir={tmp_path / 'run'}", cwd=tmp_path)
    finally:
        stop_process(proc)
    assert run.returncode == 0, run.stderr[-3000:]
    config = (tmp_path / "run" / "resolved_config.yaml").read_text()
    assert "backend: zmq" in config and f"address: {endpoint}" in config
    assert (tmp_path / "run" / "checkpoints" / "last.pt").is_file()
    curve = (tmp_path / "run" / "learning_curve.csv").read_text().strip().splitlines()
    assert len(curve) == 3  # a header and two iterations
