"""The parameter dataclasses are the one source of the Hydra configurations' defaults (rlbridge/conf).

``algorithm.params`` and ``usecase.params`` are composed from the learner's and the use case's
dataclass (structured configs, :mod:`rlbridge.experiment.configstore`); the YAML files list only
what a preset changes. ``data/composed_configs.json`` holds what ``aamgym train`` (``config``) and
``aamgym evaluate`` (``evaluate``) composed before, when the YAML files repeated every default
(recorded at commit 64c295a; then NMAC/LoWC/separation defaults null = the simulation's standard and the
backend keys, both on purpose): today's composition must give the same values, so a dataclass
default that drifts fails here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

import pytest
import yaml
from omegaconf import OmegaConf

from rlbridge.agents import learner_config_class
from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.preflight import check_job
from rlbridge.usecases import usecase_spec

ROOT = Path(__file__).resolve().parents[1]
CONF = ROOT / "rlbridge" / "conf"
RECORDED = json.loads((Path(__file__).parent / "data" / "composed_configs.json").read_text())
# What a preset configuration changes on purpose (anything else is the dataclass default).
PRESETS: dict[str, dict[str, Any]] = {
    "algorithm/d2mava_a_shared": {"shared": True},
    "algorithm/ddqn_per_transition": {"schedule": "per_transition", "learning_starts": 10000},
    "algorithm/dqn": {"double": False},
    "usecase/corridor_sa_v1": {"variant": "v1", "hover_cost": 0.05},
}
OPTIONS = sorted(f"{p.parent.name}/{p.stem}" for group in ("algorithm", "usecase") for p in (CONF / group).glob("*.yaml"))


def _default(f: Any) -> Any:
    value = f.default if f.default is not MISSING else f.default_factory()
    return list(value) if isinstance(value, tuple) else value


def _params_class(group: str, node: Any) -> type:
    return learner_config_class(str(node["kind"])) if group == "algorithm" else usecase_spec(str(node["name"])).params_class


def _composed(command: str, overrides: list[str], node: str | None = None) -> Any:
    cfg = compose_config(command, overrides)
    return OmegaConf.to_container(cfg[node] if node else cfg, resolve=False)


def test_every_option_is_recorded():
    recorded = {key.split()[1].replace("=", "/") for key in RECORDED if " " in key}
    assert recorded == set(OPTIONS), "a group option without a recorded composition (or a recorded one removed)"


@pytest.mark.parametrize("key", sorted(RECORDED))
def test_composition_gives_the_recorded_values(key):
    """Every value composed before is composed again; ``params`` gains only the dataclass defaults
    the YAML did not list (the job built the same dataclass from them before)."""
    command, *rest = key.split()
    node = rest[0].split("=")[0] if rest else None
    now, before = _composed(command, rest, node), RECORDED[key]
    sections = {node: now} if node else {g: now[g] for g in ("algorithm", "usecase") if g in now}
    old_sections = {node: before} if node else {g: before[g] for g in sections}
    for group, section in sections.items():
        defaults = {f.name: _default(f) for f in fields(_params_class(group, section))}
        added = {k: v for k, v in section["params"].items() if k not in old_sections[group]["params"]}
        assert added == {k: defaults[k] for k in added}, f"{key}: {group}.params added non-defaults"
        section["params"] = {k: v for k, v in section["params"].items() if k not in added}
    assert now == before


@pytest.mark.parametrize("option", OPTIONS)
def test_composed_params_are_the_dataclass_defaults_plus_the_preset(option):
    group, name = option.split("/")
    node = _composed("config", [f"{group}={name}"], group)
    cls = _params_class(group, node)
    expected = {f.name: _default(f) for f in fields(cls)} | PRESETS.get(option, {})
    assert node["params"] == expected


@pytest.mark.parametrize("option", OPTIONS)
def test_yaml_lists_only_what_the_preset_changes(option):
    listed = (yaml.safe_load((CONF / f"{option}.yaml").read_text()) or {}).get("params") or {}
    assert listed == PRESETS.get(option, {}), f"{option}.yaml repeats a dataclass default or has an unlisted preset"


@pytest.mark.parametrize(("override", "problem"), [
    ("algorithm.params.lr=abc", "algorithm.params.lr=abc: expected a number"),
    ("usecase.params.n_intruders=1.5", "usecase.params.n_intruders=1.5: expected an integer"),
    ("algorithm.params.shared=maybe", "algorithm.params.shared=maybe: expected true or false"),
])
def test_an_override_of_the_wrong_type_is_refused_naming_the_field(override, problem):
    assert check_job("config", [override, "workers=0"]) == [problem]


def test_aamgym_train_refuses_a_mistyped_override_before_starting(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "rlbridge.experiment.cli", "train", "algorithm=ddqn",
                           "algorithm.params.lr=abc", "workers=0", f"out_dir={tmp_path}"],
                          check=False, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["aamgym train: error: algorithm.params.lr=abc: expected a number"]
    assert not any(tmp_path.iterdir())  # no run directory


@pytest.mark.parametrize("command", ["config", "evaluate"])
def test_the_app_yaml_lists_no_key_of_its_dataclass(command):
    """``config.yaml``/``evaluate.yaml`` name their presets and Hydra's settings only: every other key and
    its default is the dataclass's (rlbridge.experiment.schema.SCHEMAS), which is not repeated there."""
    from rlbridge.experiment.schema import SCHEMAS

    listed = yaml.safe_load((CONF / f"{command}.yaml").read_text())
    assert set(listed) == {"defaults", "hydra"}
    assert f"/schema/app/{command}@_here_" in listed["defaults"]
    assert {f.name for f in fields(SCHEMAS[command])} - {"algorithm", "usecase"} <= set(RECORDED[command])


@pytest.mark.parametrize("command", ["config", "evaluate"])
def test_the_app_dataclass_defaults_are_the_recorded_values(command):
    """A drifted default of TrainConfig / EvaluateConfig (or one of their sections) fails here, naming the key."""
    from rlbridge.experiment.schema import SCHEMAS, config_defaults

    defaults = config_defaults(SCHEMAS[command])
    recorded = {k: v for k, v in RECORDED[command].items() if k not in ("algorithm", "usecase")}
    for key in sorted(set(defaults) | set(recorded)):
        assert defaults.get(key) == recorded.get(key), f"{command}: {key}"
