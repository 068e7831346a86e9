"""Helpers shared by the tests of ``uamtoolkit_import``."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

HEADER = (
    "flight_id,tail_id,aircraft_type,origin,destination,departure_time,arrival_time,route,"
    "cruise_speed_kts,cruise_alt_ft,passengers,cargo_kg"
)

# Three good flights on the New York network (the route includes its end points or not).
GOOD_ROWS = (
    "F1,N001,EVTOL4,DMH,W30,08:00:00,08:04:00,DMH HUD02 HUD03 W30,120,500,2,10",
    "F2,N002,EVTOL4,W30,DMH,08:01:00,08:05:00,HUD03 HUD02,100,1200,1,0",
    "F3,N003,EVTOL4,E34,LGA,08:02:30,08:09:00,ER06 ER07 ER08 ER09 ER10,140,500,3,45.5",
)


def write_csv(path: Path, header: str, rows: tuple[str, ...] | list[str]) -> Path:
    path.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return path


def run_module(
    module: str, *args: str, cwd: Path | None = None, timeout: float = 300
) -> subprocess.CompletedProcess[str]:
    """``python -m module args`` with the repository first on the path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=cwd or REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def read_flights(run_dir: Path) -> dict[str, dict[str, str]]:
    with open(run_dir / "flights.csv", newline="") as fh:
        return {row["id"]: row for row in csv.DictReader(fh)}


def created_callsigns(scn_text: str) -> list[str]:
    return [
        line.split(">", 1)[1].split()[1]
        for line in scn_text.splitlines()
        if ">" in line and line.split(">", 1)[1].startswith("CRE ")
    ]
