"""Episode backends: the corridor use case on BlueSky gives the observations and rewards it gives on aamsim."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rlbridge
from aamsim.units import KTS

HERE = Path(__file__).parent
TINY = str(HERE / "data" / "tiny_conflict.scn")
ROOT = HERE.parent


def test_unknown_backend_is_a_clear_error():
    with pytest.raises(ValueError, match="'local', 'zmq', 'bluesky'"):
        rlbridge.parallel_env(TINY, backend="xplane")


def test_corridor_on_bluesky_matches_aamsim(tmp_path):
    pytest.importorskip("bluesky")
    out = tmp_path / "bluesky.npz"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(HERE / "bluesky_episode.py"), TINY, str(out)], capture_output=True,
                          text=True, env=env, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    got = np.load(out)
    sys.path.insert(0, str(HERE))
    from bluesky_episode import ACTIONS

    agents = json.loads(str(got["agents"]))
    local = rlbridge.parallel_env(TINY, backend="local", time_limit_s=600.0, n_intruders=4)
    obs, _ = local.reset(seed=0)
    assert list(obs) == agents[0] == ["TA1", "TB2"]
    np.testing.assert_allclose(np.array([obs[a] for a in obs]), got["obs0"], rtol=0, atol=1e-6)
    for k, actions in enumerate(ACTIONS, start=1):
        obs, rewards, _, _, _ = local.step(actions)
        assert list(obs) == agents[k]
        # BlueSky's aircraft are the mirror's, to the bit, after every decision.
        np.testing.assert_array_equal(got[f"bs_lat{k}"], got[f"mirror_lat{k}"])
        # Same observations (float32 features) and rewards, to a tolerance far below any feature's scale.
        np.testing.assert_allclose(np.array([obs[a] for a in obs]), got[f"obs{k}"], rtol=0, atol=1e-5)
        np.testing.assert_allclose(np.array([rewards[a] for a in obs]), got[f"rew{k}"], rtol=0, atol=1e-6)
    # The advisories reached BlueSky: after the third decision TA1 selected 150 kt and TB2 0 kt there.
    np.testing.assert_allclose(got["bs_selspd3"], [150 * KTS, 0.0], atol=1e-9)
