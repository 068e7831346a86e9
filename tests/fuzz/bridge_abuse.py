"""Abuse of ``aamsim serve``: malformed, truncated, oversized and out-of-order messages from several
clients, interleaved with valid episodes; checks that the server never dies, that every valid request
is answered, and that its memory stays flat.

    python -m tests.fuzz.bridge_abuse --messages 100000      # the long run (figures in docs/reliability.md)

``tests/test_fuzz_bridge.py`` runs a short one.
"""

from __future__ import annotations

import argparse
import os
import random
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import msgpack
import zmq

from rlbridge.protocol import decode, request

SCENARIO = """\
00:00:00.00>CRE A1 EC35 40.700000 -74.020000 90 1000 100
00:00:00.00>ADDWPT A1 40.700000 -73.960000
00:00:00.00>CRE B1 EC35 40.677000 -73.990000 0 1000 100
00:00:00.00>ADDWPT B1 40.730000 -73.990000
00:00:20.00>CRE C1 EC35 40.700000 -74.020000 90 1000 120
00:00:20.00>ADDWPT C1 40.700000 -73.960000
"""


def malformed(rng: random.Random) -> list[bytes]:
    """One bad message (frames), of a kind drawn at random."""
    kind = rng.randrange(12)
    if kind == 0:
        return [os.urandom(rng.randint(0, 300))]
    if kind == 1:
        frames = request("reset", 1, scenario="abuse.scn", seed=1)
        return [bytes(frames[0])[: rng.randint(0, max(0, len(frames[0]) - 1))]]
    if kind == 2:
        return [msgpack.packb({"v": 1, "op": rng.choice(["frob", "", "STEP", "step\x00"]), "id": rng.randint(0, 9)})]
    if kind == 3:
        deep: object = 1
        for _ in range(rng.randint(10, 400)):
            deep = [deep] if rng.random() < 0.5 else {"k": deep}
        return [msgpack.packb({"v": 1, "op": "hello", "id": 2, "client": deep})]
    if kind == 4:
        desc = {"__nd__": rng.randint(-2, 3), "dtype": rng.choice(["float32", "object", "V8", "<f8", "int64", "x"]),
                "shape": rng.choice([[4], [-1], [2**40], [], [3, 3]])}
        return [msgpack.packb({"v": 1, "op": "step", "id": 3, "actions": desc})] + \
            [os.urandom(rng.randint(0, 64)) for _ in range(rng.randint(0, 3))]
    if kind == 5:
        return [msgpack.packb({"v": 1, "op": "hello", "id": 4, "client": "x" * rng.choice([10, 10**5, 2 * 10**6])})]
    if kind == 6:  # out of order: a session op before any session
        return request(rng.choice(["step", "stack", "state", "metrics"]), 5, **({"text": "ECHO x"} if rng.random() < .5
                                                                             else {}))
    if kind == 7:
        return request("open", 6, scenario=rng.choice(["../x.scn", "/etc/passwd", "scn/../../x", "", "a\x00b",
                                                       "nowhere.scn"]))
    if kind == 8:
        return request("reset", 7, scenario="abuse.scn", dt=rng.choice([0.0, -1.0, 1e300, float("nan"), 1e-9]))
    if kind == 9:
        return [msgpack.packb([1, 2, 3])] + [b""] * rng.randint(0, 3)
    if kind == 10:
        return [msgpack.packb({"v": rng.choice([0, 2, "1", None]), "op": "hello", "id": 8})]
    return [b""] + request("hello", 9)  # an empty first frame (a REQ delimiter from a DEALER)


@dataclass
class Tally:
    lock: threading.Lock = field(default_factory=threading.Lock)
    sent: int = 0
    valid: int = 0
    stuck: list[str] = field(default_factory=list)
    wrong: list[str] = field(default_factory=list)
    # What to send again, alone on a fresh connection, for each entry of ``stuck``: a request left
    # unanswered under load is a failure only when it is unanswered again alone.
    replay: list[list[list[bytes]]] = field(default_factory=list)

    def stuck_on(self, what: str, messages: list[list[bytes]]) -> None:
        with self.lock:
            self.stuck.append(what)
            self.replay.append(messages)

    def add(self, sent: int = 0, valid: int = 0) -> None:
        with self.lock:
            self.sent += sent
            self.valid += valid


def _socket(ctx: zmq.Context, endpoint: str, timeout_ms: int) -> zmq.Socket:
    sock = ctx.socket(zmq.DEALER)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
    sock.setsockopt(zmq.SNDTIMEO, timeout_ms)
    sock.connect(endpoint)
    return sock


def abuser(endpoint: str, count: int, seed: int, tally: Tally, timeout_ms: int) -> None:
    """Sends bad messages on its own connection, then a valid hello: it must still be answered."""
    ctx = zmq.Context()
    rng = random.Random(seed)
    sock = _socket(ctx, endpoint, timeout_ms)
    try:
        for k in range(count):
            bad = malformed(rng)
            sock.send_multipart(bad)
            try:
                sock.recv_multipart()  # a reply (error) to each; some bad frames get none: drain what comes
            except zmq.Again:
                tally.stuck_on(f"abuser {seed}: no reply to a malformed message {k}", [bad])
                return
            tally.add(sent=1)
            if k % 50 == 49:  # a valid request among the bad ones, on the same connection
                sock.send_multipart(request("hello", 10_000 + k))
                try:
                    reply = decode(sock.recv_multipart())
                except zmq.Again:
                    tally.stuck_on(f"abuser {seed}: valid hello not answered", [request("hello", 10_000 + k)])
                    return
                tally.add(sent=1, valid=1)
                if reply.get("ok") is not True or reply.get("id") != 10_000 + k:
                    tally.wrong.append(f"abuser {seed}: hello after bad messages answered {reply}")
    except zmq.Again:  # a send that could not go out
        tally.stuck_on(f"abuser {seed}: a message could not be sent", [request("hello", 1)])
    finally:
        sock.close(0)
        ctx.term()


def player(endpoint: str, count: int, seed: int, tally: Tally, timeout_ms: int) -> None:
    """Plays valid episodes (reset, steps, metrics, close) and checks every reply."""
    ctx = zmq.Context()
    rng = random.Random(seed)
    sock = _socket(ctx, endpoint, timeout_ms)
    msg_id = 0
    episode: list[list[bytes]] = []  # this episode's requests so far: what a rerun alone sends again

    def ask(frames: list, what: str) -> dict | None:
        episode.append(frames)
        sock.send_multipart(frames)
        try:
            reply = decode(sock.recv_multipart())
        except zmq.Again:
            tally.stuck_on(f"player {seed}: {what} not answered within {timeout_ms / 1000:g} s", list(episode))
            return None
        tally.add(sent=1, valid=1)
        if reply.get("ok") is not True:
            tally.wrong.append(f"player {seed}: {what} failed: {reply}")
            return None
        return reply

    try:
        while tally.valid < count and not tally.stuck:
            msg_id += 1
            episode.clear()
            opened = ask(request("reset", msg_id, scenario="abuse.scn", seed=rng.randint(0, 10**6)), "reset")
            if opened is None:
                return
            agents = list(opened.get("agents", []))
            for _ in range(rng.randint(1, 6)):
                msg_id += 1
                stepped = ask(request("step", msg_id, actions={a: rng.randint(0, 2) for a in agents}), "step")
                if stepped is None:
                    return
                agents = list(stepped.get("agents", []))
                if not agents:
                    break
            msg_id += 1
            if ask(request("metrics", msg_id), "metrics") is None or ask(request("close", msg_id + 1), "close") is None:
                return
            msg_id += 1
    finally:
        sock.close(0)
        ctx.term()


def rss_mb(pid: int) -> float:
    return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


@dataclass
class AbuseResult:
    messages: int
    valid: int
    server_alive: bool
    stuck: list[str]  # unanswered, and unanswered again when sent alone
    wrong: list[str]
    rss_before_mb: float
    rss_after_mb: float
    wall_s: float
    unconfirmed_stuck: list[str] = field(default_factory=list)  # unanswered under load, answered alone


def answered_alone(endpoint: str, messages: list[list[bytes]], timeout_ms: int) -> bool:
    """Send the messages again, one after the other, on a fresh connection: is the last one answered?"""
    ctx = zmq.Context()
    sock = _socket(ctx, endpoint, timeout_ms)
    try:
        for frames in messages:
            sock.send_multipart(frames)
            sock.recv_multipart()
        return True
    except zmq.Again:
        return False
    finally:
        sock.close(0)
        ctx.term()


def abuse(endpoint: str, pid: int, messages: int, clients: int = 4, seed: int = 0,
          timeout_ms: int = 30_000, alive: object = None) -> AbuseResult:
    """``messages`` bad messages over ``clients`` abusers, with as many players playing valid episodes."""
    tally = Tally()
    t0 = time.perf_counter()
    warm = threading.Thread(target=player, args=(endpoint, 20, seed + 999, tally, timeout_ms))
    warm.start()
    warm.join()
    before = rss_mb(pid)
    tally.valid = 0
    per = max(1, messages // clients)
    threads = [threading.Thread(target=abuser, args=(endpoint, per, seed + k, tally, timeout_ms)) for k in range(clients)]
    threads += [threading.Thread(target=player, args=(endpoint, messages // 5, seed + 100 + k, tally, timeout_ms))
                for k in range(max(1, clients // 2))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    server_alive = bool(alive()) if callable(alive) else True
    after = rss_mb(pid) if server_alive else float("nan")
    stuck, unconfirmed = [], []
    for what, sequence in zip(tally.stuck, tally.replay):
        again = server_alive and answered_alone(endpoint, sequence, timeout_ms)
        (unconfirmed if again else stuck).append(what)
    return AbuseResult(tally.sent, tally.valid, server_alive, stuck, tally.wrong, before, after,
                       time.perf_counter() - t0, unconfirmed)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--messages", type=int, default=10_000)
    parser.add_argument("--clients", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    import tempfile

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from bridge_util import spawn_server, stop_process

    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "abuse.scn").write_text(SCENARIO)
        proc, endpoint = spawn_server("--log-level", "ERROR", cwd=Path(folder))
        try:
            result = abuse(endpoint, proc.pid, args.messages, args.clients, args.seed,
                           alive=lambda: proc.poll() is None)
        finally:
            stop_process(proc)
    print(f"{result.messages} messages ({result.valid} valid) in {result.wall_s:.0f} s from {args.clients} abusers "
          f"and {max(1, args.clients // 2)} players: server {'alive' if result.server_alive else 'DEAD'}, "
          f"{len(result.stuck)} stuck (again alone), {len(result.unconfirmed_stuck)} late under load only, "
          f"{len(result.wrong)} wrong replies; server RSS {result.rss_before_mb:.1f} -> {result.rss_after_mb:.1f} MB")
    for line in (result.stuck + result.wrong)[:20]:
        print("  " + line)
    return 0 if result.server_alive and not result.stuck and not result.wrong else 1


if __name__ == "__main__":
    sys.exit(main())
