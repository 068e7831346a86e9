"""``scripts/reproduce_paper.sh`` (``aamgym study``): the paper's whole study, run tiny end to end."""

from __future__ import annotations

import csv
import json
import os
import subprocess
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


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_smoke_study_runs_the_whole_pipeline(tmp_path):
    work = tmp_path / "study"
    run_script(["usecase.params.n_intruders=4", "env.time_limit_s=600", "--smoke", "--work", str(work),
                "--workers", "0", "--budget", "60", "--train-scenario", TINY, "--eval-scenarios", TINY], timeout=1800)
    out = work / "report"
    labels = {"D2MAV-A No Shared Layers", "D2MAV-A Shared Layers", "DDQN"}
    for sfx in ("", "_v1"):  # the paper's use case and the corrected variant, in separate tables
        table = rows(out / f"risk_ratio{sfx}.csv")
        names = {r["Algorithm"].split(" — ")[0] for r in table}
        assert names == labels | {f"{lb}, sampled actions" for lb in labels} | {"MVP speed-only (rule-based)"}
        for r in table:  # two training seeds x two evaluation episodes per learned row
            expected = "(n=2)" if r["Algorithm"].startswith("MVP") else "(n=4)"
            assert expected in r["Risk Ratio - tiny_conflict"]
            assert r["parked at time limit - tiny_conflict"] != "n/a"
    training = rows(out / "training.csv")
    assert sorted(r["Algorithm"] for r in training) == sorted(
        [lb for lb in labels for _ in range(2)] + [f"{lb} [v1]" for lb in labels for _ in range(2)])
    for r in training:  # the equal budget: no run stops before it (iterations are whole episodes)
        assert int(r["aircraft-states"].replace(",", "")) >= 60
    assert (out / "reward_curve.png").read_bytes()[:4] == b"\x89PNG"
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
