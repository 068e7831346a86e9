"""Live real traffic: OpenSky's REST ``states/all`` polled for a box while the simulation runs
paced to real time (``--overlay opensky:LAT0,LON0,LAT1,LON1``, ``REPLAY OPENSKY``).

The live picture is shown ``delay_s`` behind the wall clock (two poll intervals plus 5 s) so
that every aircraft sits between two received reports and is interpolated as in a recording.
Polls follow OpenSky's documented limits (openskynetwork.github.io/opensky-api/rest.html):
state vectors have a 10 s resolution for anonymous users and 5 s with an account, a request
for a box of up to 25 square degrees costs one credit (2, 3, 4 for up to 100, 400, more), and
the daily credits are 400 anonymous, 4,000 with an account; a 429 answer says in
``X-Rate-Limit-Retry-After-Seconds`` when to ask again, which is obeyed. An account is used
through OAuth2 client credentials from ``OPENSKY_CLIENT_ID`` and ``OPENSKY_CLIENT_SECRET``
(basic authentication is no longer accepted by OpenSky).

A network failure, an HTTP error, a timeout or a broken answer never stops the run: it is
reported once when it starts (and when polls work again), and polls back off (doubling the
interval, at most 5 minutes); aircraft whose reports stop leave when their track ends.
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
import urllib.error
import urllib.parse
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from aamsim.errors import CommandError
from aamsim.realtraffic.columns import ColumnPlan, plan_columns
from aamsim.realtraffic.http_get import Answer, FetchProblem, fetch
from aamsim.realtraffic.normalise import normalise
from aamsim.realtraffic.reports import SkipLog, StateReports
from aamsim.realtraffic.sources import rest_response_chunks
from aamsim.realtraffic.tracks import TrackSet, build_tracks

if TYPE_CHECKING:
    from aamsim.realtraffic.replay import BBox, Replay
    from aamsim.stack.context import CommandContext

OPENSKY_API_URL = "https://opensky-network.org/api"
OPENSKY_TOKEN_URL = "https://auth.opensky-network.org/auth/realms/opensky-network/protocol/openid-connect/token"
ANONYMOUS_INTERVAL_S = 10.0  # OpenSky's time resolution for anonymous users
ACCOUNT_INTERVAL_S = 5.0  # ... and for users with an account
DAILY_CREDITS = {"anonymous": 400, "account": 4000}
MAX_BACKOFF_S = 300.0
TIMEOUT_S = 5.0  # each socket operation of a poll
DEADLINE_S = 15.0  # a whole poll: connection, redirects, headers and body
# The largest answer read [bytes]. OpenSky's states/all for the whole world, about 10,000 aircraft,
# is about 2 MB of JSON; a box is far less. (A 400 MB answer used to be read whole: 975 MB resident.)
MAX_BODY_BYTES = 16 * 1024 * 1024
MAX_TOKEN_BYTES = 64 * 1024


def credits_per_request(box: BBox) -> int:
    """OpenSky's credit cost of one ``states/all`` request for a box (square degrees)."""
    area = abs(box[2] - box[0]) * abs(box[3] - box[1])
    return 1 if area <= 25 else 2 if area <= 100 else 3 if area <= 400 else 4


@dataclass(frozen=True)
class LiveSettings:
    """Where and how to poll; :meth:`from_env` reads the environment."""

    api_url: str = OPENSKY_API_URL
    token_url: str = OPENSKY_TOKEN_URL
    client_id: str = ""
    client_secret: str = field(default="", repr=False)
    interval_s: float | None = None  # None: OpenSky's resolution (10 s anonymous, 5 s with an account)
    timeout_s: float = TIMEOUT_S
    deadline_s: float = DEADLINE_S
    max_body_bytes: int = MAX_BODY_BYTES

    @staticmethod
    def from_env(env: dict[str, str] | None = None) -> LiveSettings:
        """``OPENSKY_CLIENT_ID`` / ``OPENSKY_CLIENT_SECRET`` (an account), ``AAMSIM_OPENSKY_URL`` and
        ``AAMSIM_OPENSKY_TOKEN_URL`` (another server, e.g. a recorded one), ``AAMSIM_OPENSKY_INTERVAL_S``,
        ``AAMSIM_OPENSKY_TIMEOUT_S`` (each socket operation), ``AAMSIM_OPENSKY_DEADLINE_S`` (a whole poll)."""
        env = dict(os.environ) if env is None else env
        interval = env.get("AAMSIM_OPENSKY_INTERVAL_S")
        timeout = env.get("AAMSIM_OPENSKY_TIMEOUT_S")
        deadline = env.get("AAMSIM_OPENSKY_DEADLINE_S")
        return LiveSettings(
            api_url=env.get("AAMSIM_OPENSKY_URL", OPENSKY_API_URL).rstrip("/"),
            token_url=env.get("AAMSIM_OPENSKY_TOKEN_URL", OPENSKY_TOKEN_URL),
            client_id=env.get("OPENSKY_CLIENT_ID", ""), client_secret=env.get("OPENSKY_CLIENT_SECRET", ""),
            interval_s=float(interval) if interval else None, timeout_s=float(timeout) if timeout else TIMEOUT_S,
            deadline_s=float(deadline) if deadline else DEADLINE_S,
        )

    @property
    def account(self) -> bool:
        return bool(self.client_id and self.client_secret)

    @property
    def poll_interval_s(self) -> float:
        """OpenSky's resolution, or a longer interval asked for; another server (a recorded one on
        loopback) has no such limit and is polled as asked."""
        resolution = ACCOUNT_INTERVAL_S if self.account else ANONYMOUS_INTERVAL_S
        if self.api_url != OPENSKY_API_URL and self.interval_s:
            return self.interval_s
        return max(self.interval_s or resolution, resolution)


@dataclass
class PollResult:
    reports: StateReports | None  # None: the poll failed (``problem`` says why)
    problem: str = ""
    retry_after_s: float | None = None


class OpenSkyClient:
    """``GET {api}/states/all?lamin&lomin&lamax&lomax`` (with a bearer token when there is an account)."""

    def __init__(self, box: BBox, settings: LiveSettings):
        self.box, self.settings = box, settings
        self.skipped = SkipLog()
        self.polls = 0
        self.remaining_credits: int | None = None
        self._token, self._token_until = "", 0.0
        self._plan: ColumnPlan | None = None

    @property
    def url(self) -> str:
        lat0, lon0, lat1, lon1 = self.box
        query = urllib.parse.urlencode({"lamin": lat0, "lomin": lon0, "lamax": lat1, "lomax": lon1})
        return f"{self.settings.api_url}/states/all?{query}"

    def _fetch(self, url: str, headers: dict[str, str], data: bytes | None = None,
               max_bytes: int | None = None) -> Answer:
        st = self.settings
        return fetch(url, headers=headers, data=data, timeout_s=st.timeout_s, deadline_s=st.deadline_s,
                     max_bytes=st.max_body_bytes if max_bytes is None else max_bytes)

    def _bearer(self) -> dict[str, str]:
        if not self.settings.account:
            return {}
        if time.time() >= self._token_until:
            form = urllib.parse.urlencode({"grant_type": "client_credentials", "client_id": self.settings.client_id,
                                           "client_secret": self.settings.client_secret}).encode()
            answer = self._fetch(self.settings.token_url, {}, data=form, max_bytes=MAX_TOKEN_BYTES)
            token = json.loads(answer.body)
            if not isinstance(token, dict):
                raise ValueError("the token answer is not a JSON object")
            self._token = str(token["access_token"])
            self._token_until = time.time() + float(token.get("expires_in", 1800)) - 60.0
        return {"Authorization": f"Bearer {self._token}"}

    def poll(self) -> PollResult:
        """One request, bounded (:mod:`aamsim.realtraffic.http_get`); every failure comes back as a
        :class:`PollResult` with its ``problem``."""
        self.polls += 1
        try:
            answer = self._fetch(self.url, {"Accept": "application/json", **self._bearer()})
            remaining = answer.headers.get("X-Rate-Limit-Remaining")
            self.remaining_credits = int(remaining) if remaining and remaining.isdigit() else None
            body = answer.body
        except urllib.error.HTTPError as err:
            retry = err.headers.get("X-Rate-Limit-Retry-After-Seconds") if err.headers else None
            if err.code == 429:
                return PollResult(None, "rate limit reached (HTTP 429)", _seconds(retry))
            return PollResult(None, f"HTTP {err.code} {err.reason}")
        except FetchProblem as err:
            return PollResult(None, err.problem)
        except TimeoutError:
            return PollResult(None, f"no answer within {self.settings.timeout_s:g} s")
        except (urllib.error.URLError, OSError) as err:
            reason = getattr(err, "reason", err)
            return PollResult(None, f"unreachable ({reason})")
        except (KeyError, ValueError, TypeError, RecursionError) as err:
            return PollResult(None, f"authentication failed ({type(err).__name__}: {str(err)[:200]})")
        try:
            response = json.loads(body)
        except (ValueError, RecursionError) as err:  # RecursionError: arrays nested thousands deep
            return PollResult(None, f"not JSON ({type(err).__name__}: {str(err)[:200]})")
        if not isinstance(response, dict) or "states" not in response:
            return PollResult(None, "not a states/all answer (no 'states')")
        return PollResult(self._reports(response))

    def _reports(self, response: dict[str, Any]) -> StateReports:
        def plan_for(names: Sequence[str]) -> ColumnPlan:
            self._plan = plan_columns("opensky", names)
            return self._plan

        blocks = [normalise(raw, self._plan, self.skipped)  # type: ignore[arg-type]  # planned by the chunk
                  for raw in rest_response_chunks("opensky", response, self.polls, plan_for, self.skipped)]
        return StateReports.concat(blocks)


def _seconds(text: str | None) -> float | None:
    """A ``Retry-After``-style number of seconds, or None when it is missing or not a sane number."""
    try:
        value = float(text) if text else None
    except ValueError:
        return None
    return value if value is not None and 0.0 <= value <= 86_400.0 else None


class LiveFeed:
    """Polled OpenSky state vectors as a :class:`~aamsim.realtraffic.replay.TrackFeed` (recording time =
    the wall clock less ``delay_s``).

    Polls run in a background thread, one at a time: the simulation loop only
    starts a poll when one is due and takes its result once it has come, so a
    slow or hostile server never holds up a step, ``--until`` or a signal (the
    poll itself is bounded by :mod:`aamsim.realtraffic.http_get`). A poll
    still running when the run ends is abandoned (its thread is a daemon).
    """

    def __init__(self, client: OpenSkyClient, *, max_gap_s: float = 60.0, clock: Callable[[], float] = time.time,
                 report: Callable[[str, str], None] | None = None):
        self.client, self.max_gap_s, self.clock = client, max_gap_s, clock
        self.interval_s = client.settings.poll_interval_s
        self.delay_s = 2.0 * self.interval_s + 5.0
        self.report = report or (lambda kind, text: None)
        self._reports = StateReports.empty()
        self._tracks: TrackSet = build_tracks(self._reports)
        self._next_poll = -math.inf
        self._backoff = self.interval_s
        self._in_flight: tuple[threading.Thread, float, list[PollResult]] | None = None  # thread, start, result
        self.problem = ""
        self.failures = 0
        self.problems: dict[str, int] = {}

    @property
    def skipped(self) -> SkipLog:
        return self.client.skipped

    def start(self) -> float:
        self._poll_if_due()
        return self.clock() - self.delay_s

    def _poll_if_due(self) -> None:
        if self._in_flight is not None:
            thread, started, done = self._in_flight
            if thread.is_alive():
                return
            self._in_flight = None
            self._take(done[0], started)
        now = self.clock()
        if now < self._next_poll:
            return
        self._next_poll = math.inf  # set when the result is taken
        result: list[PollResult] = []
        thread = threading.Thread(target=self._poll_into, args=(result,), name="opensky-poll", daemon=True)
        self._in_flight = (thread, now, result)
        thread.start()

    def _poll_into(self, result: list[PollResult]) -> None:
        """The poll thread: one poll, its result (or the failure that escaped it) into ``result``."""
        try:
            result.append(self.client.poll())
        except Exception as exc:  # noqa: BLE001 - a failed poll is a message; the run goes on
            result.append(PollResult(None, f"the poll failed ({type(exc).__name__}: {str(exc)[:200]})"))

    def wait_idle(self, timeout_s: float) -> bool:
        """Wait for the poll in flight, if any, for at most ``timeout_s``; True when none is left in flight
        (tests, and a caller that wants the newest picture now)."""
        if self._in_flight is not None:
            self._in_flight[0].join(timeout_s)
            return not self._in_flight[0].is_alive()
        return True

    def _take(self, result: PollResult, started: float) -> None:
        """A poll's result: schedules the next poll from the time this one started."""
        if result.reports is None:
            self.failures += 1
            self.problems[result.problem] = self.problems.get(result.problem, 0) + 1
            wait = result.retry_after_s if result.retry_after_s is not None else self._backoff
            self._backoff = min(2.0 * self._backoff, MAX_BACKOFF_S)
            if result.problem != self.problem:
                self.report("warning", f"OpenSky {self.client.url}: {result.problem}; the simulation goes on, "
                                       f"next try in {wait:.0f} s")
            self.problem = result.problem
            self._next_poll = started + wait
            return
        if self.problem:
            self.report("note", f"OpenSky answers again after {self.problem}")
        self.problem, self._backoff = "", self.interval_s
        self._next_poll = started + self.interval_s
        keep = self._reports.t_s >= started - self.delay_s - 2.0 * self.max_gap_s
        self._reports = StateReports.concat([self._reports.take(keep), result.reports])
        self._tracks = build_tracks(self._reports, max_gap_s=self.max_gap_s)

    def live_time(self, t: float) -> float:
        """The recording time to show: the wall clock less the delay, whatever the simulation's time
        (a simulation that fell behind real time still shows the traffic of now)."""
        return self.clock() - self.delay_s

    def tracks_at(self, t: float) -> TrackSet:
        self._poll_if_due()
        return self._tracks

    def finished(self, t: float) -> bool:
        return False  # live traffic never ends: the run stops at --until, QUIT or Ctrl-C


class Pacer:
    """Holds the simulation to the wall clock: sim time never runs ahead of the time elapsed.

    A simulation that fell more than ``max_behind_s`` behind (a first compilation, a stalled
    poll) is not raced to catch up: pacing starts again from where it is (live traffic is
    shown at the wall clock's time anyway, see :meth:`LiveFeed.live_time`).
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep,
                 max_behind_s: float = 1.0):
        self.clock, self.sleep, self.max_behind_s = clock, sleep, max_behind_s
        self._origin: tuple[float, float] | None = None  # (sim time, wall time) pacing counts from
        self.restarts = 0

    def __call__(self, sim: CommandContext) -> None:
        if self._origin is None:
            self._origin = (sim.simt, self.clock())
        ahead = (sim.simt - self._origin[0]) - (self.clock() - self._origin[1])
        if ahead > 0:
            self.sleep(ahead)
        elif ahead < -self.max_behind_s:
            self.restarts += 1
            sim.note_once("live.behind", f"the simulation fell {-ahead:.1f} s behind real time at sim time "
                                         f"{sim.simt:.1f} s; paced from there on (not raced to catch up)")
            self._origin = (sim.simt, self.clock())


def start_live(sim: CommandContext, box: BBox, settings: LiveSettings | None = None) -> Replay:
    """Overlay live OpenSky traffic in ``box`` from now on, and pace the simulation to real time."""
    from aamsim.realtraffic.replay import Alignment, Replay, next_prefix, replays_of

    settings = settings or LiveSettings.from_env()
    if any("live" in r.name for r in replays_of(sim)):
        raise CommandError("a live OpenSky overlay is already running")
    client = OpenSkyClient(box, settings)
    feed = LiveFeed(client, report=lambda kind, text: sim.report(kind, text))
    tier = "account" if settings.account else "anonymous"
    cost = credits_per_request(box)
    lasts_h = DAILY_CREDITS[tier] / cost * feed.interval_s / 3600.0
    sim.report("note", f"live OpenSky ({tier}): polling {client.url} every {feed.interval_s:g} s, {cost} credit(s) "
                       f"each of {DAILY_CREDITS[tier]} a day (they last {lasts_h:.1f} h at this rate); traffic shown "
                       f"{feed.delay_s:g} s behind real time; the simulation runs paced to real time")
    replay = Replay(feed, name=f"live OpenSky {box}", prefix=next_prefix(sim), alignment=Alignment(sim.simt))
    replay.attach(sim)
    if "live.pacer" not in sim.hooks.pre_step.names():
        sim.hooks.pre_step.add(Pacer(), interval_s=0.1, name="live.pacer", priority=1)
    return replay
