"""Services wired explicitly: typed fields built with the simulation, started once, the ASAS interval read from
the settings."""

from __future__ import annotations

import pytest

from aamsim import Simulation
from aamsim.conflicts import ConflictService
from aamsim.metrics import MetricsService
from aamsim.services import Services


def _pair(sim: Simulation) -> None:
    sim.stack("CRE A EC35 0 0 0 1000 100; CRE B EC35 0.05 0 180 1000 100")


@pytest.mark.parametrize(("interval", "last_check"), [(5.0, 10.0), (1.0, 12.0), (0.5, 12.0)])
def test_dt_asas_sets_the_check_interval(interval, last_check):
    sim = Simulation(seed=0)
    services = sim.services.start()
    _pair(sim)
    assert sim.stack(f"DT ASAS {interval}")
    sim.run_until(12.0)
    # The conflict check ran at 0, then every `interval` seconds: the last one at `last_check`.
    assert services.conflicts._last_check_s == last_check
    sim.stack("DT")
    assert f"conflict detection every {interval:g} s" in sim.reporter.messages[-1].text


def test_dt_asas_changes_the_interval_after_the_first_checks():
    sim = Simulation(seed=0)
    services = sim.services.start()
    _pair(sim)
    sim.run_until(3.0)
    assert services.conflicts._last_check_s == 3.0  # every 1 s (BlueSky's default)
    sim.stack("DT ASAS 5")
    sim.run_until(12.0)
    assert services.conflicts._last_check_s == 9.0  # 4 was due on the old interval, then 9


def test_services_are_typed_fields_built_once():
    sim = Simulation(seed=0)
    services = sim.services
    assert isinstance(services, Services) and isinstance(services.conflicts, ConflictService)
    assert isinstance(services.metrics, MetricsService) and services.metrics.conflicts is services.conflicts
    assert not services.started and "conflicts" not in sim.hooks.post_step.names()  # idle: no check hooks
    sim.stack("SEPVOLUME")  # a listing does not start conflict detection
    assert not services.started and "conflicts" not in sim.hooks.post_step.names()
    assert services.start() is services and sim.services is services
    assert sim.hooks.post_step.names().count("conflicts") == 1
    services.start(groups=("safety",))  # a second start configures, attaches nothing twice
    assert sim.hooks.post_step.names().count("conflicts") == 1 and services.metrics.groups == ("safety",)
    sim.stack("SEPVOLUME NMAC 100")
    assert sim.services is services and services.conflicts.volume("nmac").radius_m == 100.0


def test_configuring_commands_start_the_services():
    for command in ("SEPVOLUME NMAC 100", "RESO MVP", "DAA TPREV 50"):
        sim = Simulation(seed=0)
        assert sim.stack(command)
        assert sim.services.started and sim.hooks.post_step.names().count("conflicts") == 1, command


def test_snapshot_stream_is_frozen_shared_and_periodic():
    from aamsim.snapshots import take_snapshot

    sim = Simulation(seed=0)
    services = sim.services.start()
    _pair(sim)
    got: list = []
    services.snapshots.subscribe(got.append, 2.0, name="a")
    services.snapshots.subscribe(got.append, 2.0, name="b")
    sim.run_until(4.0)
    assert [s.simt for s in got] == [0.0, 0.0, 2.0, 2.0, 4.0, 4.0]
    assert got[2] is got[3]  # subscribers due together share one snapshot
    first = got[0]
    assert first.ids == ("A", "B") and first.lat.tolist() == [0.0, 0.05]
    with pytest.raises(ValueError):
        first.lat[0] = 1.0
    # A copy: the traffic moved on, the snapshot did not.
    assert sim.view.lat[0] > first.lat[0] == 0.0
    now = take_snapshot(sim, ("alt", "gs"))
    assert now.as_dict() == {"simt": 4.0, "ids": ["A", "B"], "alt": pytest.approx(sim.view.alt.tolist()),
                             "gs": pytest.approx(sim.view.gs.tolist())}
    with pytest.raises(AttributeError, match="no field 'lat'"):
        _ = now.lat
    with pytest.raises(ValueError, match="unknown traffic field"):
        take_snapshot(sim, ("nope",))
