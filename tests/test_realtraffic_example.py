"""The Zurich example (examples/zurich_real_traffic): AAM flights meet a real REGA helicopter flight.

Runs the README's commands as a user would and checks the figures its table reports.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "zurich_real_traffic"


def _cli(module: str, *args: str, cwd: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr


def test_zurich_example_reproduces_its_encounters_with_the_rega_helicopter(tmp_path: Path) -> None:
    net = EXAMPLE / "zurich_network.json"
    _cli("uamtoolkit_import", "synth", "--network", str(net), "-o", "schedule.csv", "--fleet", "20",
         "--daily-requests", "3000", "--seed", "7", cwd=tmp_path)
    # The committed schedule and scenario are what the commands write.
    assert (tmp_path / "schedule.csv").read_text() == (EXAMPLE / "zurich_schedule.csv").read_text()
    _cli("uamtoolkit_import", "convert", "schedule.csv", "--network", str(net), "--start", "08:00", "--end", "08:30",
         "-o", "zurich_0800.scn", cwd=tmp_path)
    shipped = (EXAMPLE / "zurich_0800.scn").read_text().splitlines()
    written = (tmp_path / "zurich_0800.scn").read_text().splitlines()
    assert [x for x in written if not x.startswith("#")] == [x for x in shipped if not x.startswith("#")]
    _cli("aamsim", "run", str(EXAMPLE / "zurich_0800.scn"), "--seed", "1", "--out", "run", "--quiet",
         "--overlay", str(ROOT / "tests" / "data" / "opensky" / "rega_zh.json.gz"), "--overlay-offset", "300",
         cwd=tmp_path)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    safety = summary["safety"]
    assert (safety["nmac_events_aam_vs_aam"], safety["lowc_events_aam_vs_aam"]) == (6, 16)
    assert (safety["nmac_events_aam_vs_real_traffic"], safety["lowc_events_aam_vs_real_traffic"]) == (1, 1)
    assert summary["flights_created"] == 38
    with open(tmp_path / "run" / "conflicts.csv", newline="") as fh:
        real = [row for row in csv.DictReader(fh) if row["pair"] == "AAM vs real traffic"]
    nmac = next(row for row in real if row["volume"] == "nmac")
    assert {nmac["ac1"], nmac["ac2"]} == {"RT4B43AC", "UAM0391"}
    assert float(nmac["min_dist_m"]) == 73.85 and float(nmac["t_min_s"]) == 355.0
