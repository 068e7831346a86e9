"""Pretrained policies: exported as plain data, loaded by name or folder, evaluated, and reproducing their figures."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rlbridge
from rlbridge.pretrained import available, load, reference
from rlbridge.pretrained.ship import reference_figures, ship
from tests.test_study import ROOT, TINY, _tiny_plan


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict[str, Path]:
    """A D2MAV-A and a DDQN policy trained a few iterations on the tiny scenario, exported by the study."""
    from rlbridge.experiment.study import run_study

    tmp = tmp_path_factory.mktemp("pretrained")
    run_study(_tiny_plan(contenders=["d2mava_a", "ddqn"]), tmp / "work", tmp / "out", ("train",))
    return {a: tmp / "out" / "runs" / "corridor_sa" / f"{a}_s0" for a in ("d2mava_a", "ddqn")}


@pytest.mark.parametrize("algo", ["d2mava_a", "ddqn"])
def test_an_exported_policy_acts_on_a_pettingzoo_env_as_its_network_does(exported, algo):
    policy = load(exported[algo])
    assert policy.usecase == "corridor_sa" and policy.provenance["seed"] == 0
    assert policy.provenance["training_scenario"] == "tiny_conflict"
    env = rlbridge.parallel_env(str(ROOT / TINY), usecase=policy.usecase, **policy.env_params)
    obs, _ = env.reset(seed=3)
    acts = policy.actions(obs)
    assert set(acts) == set(obs) and all(env.action_space(a).contains(v) for a, v in acts.items())
    # The actions are the argmax of the network the spec builds with the shipped weights.
    import torch

    agents = list(obs)
    with torch.no_grad():
        if algo == "ddqn":
            scores = policy.actor.q(torch.from_numpy(np.stack([obs[a] for a in agents])))
        else:
            parts = [torch.from_numpy(np.stack([obs[a][k] for a in agents])) for k in ("ownship", "intruders", "mask")]
            scores = policy.actor.model(*parts)[0]
    assert [acts[a] for a in agents] == scores.argmax(dim=1).tolist()
    env.close()


def test_a_shipped_policy_records_figures_that_replay_exactly_and_evaluates_by_name(exported, tmp_path, monkeypatch):
    import rlbridge.pretrained.ship as ship_module
    from rlbridge import pretrained

    monkeypatch.setattr(pretrained, "SHIPPED_DIR", tmp_path / "shipped")
    monkeypatch.setattr(ship_module, "SHIPPED_DIR", tmp_path / "shipped")
    (tmp_path / "shipped").mkdir()
    dest = ship(exported["d2mava_a"], "tiny_d2mava", str(ROOT / TINY), seeds=(5, 6), note="a test policy")
    assert available() == ["tiny_d2mava"] and dest.name == "tiny_d2mava"
    ref = reference("pretrained:tiny_d2mava")
    assert [e["seed"] for e in ref["episodes"]] == [5, 6] and ref["scenario"] == "tiny_conflict"
    assert ref["time_limit_s"] == 1200.0  # the first 20 minutes of each episode
    assert reference_figures("tiny_d2mava", str(ROOT / TINY), (5, 6)) == ref["episodes"]
    assert json.loads((dest / "policy.json").read_text())["provenance"]["note"] == "a test policy"


def test_aamgym_evaluate_takes_an_exported_policy_folder(exported, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = tmp_path / "eval"
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "evaluate", f"policy={exported['ddqn']}",
                           f"scenario={ROOT / TINY}", "episodes=2", "workers=0", "baselines=[]",
                           f"hydra.run.dir={out}"], env=env, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    ev = json.loads((out / "evaluation.json").read_text())
    assert ev["policies"]["ddqn"]["learned"] is True and ev["policies"]["ddqn"]["label"] == "DDQN (RLlib update ratio)"
    assert set(ev["policies"]) == {"ddqn", "unequipped"} and ev["episodes"] == 2


def test_bad_policy_files_are_refused_with_what_is_wrong(exported, tmp_path):
    with pytest.raises(FileNotFoundError, match="no pretrained policy 'pretrained:nope'"):
        load("pretrained:nope")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "policy.json").write_text((exported["ddqn"] / "policy.json").read_text())
    with np.load(exported["ddqn"] / "policy.npz") as npz:
        weights = {k: npz[k] for k in npz.files}
    first = min(weights)
    weights[first] = weights[first][..., :1]
    np.savez(bad / "policy.npz", **weights)
    with pytest.raises(ValueError, match="wrong shape"):
        load(bad)
    np.savez(bad / "policy.npz", evil=np.array([object()], dtype=object))
    with pytest.raises(ValueError):  # object arrays would need pickle: refused (allow_pickle=False)
        load(bad)


@pytest.mark.parametrize("name", available())
def test_every_shipped_policy_reproduces_its_published_figures(name):
    ref = reference(name)
    again = reference_figures(name, ref["scenario"], tuple(e["seed"] for e in ref["episodes"]), ref["time_limit_s"])
    for replayed, shipped in zip(again, ref["episodes"], strict=True):
        # Counts exactly; the reward is a sum of floats whose order another CPU's kernels may change.
        assert {k: v for k, v in replayed.items() if k != "reward_total"} == \
            {k: v for k, v in shipped.items() if k != "reward_total"}
        assert replayed["reward_total"] == pytest.approx(shipped["reward_total"], rel=1e-9, abs=1e-9)


def test_action_counts_show_a_policy_that_always_accelerates(exported, tmp_path, capsys):
    from rlbridge.pretrained import action_counts
    from rlbridge.pretrained.ship import main

    # The DDQN network with its last layer replaced: Q = (0, 0, 5) whatever it sees, so it accelerates in
    # every decision.
    forced = tmp_path / "always_accelerate"
    forced.mkdir()
    (forced / "policy.json").write_text((exported["ddqn"] / "policy.json").read_text())
    with np.load(exported["ddqn"] / "policy.npz") as npz:
        weights = {k: npz[k] for k in npz.files}
    last = max(k for k in weights if k.endswith(".weight"))
    weights[last] = np.zeros_like(weights[last])
    weights[last.replace(".weight", ".bias")] = np.array([0.0, 0.0, 5.0], dtype=weights[last].dtype)
    np.savez(forced / "policy.npz", **weights)
    counts = action_counts(load(forced), str(ROOT / TINY), seed=3)
    assert set(counts) == {0, 1, 2} and counts[0] == counts[1] == 0 and counts[2] > 0
    # The trained policy's counts add up to its decisions, which the same episode played by hand gives.
    policy = load(exported["ddqn"])
    counts = action_counts(policy, str(ROOT / TINY), seed=3)
    env = rlbridge.parallel_env(str(ROOT / TINY), usecase=policy.usecase, **policy.env_params)
    obs, _ = env.reset(seed=3)
    by_hand = [0, 0, 0]
    while env.agents:
        acts = policy.actions(obs)
        for a in acts.values():
            by_hand[a] += 1
        obs, *_ = env.step(acts)
    env.close()
    assert [counts[a] for a in range(3)] == by_hand
    main(["actions", str(forced), "--scenario", str(ROOT / TINY), "--seed", "3"])
    line = capsys.readouterr().out
    assert "action 0: 0 (0.0 %)" in line and "(100.0 %)" in line and "seed 3:" in line
