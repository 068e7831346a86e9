"""A short run of the bridge abuse harness against a real ``aamsim serve`` (the long one:
``python -m tests.fuzz.bridge_abuse --messages 100000``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from bridge_util import spawn_server, stop_process

from tests.fuzz.bridge_abuse import SCENARIO, abuse


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="reads the server's size from /proc")
def test_malformed_messages_from_several_clients_never_stop_valid_episodes(tmp_path: Path) -> None:
    (tmp_path / "abuse.scn").write_text(SCENARIO)
    proc, endpoint = spawn_server("--log-level", "ERROR", cwd=tmp_path)
    try:
        # A reply later than 120 s counts as stuck: on a loaded 2-core CI machine a valid reset queued
        # behind the abusers' megabyte messages took over 30 s (the harness's own default) to come.
        result = abuse(endpoint, proc.pid, messages=1500, clients=3, seed=7, alive=lambda: proc.poll() is None,
                       timeout_ms=120_000)
    finally:
        stop_process(proc)
    assert result.server_alive and result.stuck == [] and result.wrong == []
    assert result.messages >= 1500 and result.valid >= 300
    assert result.rss_after_mb - result.rss_before_mb < 40.0
