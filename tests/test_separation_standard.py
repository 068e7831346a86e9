"""The separation standard (NMAC and LoWC volumes): owned by the conflict service, read through the simulation."""

from __future__ import annotations

import math

import pytest

from aamsim import SeparationStandard, Simulation
from aamsim.conflicts import PAPER_VOLUMES, SeparationVolume

DEG_PER_M = 1.0 / (6371000.0 * math.pi / 180.0)  # degrees of arc per metre on the sphere


def passing(offset_m: float, standard: SeparationStandard | None = None) -> Simulation:
    """Two EC135s head-on at 1000 ft, 4 km apart along track and ``offset_m`` apart across it."""
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    if standard is not None:
        sim.set_separation_standard(standard)
    lon = offset_m * DEG_PER_M
    sim.load_text(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n"
                  f"00:00:00.00>CRE B EC35 {4000 * DEG_PER_M} {lon} 180 1000 100\n")
    sim.run_until(120.0)
    sim.services.start().conflicts.finish(sim)
    return sim


def test_the_default_is_the_papers_spheres():
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    std = sim.separation_standard
    assert std == SeparationStandard(150.0, 150.0, 450.0, 450.0, nmac_sphere=True, lowc_sphere=True)
    assert std.volumes() == PAPER_VOLUMES == (SeparationVolume("nmac", 150.0), SeparationVolume("lowc", 450.0))


def test_the_standard_decides_what_counts_as_a_loss_of_well_clear():
    # 500 m abeam: outside the paper's 450 m LoWC sphere, inside a 600 m one; never an NMAC.
    paper = (passing(500.0)).services.start().conflicts
    wide = (passing(500.0, SeparationStandard(lowc_horizontal_m=600.0, lowc_vertical_m=600.0))).services.start().conflicts
    assert (paper.count("nmac"), paper.count("lowc")) == (0, 0)
    assert (wide.count("nmac"), wide.count("lowc")) == (0, 1)
    assert wide.events[0].min_dist_m == pytest.approx(500.0, abs=1.0)


def test_sepvolume_changes_the_standard_and_the_metrics_read_it():
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    assert sim.separation_standard == SeparationStandard()  # read (and kept by the service) before the change
    sim.stack("SEPVOLUME NMAC 100 30")
    sim.run_until(0.0)
    std = sim.separation_standard
    assert (std.nmac_horizontal_m, std.nmac_vertical_m, std.nmac_sphere) == (100.0, 30.0, False)
    assert (std.lowc_horizontal_m, std.lowc_vertical_m, std.lowc_sphere) == (450.0, 450.0, True)
    assert std.nmac == SeparationVolume("nmac", 100.0, 30.0)
    assert sim.services.start().metrics.context(sim).separation == std


def test_a_service_without_the_two_volumes_has_no_standard():
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    service.volumes = (SeparationVolume("wide", 900.0),)
    with pytest.raises(LookupError, match="no 'nmac' volume"):
        _ = sim.separation_standard
    assert sim.services.start().metrics.context(sim).separation == SeparationStandard()  # the metrics keep the paper's names


@pytest.mark.parametrize("kwargs, message", [
    ({"nmac_horizontal_m": 0.0, "nmac_vertical_m": 0.0}, "nmac_horizontal_m must be a distance above 0"),
    ({"lowc_vertical_m": math.nan, "lowc_sphere": False}, "lowc_vertical_m must be a distance above 0"),
    ({"lowc_vertical_m": 150.0}, "the lowc sphere has one radius"),
])
def test_a_bad_standard_is_refused_with_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        SeparationStandard(**kwargs)
