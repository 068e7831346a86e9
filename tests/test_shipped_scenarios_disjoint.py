"""The evaluation scenario is held out: it shares no flight with the training scenario (issue 13)."""

from __future__ import annotations

import re
from pathlib import Path

from aamsim.scenarios import packaged_scenario

CRE = re.compile(r"^(\d\d):(\d\d):(\d\d\.\d\d)>(CRE (\w+) .*)$", re.MULTILINE)
WINDOW = re.compile(r"^# Window: (\d\d):(\d\d):(\d\d) to (\d\d):(\d\d):(\d\d) of the day", re.MULTILINE)


def _seconds(h: str, m: str, s: str) -> float:
    return 3600.0 * int(h) + 60.0 * int(m) + float(s)


def flights(name: str) -> tuple[tuple[float, float], dict[str, tuple[str, str, str, float]]]:
    """(window of the day [s], callsign -> (creation line, origin, destination, departure time of day [s]))."""
    path = packaged_scenario(name)
    assert path is not None, name
    text = Path(path).read_text()
    w = WINDOW.search(text)
    assert w is not None, f"{name}: no '# Window:' header"
    start, end = _seconds(*w.groups()[:3]), _seconds(*w.groups()[3:])
    out = {}
    for h, m, s, line, cs in CRE.findall(text):
        orig = re.search(rf"^\S+>ORIG {cs} (\w+)$", text, re.MULTILINE)
        dest = re.search(rf"^\S+>DEST {cs} (\w+)$", text, re.MULTILINE)
        assert orig and dest, cs
        out[cs] = (line, orig.group(1), dest.group(1), start + _seconds(h, m, s))
    return (start, end), out


def test_evaluation_traffic_shares_no_flight_with_the_training_traffic():
    (t0, t1), train = flights("nyc_train_100.scn")
    (e0, e1), ev = flights("nyc_eval_678.scn")
    assert len(train) == 100 and t1 - t0 == 25 * 60.0
    assert len(ev) == 678 and e1 - e0 == 5 * 3600.0
    assert not set(train) & set(ev), "common callsigns"
    assert not {f[0] for f in train.values()} & {f[0] for f in ev.values()}, "identical creation lines"
    assert not {f[1:] for f in train.values()} & {f[1:] for f in ev.values()}, "common (origin, destination, time)"
    assert e1 <= t0 or e0 >= t1, "the windows of the day overlap"
    # Every flight departs inside its file's window.
    assert all(t0 <= f[3] < t1 for f in train.values()) and all(e0 <= f[3] < e1 for f in ev.values())


def test_find_window_skips_windows_overlapping_an_avoided_interval():
    from uamtoolkit_import.scenarios import find_window

    dep = [0.0, 10.0, 20.0, 30.0]
    assert find_window(dep, 15.0, 2, 0.0, 40.0) == 0.0  # [0, 15) holds 0 and 10
    # [0, 12) avoided: the first start whose window [s, s + 15) is clear and holds 2 departures is 16.
    assert find_window(dep, 15.0, 2, 0.0, 40.0, avoid=((0.0, 12.0),)) == 16.0
