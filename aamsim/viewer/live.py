"""The web viewer beside a running simulation (``aamsim run --view``, ``aamsim serve --view``, ``render_mode="human"``).

:class:`LiveViewer` runs the viewer's server on a daemon thread with its own
event loop, so the simulation never waits for a browser. :meth:`LiveViewer.attach`
adds a post-step hook (every second of sim time) that builds a frame only when a tenth of a second of
wall time has passed since the last one (building one for every step would
cost more than stepping), optionally holds the simulation to ``pace`` times
real time so a person can follow it, and runs the stack commands a browser
sent (only with ``allow_commands``) on the simulation's own thread.
"""

from __future__ import annotations

import asyncio
import threading
import time
from typing import TYPE_CHECKING, Any

from aamsim.viewer.frames import MapLayout, TrafficFrame, frame_from_sim, layout_from_sim
from aamsim.viewer.server import FRAME_PERIOD_S, AccessPolicy, LiveSource, ViewerApp, start_site

if TYPE_CHECKING:
    from aamsim.simulation import Simulation


HOOK_PERIOD_S = 1.0  # sim seconds between the viewer's looks at the simulation


class LiveViewer:
    """A web viewer on a daemon thread; :meth:`publish` frames to it, or :meth:`attach` a simulation."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, *, allow_commands: bool = False,
                 title: str = "live simulation", allow_hosts: tuple[str, ...] = ()) -> None:
        self.host, self.port = host, port
        self.source = LiveSource(title)
        self.viewer = ViewerApp(self.source, allow_commands=allow_commands,
                                access=AccessPolicy.for_server(host, allow_hosts, allow_commands))
        self.url: str | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._last_wall = -1.0
        self._last_simt: float | None = None
        self._shown: tuple[int, Any] | None = None  # the bridge session (and scenario) on screen

    def start(self) -> str:
        """Start serving on a daemon thread; returns the URL once the port is bound."""
        if self.url is not None:
            return self.url
        ready = threading.Event()
        failure: list[BaseException] = []

        async def main() -> None:
            self._stop = asyncio.Event()
            try:
                runner, self.url = await start_site(self.viewer, self.host, self.port)
            except Exception as exc:  # noqa: BLE001  (the port is taken, the host unknown: reported to start())
                failure.append(exc)
                ready.set()
                return
            ready.set()
            try:
                await self._stop.wait()
            finally:
                await runner.cleanup()

        def thread_main() -> None:
            self._loop = asyncio.new_event_loop()
            self._loop.run_until_complete(main())
            self._loop.close()

        self._thread = threading.Thread(target=thread_main, name="aamsim-viewer", daemon=True)
        self._thread.start()
        ready.wait(30.0)
        if failure:
            raise OSError(f"the viewer could not listen on {self.host}:{self.port}: {failure[0]}")
        if self.url is None:
            raise OSError(f"the viewer did not start on {self.host}:{self.port} within 30 s")
        return self.url

    @property
    def page_url(self) -> str | None:
        """The URL a person opens: :attr:`url`, plus the command token when commands are allowed."""
        return None if self.url is None else self.viewer.page_url(self.url)

    def publish(self, frame: TrafficFrame, layout: MapLayout | None = None) -> None:
        """Hand a frame to the browsers (never blocks; they take the latest at ten per second)."""
        self.source.publish(frame, layout)

    def attach(self, sim: Simulation, scenario_text: str | None = None, pace: float | None = None) -> None:
        """Publish ``sim``'s traffic from a post-step hook (see the module docstring)."""
        wall0 = time.perf_counter()
        simt0 = sim.simt
        layout_text = scenario_text

        def hook(s: Any) -> None:
            while self.source.commands:
                s.stack(self.source.commands.popleft())
            now = time.perf_counter()
            if pace:
                ahead = (s.simt - simt0) / pace - (now - wall0)
                if ahead > 0:
                    time.sleep(min(ahead, 1.0))
                    now = time.perf_counter()
            if now - self._last_wall >= FRAME_PERIOD_S:
                self.publish_sim(s, layout_text)
                self._last_wall = now

        # Every HOOK_PERIOD_S of sim time, not every step: a Python call per step would cost more than
        # the step (nyc_day: 10.1-10.3 s plain, 17.7 s with a hook every step, 10.5-10.7 s like this).
        sim.hooks.post_step.add(hook, name="aamsim.viewer.live", priority=900, interval_s=HOOK_PERIOD_S)
        self.publish_sim(sim, layout_text)

    def publish_sim(self, sim: Simulation, scenario_text: str | None = None) -> None:
        """Publish ``sim``'s traffic now (the map on the first call)."""
        layout = layout_from_sim(sim, scenario_text) if self.source.layout is None else None
        self.publish(frame_from_sim(sim, events_since=self._last_simt), layout)
        self._last_simt = sim.simt

    def show_episode(self, session: int, core: Any) -> None:
        """``aamsim serve --view``: the traffic of a bridge session's episode, at most ten pictures a second.

        The map follows the session: a session on another scenario brings its own.
        """
        now = time.perf_counter()
        changed = (session, core.path) != self._shown
        if not changed and now - self._last_wall < FRAME_PERIOD_S:
            return
        self._last_wall = now
        if changed:
            self._shown = (session, core.path)
            self.source.title = f"session {session}: {core.path.stem}"
            self._last_simt = None
            self.publish(frame_from_sim(core.sim), layout_from_sim(core.sim, core.text))
            self._last_simt = core.sim.simt
        else:
            self.publish_sim(core.sim)

    def finish(self, sim: Simulation | None = None) -> None:
        """Mark the simulation as over, publishing ``sim``'s last picture (the page keeps showing it)."""
        self.source.finished = True
        if sim is not None:
            self.publish_sim(sim)
        elif self.source.frame is not None:
            self.source.publish(self.source.frame)  # a new sequence number: tabs learn the run is over

    def close(self) -> None:
        """Stop the server (the daemon thread ends)."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(5.0)
        self.url = None
