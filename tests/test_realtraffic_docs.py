"""docs/real-traffic.md: its example runs and prints what the page says it prints."""

from __future__ import annotations

import contextlib
import io
import re
import runpy

import pytest
from bridge_util import ROOT

from aamsim.realtraffic import RecordingError, read_reports

DOC = ROOT / "docs" / "real-traffic.md"


def test_the_documented_example_prints_what_the_page_shows(monkeypatch, tmp_path):
    text = DOC.read_text()
    code = re.search(r"```python\n(.*?)```", text, re.DOTALL)
    shown = re.search(r"```text\n(.*?)```", text, re.DOTALL)
    assert code and shown, "docs/real-traffic.md lost its example or its output"
    monkeypatch.chdir(ROOT)  # the example names the sample by its path from the repository root
    example = tmp_path / "real_traffic_example.py"
    example.write_text(code.group(1))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        runpy.run_path(str(example), run_name="docs_example")
    assert out.getvalue() == shown.group(1)


def test_the_documented_error_messages_are_the_ones_raised(tmp_path):
    """Each message in the errors table, produced for real (the file name aside)."""
    table = DOC.read_text().split("## Errors")[1].split("A row that cannot")[0]
    cases = {
        "time,icao24,lat,lon,baroaltitude,wind": "unknown column",
        "time,icao24,lat,lon,baroaltitude,groundspeed": "mixed units",
        "time,icao24,lat,lon,geoaltitude": "unit not told",
        "time,icao24,lon,baroaltitude": "no position",
        "icao24,lat,lon,baroaltitude": "no time",
    }
    for header, case in cases.items():
        path = tmp_path / "f.csv"
        path.write_text(header + "\n")
        with pytest.raises(RecordingError) as caught:
            read_reports(path)
        message = str(caught.value).replace(str(path), "f.csv")
        row = next(line for line in table.splitlines() if line.startswith(f"| {case}"))
        assert f"`{message}`" in row, (case, message)
