"""Trained policies as plain data: weights in ``policy.npz`` beside their spec in ``policy.json``.

A training run's ``checkpoints/best.pt`` holds the optimiser, RNG states and the machine's paths;
what a researcher needs to act with the policy is much less: the actor spec (algorithm kind,
hyper-parameters, observation sizes), the use case and its parameters, and the network's weights.
:func:`export_policy` writes exactly that (no pickle, no machine path), with its provenance (the
code that trained it, the seed, the budget, the best iteration); :func:`load_policy` reads it back
and checks that the weights fit the spec.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

POLICY_FORMAT = 1


@dataclass(frozen=True)
class ExportedPolicy:
    """A policy read back from ``policy.json`` + ``policy.npz``."""

    name: str
    label: str
    actor_spec: dict[str, Any]  # {"kind", "config", "dims"}: what make_actor needs
    usecase: str
    usecase_params: dict[str, Any]
    episode: dict[str, Any]  # time_limit_s, dt, metrics of the training episodes
    weights: dict[str, np.ndarray]
    provenance: dict[str, Any]
    greedy_explore: dict[str, Any]  # the explore settings of a greedy evaluation


def policy_env(policy: ExportedPolicy, scenario: str) -> Any:
    """The episode settings to run ``policy`` on ``scenario`` as it was trained (use case, parameters, step)."""
    from rlbridge.agents.rollout import EnvSpec
    from rlbridge.experiment.train import resolve_scenario_path

    ep = policy.episode
    return EnvSpec(resolve_scenario_path(scenario), policy.usecase, dict(policy.usecase_params),
                   None if ep.get("time_limit_s") is None else float(ep["time_limit_s"]), float(ep.get("dt", 0.05)),
                   tuple(ep.get("metrics", ("safety", "operational"))))


def export_policy(checkpoint: str | Path, dest: str | Path, extra_provenance: dict[str, Any] | None = None) -> Path:
    """Write the acting half of ``checkpoint`` to ``dest/policy.json`` and ``dest/policy.npz``."""
    from rlbridge.experiment.evaluate import numpy_weights
    from rlbridge.experiment.train import load_checkpoint

    ckpt = load_checkpoint(checkpoint)
    algo = ckpt["algorithm"]
    env = ckpt["env"]
    config = ckpt.get("config", {})
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    weights = numpy_weights(ckpt["learner"]["model"])
    np.savez_compressed(dest / "policy.npz", **weights)  # type: ignore[arg-type]
    state = ckpt["state"]
    spec = {
        "format": POLICY_FORMAT,
        "name": algo["name"], "label": algo.get("label", algo["name"]),
        "actor": {"kind": algo["kind"], "config": algo["params"], "dims": ckpt["dims"]},
        "usecase": env["usecase"], "usecase_params": env["params"],
        "episode": {"time_limit_s": env.get("time_limit_s"), "dt": env.get("dt", 0.05),
                    "metrics": list(env.get("metrics", ("safety", "operational")))},
        "provenance": {
            "training_scenario": Path(env["scenario"]).stem, "seed": ckpt["seed"],
            "aircraft_states_budget": config.get("train", {}).get("aircraft_states"),
            "aircraft_states": state.get("transitions"), "iterations": state.get("iteration"),
            "best_iteration": state.get("best_iteration"), "best_rolling_reward": state.get("best"),
            "best_window": config.get("train", {}).get("best_window"),
            "workers": config.get("workers"), "train_mode": config.get("train", {}).get("mode"),
            "code": ckpt.get("code", []), **(extra_provenance or {}),
        },
    }
    (dest / "policy.json").write_text(json.dumps(spec, indent=2, default=_plain) + "\n")
    return dest


def _plain(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"{type(x).__name__} is not plain data")


def load_policy(path: str | Path) -> ExportedPolicy:
    """Read a policy written by :func:`export_policy` (a folder holding ``policy.json`` and ``policy.npz``)."""
    folder = Path(path)
    spec_file, weights_file = folder / "policy.json", folder / "policy.npz"
    if not spec_file.is_file() or not weights_file.is_file():
        raise FileNotFoundError(f"{folder}: not an exported policy (needs policy.json and policy.npz)")
    spec = json.loads(spec_file.read_text())
    if spec.get("format") != POLICY_FORMAT:
        raise ValueError(f"{spec_file}: policy format {spec.get('format')!r}, this version reads {POLICY_FORMAT}")
    with np.load(weights_file, allow_pickle=False) as npz:
        weights = {k: npz[k] for k in npz.files}
    actor = spec["actor"]
    _check_weights(actor, weights, folder)
    kind = actor["kind"]
    greedy = {"greedy": True} if kind == "d2mava" else {"epsilon": 0.0}
    episode = spec.get("episode", {"time_limit_s": None, "dt": 0.05, "metrics": ["safety", "operational"]})
    return ExportedPolicy(spec["name"], spec["label"], actor, spec["usecase"], spec["usecase_params"], episode,
                          weights, spec["provenance"], greedy)


def _check_weights(actor: dict[str, Any], weights: dict[str, np.ndarray], folder: Path) -> None:
    """The weights must be exactly the tensors of the network the spec builds (names and shapes)."""
    from rlbridge.agents import make_actor

    model = make_actor(actor)
    net = getattr(model, "model", None) or getattr(model, "q", None)
    if net is None:
        raise ValueError(f"{folder}: actor kind {actor['kind']!r} has no network to load")
    expected = {k: tuple(v.shape) for k, v in net.state_dict().items()}
    got = {k: tuple(v.shape) for k, v in weights.items()}
    if expected != got:
        missing = sorted(set(expected) - set(got))
        extra = sorted(set(got) - set(expected))
        wrong = sorted(k for k in set(expected) & set(got) if expected[k] != got[k])
        raise ValueError(f"{folder}: the weights do not fit the {actor['kind']} network of policy.json "
                         f"(missing {missing}, unexpected {extra}, wrong shape {wrong})")
