"""BlueSky itself runs what uam2scn writes (skipped only without bluesky-simulator)."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import pytest
from uam_helpers import GOOD_ROWS, HEADER

from uamtoolkit_import.convert import ConvertOptions, convert, scenario_names
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.schedule import parse_schedule

pytestmark = pytest.mark.bluesky

NET = nyc_network()


def distance_m(a: list[float], b: tuple[float, float]) -> float:
    from aamsim.geo import geodesic_inverse

    return geodesic_inverse(a[0], a[1], b[0], b[1])[1]


def test_bluesky_flies_the_converted_scenario_and_deletes_on_arrival(tmp_path: Path):
    pytest.importorskip("bluesky")
    sched = parse_schedule(io.StringIO("\n".join([HEADER, *GOOD_ROWS]) + "\n"), NET, "s.csv")
    conv = convert(sched, NET, ConvertOptions(start_s=8 * 3600.0, alt_noise_ft=100.0, seed=4))
    scn = tmp_path / "uam.scn"
    scn.write_text(conv.text)
    workdir = tmp_path / "bluesky-work"
    workdir.mkdir()
    runner = Path(__file__).with_name("bluesky_runner.py")
    out = tmp_path / "bluesky.json"
    r = subprocess.run(
        [sys.executable, str(runner), str(scn), str(workdir), "700", str(out)],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    result = json.loads(out.read_text())
    aircraft = result["aircraft"]
    assert set(aircraft) == {"F1", "F2", "F3"}, result
    assert not [e for e in result["echo"] if "error" in e.lower() or "usage" in e.lower()], result["echo"]
    noise = {line.split()[1]: float(line.split()[6]) for line in conv.text.splitlines() if ">CRE " in line}
    for f in sched.flights:
        rec = aircraft[f.callsign]
        assert rec["created_s"] == pytest.approx(f.departure_s - 8 * 3600.0, abs=0.1)
        # Deleted by ATDIST on arrival, at the right vertiport, after really flying the route.
        assert rec["deleted_s"] is not None, f"{f.callsign} never arrived"
        assert distance_m(rec["last"], NET.position(f.destination)) < 0.1 * 1852
        assert distance_m(rec["first"], NET.position(f.origin)) < 1.0
        flown = rec["deleted_s"] - rec["created_s"]
        assert flown > 0.8 * NET.path_length_m([f.origin, *f.route, f.destination]) / (150 * 0.514444)
        # The lane altitude (with its noise) is held: VNAV is off, DEST does not pull it down.
        assert rec["alt_min_ft"] == pytest.approx(noise[f.callsign], abs=1.0)
        assert rec["alt_max_ft"] == pytest.approx(noise[f.callsign], abs=1.0)
    assert scenario_names(NET)["DMH"] in conv.text
