"""The Hydra configurations (rlbridge/conf) agree with the parameter dataclasses: every ``params`` value
Hydra composes for an algorithm or a use case equals the dataclass default, except the deliberate
overrides of a preset, listed here. A YAML value that drifts from its dataclass fails."""

from __future__ import annotations

from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from rlbridge.agents import learner_config_class
from rlbridge.usecases import usecase_spec

CONF = Path(__file__).resolve().parents[1] / "rlbridge" / "conf"
# What a preset configuration changes on purpose (anything else must be the dataclass default).
PRESETS: dict[str, dict[str, Any]] = {
    "algorithm/d2mava_a_shared": {"shared": True},
    "algorithm/ddqn_per_transition": {"schedule": "per_transition", "learning_starts": 10000},
    "algorithm/dqn": {"double": False},
    "usecase/corridor_sa_v1": {"variant": "v1", "hover_cost": 0.05},
}


def _default(f: Any) -> Any:
    value = f.default if f.default is not MISSING else f.default_factory()
    return list(value) if isinstance(value, tuple) else value


def _composed(group: str, name: str) -> tuple[type, dict[str, Any]]:
    with initialize_config_module("rlbridge.conf", version_base="1.3"):
        cfg = compose("config", overrides=[f"{group}={name}"])
    node = cfg[group]
    cls = learner_config_class(str(node.kind)) if group == "algorithm" else usecase_spec(str(node.name)).params_class
    return cls, OmegaConf.to_container(node.params, resolve=True)  # type: ignore[return-value]


@pytest.mark.parametrize("config", sorted(f"{p.parent.name}/{p.stem}" for group in ("algorithm", "usecase")
                                          for p in (CONF / group).glob("*.yaml")))
def test_composed_params_are_the_dataclass_defaults(config):
    group, name = config.split("/")
    cls, params = _composed(group, name)
    defaults = {f.name: _default(f) for f in fields(cls)}
    assert set(params) <= set(defaults), f"{config}: keys the dataclass does not have"
    overrides = PRESETS.get(config, {})
    drift = {k: (v, defaults[k]) for k, v in params.items() if k not in overrides and v != defaults[k]}
    assert drift == {}, f"{config}: YAML values differ from {cls.__name__}'s defaults (value, default): {drift}"
    assert {k: params[k] for k in overrides} == overrides
