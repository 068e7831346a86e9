"""Reports never mix rows of two use-case configurations (the paper's reward and variant v1)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.evaluate import run_evaluation
from rlbridge.experiment.report import make_report
from rlbridge.experiment.train import run_training

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
QUICK = [f"scenario={TINY}", "workers=0", "env.time_limit_s=600", "usecase.params.n_intruders=4",
         "train.baseline_episodes=0", "train.iterations=1", "algorithm=d2mava_a"]


def rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_paper_and_v1_evaluations_get_separate_tables(tmp_path, monkeypatch):
    import rlbridge.experiment.report as report_module

    drawn: dict[str, list[str]] = {}
    draw = report_module.reward_figure

    def record(plt, groups, color_of, path, *args):
        drawn[path.name] = sorted(groups)
        return draw(plt, groups, color_of, path, *args)

    monkeypatch.setattr(report_module, "reward_figure", record)
    evals = []
    for usecase in ("corridor_sa", "corridor_sa_v1"):
        cfg = compose_config("config", overrides=[*QUICK, f"usecase={usecase}"])
        ecfg = compose_config("evaluate", overrides=[f"run={tmp_path / usecase}", "workers=0", "episodes=2",
                                                     "baselines=[mvp_speed]"])
        run_training(cfg, tmp_path / usecase)
        run_evaluation(ecfg, tmp_path / f"eval_{usecase}")
        evals.append(tmp_path / f"eval_{usecase}")
    assert json.loads((evals[1] / "evaluation.json").read_text())["usecase"] == {"name": "corridor_sa",
                                                                                 "variant": "v1"}
    out = tmp_path / "report"
    make_report(evals, [tmp_path / "corridor_sa", tmp_path / "corridor_sa_v1"], out)
    paper, v1 = rows(out / "risk_ratio.csv"), rows(out / "risk_ratio_v1.csv")
    # The same algorithm in both tables, each over its own two seeds only (not pooled to four).
    for table in (paper, v1):
        labels = [r[0].split(" — ")[0] for r in table[1:]]
        assert labels == ["D2MAV-A No Shared Layers", "MVP speed-only (rule-based)"]
        assert all("(n=2)" in r[1] for r in table[1:])
    assert rows(out / "operational.csv")[1][2] == "2" and rows(out / "operational_v1.csv")[1][2] == "2"
    report = (out / "report.md").read_text()
    assert "## Use case corridor_sa (the paper's reward)" in report
    assert "## Use case corridor_sa variant v1" in report
    assert report.index("variant v1") > report.index("the paper's reward")
    # Learning curves of the two rewards are two curves, not one pooled curve.
    training = rows(out / "training.csv")
    assert {r[0] for r in training[1:]} == {"D2MAV-A No Shared Layers", "D2MAV-A No Shared Layers [v1]"}
    # Their reward curves are two figures: the rewards measure different things (v1 adds a term).
    assert drawn == {"reward_curve.png": ["D2MAV-A No Shared Layers"],
                     "reward_curve_v1.png": ["D2MAV-A No Shared Layers [v1]"]}
    assert (out / "reward_curve_v1.png").read_bytes()[:4] == b"\x89PNG"
    assert "(reward_curve.png)" in report and "(reward_curve_v1.png)" in report


def test_config_suffix_names_the_variant_only():
    """A planner's report keeps its file names (planning.csv, risk_ratio.csv): no use-case name in them."""
    from rlbridge.experiment.report import config_suffix

    assert config_suffix(("corridor_sa", "paper")) == ""
    assert config_suffix(("corridor_sa", "v1")) == "_v1"
    assert config_suffix(("strategic_planning", "paper")) == ""


def test_two_use_cases_in_one_report_never_share_a_file_name():
    """The variant names the files while it is unique in the report; two use cases' own configurations
    (both 'paper') or the same variant of two use cases get the use case's name, each once."""
    from rlbridge.experiment.report import config_suffixes

    assert config_suffixes([("corridor_sa", "paper"), ("corridor_sa", "v1")]) == {
        ("corridor_sa", "paper"): "", ("corridor_sa", "v1"): "_v1"}
    assert config_suffixes([("strategic_planning", "paper")] * 3) == {("strategic_planning", "paper"): ""}
    both = config_suffixes([("corridor_sa", "v1"), ("corridor_sa", "paper"), ("strategic_planning", "paper"),
                            ("reach_destination", "v1")])
    assert both == {("corridor_sa", "paper"): "_corridor_sa", ("strategic_planning", "paper"): "_strategic_planning",
                    ("corridor_sa", "v1"): "_corridor_sa_v1", ("reach_destination", "v1"): "_reach_destination_v1"}
    assert len(set(both.values())) == len(both)
