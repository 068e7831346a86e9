"""A new use case with heading advisories, one module plus its registry entry, trains on every backend (issue 29).

``HeadingOnly`` (below) is the use case: heading advisories only (turns off the route and the
resume action), declared in its spec (``action_kinds=("heading",)``, baselines ``daa`` and
``mvp``). The test registers it (an entry of the registry, removed afterwards; the simulation
server gets the same entry) and trains D2MAV-A for two iterations in process, over a real
``aamsim serve`` (identical) and on BlueSky; ``mvp_speed`` is refused by name (it needs speed
actions), ``mvp`` runs over ZeroMQ as in process, ``daa`` is applied in process.
"""

from __future__ import annotations

import os
import queue
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest
from bridge_util import stop_process

from rlbridge.usecases.heading_altitude import HeadingAltitudeParams, HeadingAltitudeSA
from rlbridge.usecases.registry import BUILTIN_USECASES
from rlbridge.usecases.spec import CapabilityError, UseCaseSpec
from tests.policy_digests import DATA, batch_digest
from tests.test_policy_snapshots import _train

ROOT = Path(__file__).resolve().parent.parent
NAME = "heading_only_test"
ENTRY = "tests.test_new_heading_usecase:HeadingOnly"


class HeadingOnly(HeadingAltitudeSA):
    """Heading advisories only: turns of -30 / +30 deg off the route, or the route (no level changes)."""

    name = NAME
    spec = UseCaseSpec(HeadingAltitudeParams, action_kinds=("heading",), baselines=("daa", "mvp"),
                       advisory="manoeuvre_change", metrics=("heading_advisories", "mean_abs_xtrack_m"))

    def __init__(self, **params: Any):
        super().__init__(**{"heading_offsets_deg": (-30.0, 0.0, 30.0), "altitude_offsets_ft": (0.0,), **params})

    def extra_metrics(self, sim: Any) -> dict[str, Any]:
        out = super().extra_metrics(sim)
        return {k: out[k] for k in self.spec.metrics if k in out}


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(BUILTIN_USECASES, NAME, ENTRY)  # removed again after the test
    yield NAME
    assert NAME not in BUILTIN_USECASES or BUILTIN_USECASES[NAME] == ENTRY


def _server(cwd: Path) -> tuple[subprocess.Popen, str]:
    """``aamsim serve`` with the same registry entry (a server knows use cases by registered name)."""
    code = (f"from rlbridge.usecases.registry import BUILTIN_USECASES; BUILTIN_USECASES[{NAME!r}] = {ENTRY!r}; "
            "import sys; sys.argv = ['aamsim', 'serve', '--bind', 'tcp://127.0.0.1:*', '--log-level', 'ERROR']; "
            "from aamsim.entry import main; main()")
    env = dict(os.environ, PYTHONPATH=f"{ROOT}{os.pathsep}{ROOT / 'tests'}")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=cwd)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    try:
        line = lines.get(timeout=120)
    except queue.Empty:
        proc.kill()
        raise RuntimeError("server did not start") from None
    assert "listening on " in line, line
    return proc, line.split("listening on ", 1)[1].strip()


def test_the_new_use_case_declares_heading_actions_and_refuses_mvp_speed_by_name(registered):
    from rlbridge.agents import check_baseline_fits, make_actor
    from rlbridge.usecases.registry import make_usecase

    usecase = make_usecase(registered)
    assert usecase.action_space().n == 3 and usecase.resume_action == 1
    with pytest.raises(CapabilityError, match=rf"baseline mvp_speed does not fit use case {NAME}: it needs speed "
                                              r"actions \(its action kinds: heading\)"):
        check_baseline_fits("mvp_speed", registered)
    check_baseline_fits("daa", registered)  # heading actions: the manoeuvre DAA applies
    check_baseline_fits("mvp", registered)
    make_actor({"kind": "mvp"}).check_usecase(usecase)


def test_the_new_use_case_trains_alike_in_process_and_over_zeromq_with_its_baselines(registered, tmp_path,
                                                                                    monkeypatch):
    from rlbridge.agents.rollout import EnvSpec, RolloutWorker

    shutil.copy(DATA / "daa_turns.scn", tmp_path / "daa_turns.scn")
    monkeypatch.chdir(tmp_path)
    spec = {"scenario": "daa_turns.scn", "usecase": registered, "params": {}, "time_limit_s": 900.0}
    local_train = _train(EnvSpec(**spec))
    local_mvp = RolloutWorker(EnvSpec(**spec), {"policy": {"kind": "mvp"}}).collect([0])[0]
    daa = RolloutWorker(EnvSpec(**spec), {"policy": {"kind": "daa"}}).collect([0])[0]
    assert daa.stats.metrics[NAME]["heading_advisories"] > 0  # applied: it turned aircraft
    proc, endpoint = _server(tmp_path)
    try:
        remote = EnvSpec(**spec, backend="zmq", address=endpoint, timeout_s=600.0)
        assert _train(remote) == local_train
        remote_mvp = RolloutWorker(remote, {"policy": {"kind": "mvp"}}).collect([0])[0]
        remote_daa = RolloutWorker(remote, {"policy": {"kind": "daa"}}).collect([0])[0]
    finally:
        stop_process(proc)
    assert local_mvp.stats.metrics[NAME]["heading_advisories"] > 0
    for name in ("actions", "rewards", "obs_idx", "next_idx", "terminated", "truncated"):
        assert getattr(local_mvp, name).tobytes() == getattr(remote_mvp, name).tobytes(), name
        assert getattr(daa, name).tobytes() == getattr(remote_daa, name).tobytes(), name
    assert batch_digest(local_mvp) != ""


@pytest.mark.slow
def test_the_new_use_case_trains_on_bluesky_as_in_process(registered, tmp_path, monkeypatch):
    pytest.importorskip("bluesky")
    from rlbridge.agents.rollout import EnvSpec

    shutil.copy(DATA / "daa_turns.scn", tmp_path / "daa_turns.scn")
    monkeypatch.chdir(tmp_path)
    spec = {"scenario": "daa_turns.scn", "usecase": registered, "params": {}, "time_limit_s": 900.0}
    local = _train(EnvSpec(**spec))
    on_bluesky = _train(EnvSpec(**spec, backend="bluesky"))
    for (n_bs, r_bs, a_bs, l_bs), (n, r, a, losses) in zip(on_bluesky, local, strict=True):
        assert n_bs == n and a_bs == a
        # The same decisions; the episode rewards up to BlueSky's own arithmetic (8.6e-6 relative measured
        # on daa_turns.scn, where the turns keep aircraft close for minutes).
        assert r_bs == pytest.approx(r, rel=1e-4)
        assert dict(l_bs) == pytest.approx(dict(losses), rel=1e-3, abs=1e-6)
