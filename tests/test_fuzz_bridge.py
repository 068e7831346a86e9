"""A short run of the bridge abuse harness against a real ``aamsim serve`` (the long one:
``python -m tests.fuzz.bridge_abuse --messages 100000``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bridge_util import spawn_server, stop_process, thread_server

from rlbridge.protocol import request
from tests.fuzz.bridge_abuse import SCENARIO, abuse, answered_alone


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


def test_a_request_unanswered_under_load_is_sent_again_alone_before_it_counts_as_stuck() -> None:
    """Issue 26: only a request unanswered again, alone on a fresh connection, fails the harness."""
    with thread_server(max_message_bytes=100_000) as server:
        assert answered_alone(server.endpoint, [request("hello", 1), request("hello", 2)], timeout_ms=120_000)
        # A frame over the transport limit: ZeroMQ drops the connection, no reply can ever come.
        assert not answered_alone(server.endpoint, [request("hello", 3, client=np.zeros(100_000, np.float32))],
                                  timeout_ms=2_000)
