"""The viewer on run directories nobody checked (issue 26, items 7 and 8).

A 20,000-character id made every id array that wide (8.7 GB for a 1.9 MB file); a last row cut short
by a full disk, NaN in a CSV, a ``summary.json`` of the wrong shape and a 400-digit ``seek`` each ended
``aamsim view`` or its stream.
"""

from __future__ import annotations

import asyncio
import json
import math
import subprocess
import sys
from pathlib import Path

import aiohttp
import numpy as np
import pytest

from aamsim.units import MAX_CALLSIGN_CHARS
from aamsim.viewer.frames import ReplayError, RunReplay
from aamsim.viewer.server import ControlError, ReplaySource, ViewerApp, parse_control, start_site
from tests.test_viewer_frames import TRAJ_HEADER, run_dir  # noqa: F401  (fixture)

ROOT = Path(__file__).resolve().parents[1]


def _rows(n: int, name: str = "A{k}") -> list[str]:
    return [f"{name.format(k=k % 7)},{k // 7}.00,40.0,-74.0,150.0,50.0,50.0,50.0,90.0,0.0" for k in range(n)]


def test_ids_are_coded_in_one_pass_sorted_and_as_wide_as_the_longest(tmp_path: Path) -> None:
    rows = ["B,1.00,40.0,-74.0,150.0,50.0,50.0,50.0,90.0,0.0", "A,1.00,41.0,-74.0,150.0,50.0,50.0,50.0,90.0,0.0",
            "CC,2.00,42.0,-74.0,150.0,50.0,50.0,50.0,90.0,0.0", "B,2.00,43.0,-74.0,150.0,50.0,50.0,50.0,90.0,0.0"]
    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER + "\n".join(rows) + "\n")
    r = RunReplay(tmp_path)
    assert r.callsigns.tolist() == ["A", "B", "CC"] and r.callsigns.dtype == np.dtype("<U2")
    assert r.frame_at(1.0).ids == ("B", "A") and r.frame_at(1.0).lat.tolist() == [40.0, 41.0]
    assert r.frame_at(2.0).ids == ("CC", "B") and r.warnings == []


def test_an_id_longer_than_a_callsign_is_refused_naming_its_line(tmp_path: Path) -> None:
    rows = _rows(2_000)
    rows[1_234] = "X" * 20_000 + rows[1_234][2:]
    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER + "\n".join(rows) + "\n")
    with pytest.raises(ReplayError, match=f"line 1236: an id of 20,000 characters; a callsign has at most "
                                          f"{MAX_CALLSIGN_CHARS}"):
        RunReplay(tmp_path)


def test_an_id_of_the_longest_callsign_is_read(tmp_path: Path) -> None:
    long_id = "L" * MAX_CALLSIGN_CHARS
    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER + "\n".join(_rows(20, long_id)) + "\n")
    assert RunReplay(tmp_path).callsigns.tolist() == [long_id]


def test_cre_refuses_a_callsign_longer_than_a_callsign_can_be() -> None:
    """The simulation never writes an id the viewer would refuse: CRE stops at MAX_CALLSIGN_CHARS too."""
    from aamsim import Simulation

    sim = Simulation(use_bluesky_navdata=False)
    sim.stack(f"CRE {'L' * MAX_CALLSIGN_CHARS} EC35 40.7 -74.0 0 500 10")
    sim.stack(f"CRE {'X' * 20_000} EC35 40.7 -74.0 0 500 10")
    assert sim.view.n == 1
    assert sim.reporter.errors()[-1].text.endswith(
        f"a callsign has at most {MAX_CALLSIGN_CHARS} characters, not 20,000")


def test_a_last_row_cut_short_is_left_out_with_a_warning(run_dir: Path) -> None:  # noqa: F811
    path = run_dir / "trajectories.csv"
    path.write_text(path.read_text() + "A1,13.00,40.00269")  # the disk filled up here
    r = RunReplay(run_dir)
    assert r.t_end == 12.0 and len(r.warnings) == 1 and "line 7: cut short" in r.warnings[0]


def test_a_run_cut_short_is_viewable_and_the_cli_warns(run_dir: Path) -> None:  # noqa: F811
    path = run_dir / "trajectories.csv"
    path.write_text(path.read_text() + "A1,13.00,40.00269")
    proc = subprocess.run([sys.executable, "-m", "aamsim", "figure", str(run_dir), "-o", str(run_dir / "m.png"),
                           "--snapshot", "none"], capture_output=True, text=True, timeout=300, cwd=ROOT, check=False)
    assert proc.returncode == 0, proc.stderr
    assert (run_dir / "m.png").stat().st_size > 0


def test_non_finite_values_are_null_in_frames_and_the_map_stays_finite(run_dir: Path) -> None:  # noqa: F811
    path = run_dir / "trajectories.csv"
    text = path.read_text().replace("A2,10.00,40.0100000,-74.0000000,150.0", "A2,10.00,nan,-74.0000000,inf")
    path.write_text(text)
    r = RunReplay(run_dir)
    body = r.frame_at(10.0).to_json()
    json.dumps(body, allow_nan=False)  # what the WebSocket sends
    assert body["lat"] == [40.0, None] and body["alt"] == [150.0, None]
    assert all(math.isfinite(b) for b in r.layout().bounds)


@pytest.mark.parametrize("summary", [
    '{"operational": [1, 2]}', '{"safety": "none", "operational": null}', '{"scenario": 5, "safety": {"x": NaN}}',
    '{"operational": {"holding_speed_threshold_mps": "fast"}}', "[" * 100_000 + "]" * 100_000,
])
def test_a_malformed_summary_never_ends_the_viewer_with_a_traceback(run_dir: Path, summary: str) -> None:  # noqa: F811
    (run_dir / "summary.json").write_text(summary)
    try:
        r = RunReplay(run_dir)
    except ReplayError as exc:  # a clear refusal naming the file is fine
        assert "summary.json" in str(exc)
        return
    meta = ReplaySource(r).meta()
    json.dumps(meta, allow_nan=False)
    assert r.hold_speed_mps > 0


@pytest.mark.parametrize("text", [
    '{"op": "seek", "t": 1' + "0" * 400 + "}", '{"op": "speed", "x": -1' + "0" * 400 + "}",
    '{"op": "seek", "t": ' + "9" * 5000 + "}",
])
def test_a_huge_integer_is_refused_as_a_control_message(text: str) -> None:
    with pytest.raises(ControlError):
        parse_control(text, "replay", False)


def test_a_400_digit_seek_is_answered_and_the_stream_goes_on(run_dir: Path) -> None:  # noqa: F811
    path = run_dir / "trajectories.csv"
    path.write_text(path.read_text().replace("A2,11.00,40.0099910", "A2,11.00,nan"))

    async def main() -> None:
        runner, url = await start_site(ViewerApp(ReplaySource(RunReplay(run_dir))), "127.0.0.1", 0)
        try:
            async with aiohttp.ClientSession() as http:
                async with http.get(url + "api/frame?t=11") as res:
                    body = json.loads(await res.text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
                    assert res.status == 200 and body["lat"][1] is None
                async with http.ws_connect(url + "ws") as ws:
                    assert (await ws.receive_json(timeout=10))["type"] == "frame"
                    await ws.send_str('{"op": "pause"}')
                    await ws.send_str('{"op": "seek", "t": 1' + "0" * 400 + "}")
                    await ws.send_str('{"op": "seek", "t": 11}')
                    seen = []
                    while not seen or seen[-1].get("simt") != 11.0:
                        msg = await ws.receive(timeout=10)
                        assert msg.type == aiohttp.WSMsgType.TEXT, msg  # not an HTTP 500, not a close
                        seen.append(json.loads(msg.data))
                    assert any(m["type"] == "error" and "finite number" in m["error"] for m in seen)
        finally:
            await runner.cleanup()

    asyncio.run(main())
