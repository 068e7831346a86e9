"""``aamgym train/evaluate/report`` on the strategic planning use case, run as a user would (subprocesses)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CROSS = str(Path(__file__).parent / "data" / "strategic_cross.scn")
SMALL = ["usecase=strategic_planning", f"scenario={CROSS}", "workers=0", "usecase.params.layers_ft=[]",
         "usecase.params.max_delay_slots=2"]


def aamgym(args: list[str], cwd: Path, ok: bool = True) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", *args], cwd=cwd, env=env, check=False,
                          capture_output=True, text=True, timeout=600)
    if ok:
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def test_ddqn_planner_train_evaluate_report(tmp_path):
    aamgym(["train", *SMALL, "algorithm=ddqn", "train.iterations=3", "train.baseline_episodes=1",
            "train.best_window=2", "algorithm.params.learning_starts=4", "algorithm.params.batch_size=8",
            "algorithm.params.eps_decay_steps=20", "algorithm.params.target_update=8",
            # one gradient step per environment step (a planner episode has a handful of decisions)
            "algorithm.params.rllib_num_workers=1", "algorithm.params.rollout_fragment_length=1",
            "hydra.run.dir=train"],
           tmp_path)
    run = tmp_path / "train"
    with open(run / "learning_curve.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["iteration"]) for r in rows] == [1, 2, 3]
    assert all(int(r["aircraft_states"]) == 4 for r in rows)  # one decision per request
    assert float(rows[-1]["gradient_steps"]) > 0
    aamgym(["evaluate", f"run={run}", "episodes=2", "workers=0", "hydra.run.dir=eval"], tmp_path)
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    assert set(ev["policies"]) == {"ddqn", "unequipped", "no_planning", "fcfs"}
    pol = ev["policies"]
    # FCFS: the hand-computed plan (tests/test_strategic.py) on every seed; no planning meets.
    assert pol["fcfs"]["nmac_events"] == {"mean": 0.0, "std": 0.0}
    assert pol["no_planning"]["nmac_events"]["mean"] > 0
    assert pol["no_planning"]["nmac_events"] == pol["unequipped"]["nmac_events"]
    assert pol["fcfs"]["risk_ratio"]["mean"] == 0.0
    summary = json.loads(next((tmp_path / "eval" / "episodes" / "fcfs").glob("seed-*/summary.json")).read_text())
    assert summary["strategic_planning"]["unplaced_flights"] == ["N3"]
    assert summary["strategic_planning"]["mean_delay_s"] == 60.0
    aamgym(["report", "eval", "--train", "train", "-o", "report"], tmp_path)
    with open(tmp_path / "report" / "planning.csv", newline="") as fh:
        table = {r["Algorithm"]: r for r in csv.DictReader(fh)}
    assert set(table) == {"DDQN (RLlib update ratio)", "Unequipped", "No planning (depart on schedule)", "FCFS strategic deconfliction"}
    fcfs = table["FCFS strategic deconfliction"]
    assert (fcfs["unplaced"], fcfs["mean delay [s]"], fcfs["flights planned"]) == ("1.00 ± 0.00", "60.0 ± 0.0",
                                                                                     "3.0 ± 0.0")
    assert "### Strategic planning" in (tmp_path / "report" / "report.md").read_text()
    # Bad baseline names: a clear error listing the known ones; one that does not apply, its own.
    proc = aamgym(["evaluate", f"run={run}", "episodes=1", "workers=0", "baselines=[dax]", "hydra.run.dir=e2"],
                  tmp_path, ok=False)
    assert proc.returncode == 2
    assert "baselines=dax: unknown baseline; known: unequipped, mvp_speed, daa, mvp, no_planning, fcfs" in proc.stderr
    proc = aamgym(["evaluate", f"run={run}", "episodes=1", "workers=0", "baselines=[mvp_speed]",
                   "hydra.run.dir=e3"], tmp_path, ok=False)
    assert "baseline 'mvp_speed' does not apply to use case strategic_planning; its baselines: unequipped, " \
           "no_planning, fcfs" in proc.stderr


def test_unknown_use_case_and_parameter_from_the_cli(tmp_path):
    proc = aamgym(["train", "usecase=strategic", "workers=0", "--cfg", "job"], tmp_path, ok=False)
    assert proc.returncode != 0
    err = proc.stderr
    assert "usecase/strategic" in err and "strategic_planning" in err and "hierarchical" in err
    proc = aamgym(["train", *SMALL, "+usecase.params.slots_s=30", "algorithm=ddqn", "train.iterations=1",
                   "train.baseline_episodes=0", "hydra.run.dir=t"], tmp_path, ok=False)
    # Checked before anything starts (issue 30): one line naming the key, exit 2, no run directory.
    assert proc.returncode == 2 and not (tmp_path / "t").exists()
    assert "usecase.params.slots_s: unknown key; known:" in proc.stderr and "slot_s" in proc.stderr


def test_evaluation_baselines_per_use_case():
    from omegaconf import OmegaConf

    from rlbridge.agents.rollout import EnvSpec
    from rlbridge.experiment.evaluate import evaluation_baselines

    def pick(usecase: str, baselines: list[str] | None) -> list[str]:
        return evaluation_baselines(OmegaConf.create({"baselines": baselines}), EnvSpec(CROSS, usecase, {}))

    assert pick("corridor_sa", None) == ["mvp_speed", "daa"]
    assert pick("strategic_planning", None) == ["no_planning", "fcfs"]
    assert pick("hierarchical", None) == ["no_planning", "fcfs"]
    assert pick("corridor_sa", ["unequipped", "mvp_speed"]) == ["unequipped", "mvp_speed"]
    with pytest.raises(ValueError, match="baseline 'fcfs' does not apply to use case corridor_sa; its baselines: "
                                         "unequipped, mvp_speed, daa"):
        pick("corridor_sa", ["fcfs"])
    # Heading and altitude advisories: DAA on those axes and heading/altitude MVP; the speed baseline is refused.
    assert pick("heading_altitude_sa", None) == ["daa", "mvp"]
    with pytest.raises(ValueError, match="baseline 'mvp_speed' does not apply to use case heading_altitude_sa; its "
                                         "baselines: unequipped, daa, mvp"):
        pick("heading_altitude_sa", ["mvp_speed"])
    with pytest.raises(ValueError, match="baseline 'mvp' does not apply to use case corridor_sa"):
        pick("corridor_sa", ["mvp"])


def test_evaluation_noise_goes_only_to_the_parameters_a_use_case_declares():
    # Regression: the strategic use case (alt_noise_ft, no lanes) was given alt_noise_lanes_ft and refused it,
    # so `aamgym evaluate run=<strategic run>` failed before playing an episode.
    from rlbridge.experiment.evaluate import with_altitude_noise
    from rlbridge.usecases.registry import make_usecase

    lanes = [500.0, 1200.0]
    strategic = with_altitude_noise("strategic_planning", {"slot_s": 30.0}, 50.0, lanes)
    assert strategic == {"slot_s": 30.0, "alt_noise_ft": 50.0}
    assert make_usecase("strategic_planning", **strategic).params.alt_noise_ft == 50.0
    assert with_altitude_noise("corridor_sa", {}, 50.0, lanes) == {"alt_noise_ft": 50.0, "alt_noise_lanes_ft": lanes}
    assert with_altitude_noise("hierarchical", {"train": "tactical"}, 50.0, lanes) == {
        "train": "tactical", "corridor": {"alt_noise_ft": 50.0, "alt_noise_lanes_ft": lanes}}
    assert with_altitude_noise("hierarchical", {"train": "planning"}, 50.0, lanes) == {"train": "planning"}
