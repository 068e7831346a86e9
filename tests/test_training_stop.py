"""A stop signal ends a training run at an iteration boundary, with a checkpoint, and resuming is exact.

Ctrl-C (SIGINT) or ``kill`` (SIGTERM) during ``aamgym train`` or ``aamgym study``: the iterations already
started are learned from, ``last.pt`` is written even between periodic checkpoints, the run is not marked
finished, and ``train.resume`` ends where an uninterrupted run ends.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("torch", reason="training needs the rl extra")

from rlbridge.experiment import train as train_module
from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.train import TrainingStopped, load_checkpoint, run_training

ROOT = Path(__file__).resolve().parent.parent
TINY = str(ROOT / "tests" / "data" / "tiny_conflict.scn")
# checkpoint_every=10: no periodic last.pt in these 4 iterations, so only the stop can write one.
QUICK = [f"scenario={TINY}", "workers=0", "env.time_limit_s=300", "usecase.params.n_intruders=4",
         "train.baseline_episodes=1", "train.iterations=4", "train.checkpoint_every=10", "algorithm=d2mava_a"]


def curve(run: Path) -> list[dict[str, str]]:
    with open(run / "learning_curve.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("mode", ["serial", "overlap"])
def test_a_stop_signal_ends_the_run_at_an_iteration_boundary_and_resume_is_exact(tmp_path, monkeypatch, mode):
    cfg = compose_config("config", overrides=[*QUICK, f"train.mode={mode}"])
    run_training(cfg, tmp_path / "whole")
    whole = curve(tmp_path / "whole")
    assert [r["iteration"] for r in whole] == ["1", "2", "3", "4"]

    real_record = train_module.record_iteration

    def record_then_signal(run, *args):
        real_record(run, *args)
        if run.state.iteration == 2:
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C, right after iteration 2 was recorded

    before = signal.getsignal(signal.SIGINT)
    with monkeypatch.context() as m:
        m.setattr(train_module, "record_iteration", record_then_signal)
        with pytest.raises(TrainingStopped) as stopped:
            run_training(cfg, tmp_path / "cut")
    assert signal.getsignal(signal.SIGINT) is before  # the handler is put back
    # serial: nothing else had started; overlap: iteration 3 was being played already, and is learned from.
    done = 2 if mode == "serial" else 3
    assert (stopped.value.iteration, stopped.value.signal_name) == (done, "SIGINT")
    cut = tmp_path / "cut"
    assert len(curve(cut)) == done and not (cut / "training_summary.json").exists()
    assert load_checkpoint(cut / "checkpoints" / "last.pt")["state"]["iteration"] == done

    resumed = compose_config("config", overrides=[*QUICK, f"train.mode={mode}", f"train.resume={cut}"])
    summary = run_training(resumed, cut)
    assert summary["iterations"] == 4 and summary["stopped_by"] == "iterations"
    again = curve(cut)
    assert [r["iteration"] for r in again] == ["1", "2", "3", "4"]
    for a, b in zip(again, whole):
        assert (a["reward_mean"], a["aircraft_states_total"], a["episode_rewards"]) == \
            (b["reward_mean"], b["aircraft_states_total"], b["episode_rewards"])
    ours, theirs = (load_checkpoint(r / "checkpoints" / "last.pt")["learner"]["model"] for r in (cut, tmp_path / "whole"))
    assert sorted(ours) == sorted(theirs)
    for k in ours:
        assert ours[k].equal(theirs[k]), k


def test_a_spent_budget_is_a_finished_run_even_when_a_stop_was_asked_for(tmp_path, monkeypatch):
    """A signal during the last iteration: the run is finished (its summary), not stopped."""
    real_record = train_module.record_iteration

    def record_then_signal(run, *args):
        real_record(run, *args)
        if run.state.iteration == 4:
            os.kill(os.getpid(), signal.SIGTERM)
    monkeypatch.setattr(train_module, "record_iteration", record_then_signal)
    summary = run_training(compose_config("config", overrides=[*QUICK, "train.mode=serial"]), tmp_path / "run")
    assert summary["stopped_by"] == "iterations" and (tmp_path / "run" / "training_summary.json").exists()


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_aamgym_train_stops_on_a_signal_with_status_130_and_says_how_to_continue(tmp_path, signum):
    """The command as a user runs it, stopped from outside once its first iteration is logged: by ``kill``,
    and by ``kill -INT`` as a background job (started with SIGINT ignored)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run_dir = tmp_path / "run"
    cmd = [sys.executable, "-m", "rlbridge.experiment", "train", *QUICK[:-3], "train.iterations=100000",
           "train.checkpoint_every=1000", "algorithm=d2mava_a", f"hydra.run.dir={run_dir}"]
    if signum == signal.SIGINT:  # what a shell does to a job it starts in the background
        cmd = ["sh", "-c", 'trap "" INT; exec "$@"', "sh", *cmd]
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    deadline = time.monotonic() + 600
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            if " - it 1 |" in line:
                proc.send_signal(signum)
                break
            assert time.monotonic() < deadline, "".join(lines[-20:])
        rest, _ = proc.communicate(timeout=600)  # a run that ignores the signal fails here, not hangs
        lines.append(rest)
        rc = proc.returncode
    finally:
        if proc.poll() is None:
            proc.kill()
    text = "".join(lines)
    assert rc == 130, text[-3000:]
    assert f"{signal.Signals(signum).name}: stopping once the iterations already started are learned from" in text
    assert f"continue with train.resume={run_dir}" in text and "Traceback" not in text
    state = load_checkpoint(run_dir / "checkpoints" / "last.pt")["state"]
    assert state["iteration"] >= 1 and len(curve(run_dir)) == state["iteration"]
    assert not (run_dir / "training_summary.json").exists()


def test_aamgym_study_stopped_in_a_run_exits_130_naming_the_run(tmp_path, monkeypatch, capsys):
    from rlbridge.experiment import study as study_module

    work = tmp_path / "work"

    def stopped(plan, work_dir, out, stages):
        raise TrainingStopped(work_dir / "train" / "corridor_sa" / "d2mava_a_s0", 7, "SIGINT")
    monkeypatch.setattr(study_module, "run_study", stopped)
    with pytest.raises(SystemExit) as end:
        study_module.main(["--work", str(work), "--out", str(tmp_path / "out"), "--stages", "train"])
    assert end.value.code == 130
    err = capsys.readouterr().err
    assert "study stopped by SIGINT after iteration 7 of train/corridor_sa/d2mava_a_s0: the same command " \
           "continues it from there" in err


def test_a_stop_signal_during_the_baseline_episodes_stops_before_the_first_iteration(tmp_path, monkeypatch):
    """``kill`` while the unequipped baseline is played: the baseline is finished and kept, no iteration is
    started, ``last.pt`` holds iteration 0, and resuming trains the whole run without playing it again."""
    cfg = compose_config("config", overrides=[*QUICK, "train.mode=serial"])
    run_training(cfg, tmp_path / "whole")
    real_baseline = train_module.play_baseline
    played = []

    def signal_then_baseline(run, pool):
        os.kill(os.getpid(), signal.SIGTERM)  # arrives while the baseline episodes are being played
        real_baseline(run, pool)
        played.append(run.run_dir)

    with monkeypatch.context() as m:
        m.setattr(train_module, "play_baseline", signal_then_baseline)
        with pytest.raises(TrainingStopped) as stopped:
            run_training(cfg, tmp_path / "cut")
    cut = tmp_path / "cut"
    assert played == [cut]
    assert (stopped.value.iteration, stopped.value.signal_name) == (0, "SIGTERM")
    baseline, whole_baseline = (json.loads((r / "baseline.json").read_text()) for r in (cut, tmp_path / "whole"))
    assert baseline.pop("wall_s") > 0 and whole_baseline.pop("wall_s") > 0
    assert baseline == whole_baseline  # the same episodes
    assert curve(cut) == [] and not (cut / "training_summary.json").exists()
    assert load_checkpoint(cut / "checkpoints" / "last.pt")["state"]["iteration"] == 0

    baseline_written = (cut / "baseline.json").stat().st_mtime_ns
    summary = run_training(compose_config("config", overrides=[*QUICK, "train.mode=serial", f"train.resume={cut}"]),
                           cut)
    assert summary["iterations"] == 4 and summary["stopped_by"] == "iterations"
    assert (cut / "baseline.json").stat().st_mtime_ns == baseline_written  # not played again
    for a, b in zip(curve(cut), curve(tmp_path / "whole"), strict=True):
        assert (a["reward_mean"], a["aircraft_states_total"], a["episode_rewards"]) == \
            (b["reward_mean"], b["aircraft_states_total"], b["episode_rewards"])
