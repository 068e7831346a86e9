"""Shared fixtures."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from aamsim import Simulation


@pytest.fixture(scope="session", autouse=True)
def sb3_logs_in_pytest_tmp(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Stable-Baselines3's logger folder under pytest's temporary directory.

    Without a folder SB3 makes ``$TMPDIR/SB3-<date and time>`` at every ``learn()``, even when
    nothing is logged, and leaves it: each suite run left some sixty empty folders in /tmp. The
    variable is inherited by the processes the tests start (the examples, the CLIs).
    """
    folder = tmp_path_factory.mktemp("sb3-logs")
    before = os.environ.get("SB3_LOGDIR")
    os.environ["SB3_LOGDIR"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("SB3_LOGDIR", None)
    else:
        os.environ["SB3_LOGDIR"] = before


@pytest.fixture
def sim() -> Simulation:
    """A fresh simulation without BlueSky's navigation data (fast, self-contained)."""
    return Simulation(seed=42, use_bluesky_navdata=False)


def errors_of(sim: Simulation) -> list[str]:
    return [str(m) for m in sim.reporter.messages if m.kind == "error"]


def count_calls(monkeypatch: pytest.MonkeyPatch, owner: object, name: str) -> list[int]:
    """Counts the calls of ``owner.name`` from now on (``[calls]``); the function itself is unchanged."""
    calls = [0]
    fn = getattr(owner, name)

    def counted(*args: object) -> object:
        calls[0] += 1
        return fn(*args)

    monkeypatch.setattr(owner, name, counted)
    return calls
