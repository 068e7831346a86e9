"""Episodes on BlueSky: ``backend="bluesky"`` (``bluesky-simulator``, in this process, headless).

BlueSky flies the aircraft; aamsim keeps a *mirror* of the scenario so that
any use case runs unchanged (it reads ``sim.view`` and changes aircraft with
intents, as on the other backends):

* BlueSky loads and runs the scenario file itself (its own parser, autopilot,
  performance model and kinematics);
* the mirror, an aamsim simulation of the same scenario, gives the routes,
  the flight records and the creation/deletion events; at every conflict-check
  instant (``DT ASAS``, 1 s) a post-step hook advances BlueSky to the mirror's
  time and overwrites the mirror's positions, speeds and directions with
  BlueSky's, before the conflict check runs, so observations, rewards and
  NMAC/LoWC events are computed on BlueSky's trajectories;
* actions: after the use case applied its intents to the mirror, what they
  changed is sent to BlueSky as its own commands: a selected speed as ``SPD``,
  a selected altitude as ``ALT`` (with the selected vertical speed), a selected
  heading (LNAV switched off, or the autopilot's track changed while off) as
  ``HDG``, and the route resumed (LNAV switched on) as ``LNAV ON`` (the speed
  advisories of the corridor use case, the heading and altitude advisories of
  ``heading_altitude_sa``). In wind the heading sent is the track the mirror's
  autopilot holds;
* altitude offsets given to aircraft as they are created (the corridor use
  case's per-episode altitude noise) are applied to BlueSky's aircraft too.

BlueSky keeps its whole state in process globals, so one process runs one
BlueSky episode at a time (a second :class:`BlueSkyEpisode` in the same process
is refused while the first is open). For parallel rollouts, use one process
per environment (Ray workers do).
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from collections.abc import Generator
from pathlib import Path
from typing import Any

import numpy as np

from aamsim import Simulation
from aamsim.extras import require
from aamsim.traffic.intents import SYNC_FIELDS
from aamsim.units import FPM, FT, KTS
from rlbridge.core import EpisodeCore, StepResult

_BLUESKY: dict[str, Any] = {}  # BlueSky's module and the open episode: BlueSky itself is process-global
_INTENT_FIELDS = ("selspd", "selspd_mach", "selalt", "selvs", "lnav", "ap_trk")


def _intent_state(sim: Simulation) -> dict[str, tuple[Any, ...]]:
    """Per callsign, the intent fields a use case changes (speed, altitude, heading, route guidance)."""
    view = sim.view
    cols = [getattr(view, name).tolist() for name in _INTENT_FIELDS]
    return {acid: tuple(c[k] for c in cols) for k, acid in enumerate(view.ids)}


def intent_commands(before: dict[str, tuple[Any, ...]], after: dict[str, tuple[Any, ...]]) -> list[str]:
    """BlueSky commands for the intents that changed between two :func:`_intent_state` snapshots."""
    lines: list[str] = []
    for acid, (spd, mach, alt, vs, lnav, trk) in after.items():
        old = before.get(acid)
        if old is None:
            continue
        spd0, _mach0, alt0, _vs0, lnav0, trk0 = old
        if spd != spd0 and not mach:
            lines.append(f"SPD {acid} {spd / KTS:.6f}")
        if alt != alt0:
            lines.append(f"ALT {acid} {alt / FT:.6f}" + (f" {vs / FPM:.6f}" if vs else ""))
        if not lnav and (lnav0 or trk != trk0):
            lines.append(f"HDG {acid} {trk:.6f}")
        elif lnav and not lnav0:
            lines.append(f"LNAV {acid} ON")
    return lines


def _bluesky() -> Any:
    """BlueSky, initialised once per process (headless, detached, in a private work directory)."""
    if "bs" not in _BLUESKY:
        require("bluesky", 'backend="bluesky"', ("bluesky",))
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                import bluesky as bs

                workdir = tempfile.mkdtemp(prefix="aamgym-bluesky-")
                bs.init(mode="sim", detached=True, workdir=workdir)
        except ImportError as exc:
            raise RuntimeError(f'backend="bluesky": BlueSky does not start ({exc}); reinstall it: '
                               f'pip install "aamsim[bluesky]"') from exc
        bs.net.send = lambda *args, **kwargs: None  # detached: no network, no screen
        _BLUESKY["bs"] = bs
    return _BLUESKY["bs"]


class BlueSkyEpisode(EpisodeCore):
    """An :class:`~rlbridge.core.EpisodeCore` whose aircraft BlueSky flies (see the module docstring)."""

    # Its _advance_steps sends the use case's actions to BlueSky at each decision: the decisions of a
    # reset's flight to the ego go through it too, as the backend was checked against BlueSky.
    flies_idle_decisions = False

    def __init__(self, scenario: str | Path, usecase: Any = "corridor_sa", params: dict[str, Any] | None = None,
                 time_limit_s: float | None = None, dt: float = 0.05, **kwargs: Any):
        super().__init__(scenario, usecase, params, time_limit_s=time_limit_s, dt=dt, **kwargs)
        if self.spec.plans_departures:
            # BlueSky reads the scenario file itself: it would create every flight at its filed time.
            raise ValueError(f"use case {self.usecase.name} plans departures, which the bluesky backend cannot "
                             "hold back; run it on the local or zmq backend")
        owner = _BLUESKY.get("owner")
        if owner is not None and owner() is not None:
            raise RuntimeError("BlueSky runs one episode per process; close the other BlueSky environment first")
        import weakref

        _BLUESKY["owner"] = weakref.ref(self)
        self.bs = _bluesky()
        self._pending: dict[str, tuple[Any, ...]] | None = None
        self._alt_offsets: dict[str, float] = {}  # callsign -> altitude offset given at creation [m]

    # ------------------------------------------------------------- simulation
    def _new_simulation(self, seed: int | None) -> Simulation:
        sim = super()._new_simulation(seed)
        bs = self.bs
        with contextlib.redirect_stdout(io.StringIO()):
            bs.sim.reset()
            bs.sim.simdt = self.dt
            # Absolute: BlueSky reads a relative path from its own scenario folder, not the working directory.
            lines = bs.stack.simstack.readscn(str(Path(self.path).resolve()))
            bs.stack.set_scendata([t for t, _ in lines], [c for _, c in lines])
        # Before the conflict check (priority 10) at each of its instants.
        sim.hooks.post_step.add(self._sync, interval_s=lambda: sim.settings.cd_interval_s, name="bluesky.sync",
                                priority=0)
        # Altitude changes made to the mirror while an aircraft is created (the corridor use case's
        # per-episode altitude noise) are measured around the other creation hooks and applied to
        # BlueSky's aircraft when it creates them, so both fly the same altitudes.
        created_alt: dict[str, float] = {}
        self._alt_offsets = {}

        def before(sim: Simulation, i: int) -> None:
            created_alt[sim.view.callsign(i)] = float(sim.view.alt[i])

        def after(sim: Simulation, i: int) -> None:
            acid = sim.view.callsign(i)
            dz = float(sim.view.alt[i]) - created_alt.pop(acid, float(sim.view.alt[i]))
            if dz:
                self._alt_offsets[acid] = dz

        sim.hooks.created.add(before, name="bluesky.created_alt", priority=-1000)
        sim.hooks.created.add(after, name="bluesky.alt_offset", priority=1000)
        return sim

    def _sync(self, sim: Simulation) -> None:
        """Advance BlueSky to the mirror's time and copy its aircraft states into the mirror."""
        bs = self.bs
        target = sim.simt
        while bs.sim.simt < target - 1e-9:
            bs.sim.step()
        # BlueSky runs the commands due now at the start of its next step; run them now instead (the
        # same order: they come before the move), so its aircraft exist when actions are sent at t.
        bs.stack.process()
        index = {acid: k for k, acid in enumerate(bs.traf.id)}
        for acid in [a for a in self._alt_offsets if a in index]:
            k, dz = index[acid], self._alt_offsets.pop(acid)
            bs.traf.alt[k] += dz  # the aircraft and its selected altitude, as aamsim's offset_altitude
            bs.traf.selalt[k] += dz
        view = sim.view
        pairs = [(s, index[a]) for s, a in enumerate(view.ids) if a in index]
        if not pairs:
            return
        slots = np.array([p[0] for p in pairs], dtype=np.int64)
        rows = np.array([p[1] for p in pairs], dtype=np.int64)
        values = {name: np.asarray(getattr(bs.traf, name), dtype=np.float64)[rows] for name in SYNC_FIELDS}
        sim.set_kinematic_state(slots, values)

    # ----------------------------------------------------------------- steps
    def step(self, actions: dict[str, Any]) -> StepResult:
        if self.sim is not None:
            self._pending = _intent_state(self.sim)
        return super().step(actions)

    def _advance_steps(self) -> Generator[float, None, None]:
        if self._pending is not None and self.sim is not None:
            # The use case applied its actions to the mirror: send what they changed to BlueSky.
            for line in intent_commands(self._pending, _intent_state(self.sim)):
                self.bs.stack.stack(line)
            self._pending = None
        yield from super()._advance_steps()

    def bluesky_state(self) -> dict[str, Any]:
        """BlueSky's own traffic arrays now (``ids`` and SI arrays), for checks against the mirror."""
        bs = self.bs
        out: dict[str, Any] = {"simt": float(bs.sim.simt), "ids": list(bs.traf.id)}
        for name in SYNC_FIELDS:
            out[name] = np.array(getattr(bs.traf, name), dtype=np.float64)
        return out

    def close(self) -> None:
        super().close()
        if _BLUESKY.get("owner") is not None and _BLUESKY["owner"]() is self:
            del _BLUESKY["owner"]
