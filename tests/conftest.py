"""Shared fixtures."""

from __future__ import annotations

import pytest

from aamsim import Simulation


@pytest.fixture
def sim() -> Simulation:
    """A fresh simulation without BlueSky's navigation data (fast, self-contained)."""
    return Simulation(seed=42, use_bluesky_navdata=False)


def errors_of(sim: Simulation) -> list[str]:
    return [str(m) for m in sim.reporter.messages if m.kind == "error"]
