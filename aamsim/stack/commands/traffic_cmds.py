"""Aircraft commands: create, delete, move, and autopilot selections."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.shapes import delete_shape
from aamsim.turbulence import noise_on, set_noise
from aamsim.stack.argtypes import (
    AcIndex,
    Altitude,
    Count,
    Heading,
    Number,
    OnOff,
    PositionValue,
    SpeedArg,
    Text,
    VSpeed,
    Word,
)
from aamsim.stack.registry import command
from aamsim.units import FPM, FT, KTS, Speed

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


@command("CRE", aliases=("CREATE",), group="traffic")
def cre(
    sim: CommandContext,
    acid: Text,
    actype: Text,
    pos: PositionValue,
    hdg: Heading | None = None,
    alt: Altitude = 0.0,
    spd: SpeedArg | None = None,
) -> None:
    """CRE acid, type, lat, lon, [hdg, alt, spd]: create an aircraft.

    Heading in degrees (default 0, or the runway's at ``APT/RWxx``), altitude in ft or FLnnn (default 0),
    speed in kts CAS or Mach (default 0). An existing callsign is an error.
    """
    if hdg is None:  # BlueSky: the heading of a runway position, else 0
        hdg = pos.heading if pos.heading is not None else 0.0
    sim.create_aircraft(acid, actype, pos.lat, pos.lon, hdg, alt, spd or Speed(0.0))


@command("MCRE", group="traffic")
def mcre(
    sim: CommandContext,
    count: Count,
    actype: Text = "",
    alt: Altitude | None = None,
    spd: SpeedArg | None = None,
    dest: Text = "",
) -> None:
    """MCRE n, [type, alt, spd, dest]: create n random aircraft (seeded by SEED / --seed).

    Positions are uniform in the MCRE area (default +-1 deg around 0,0, as
    BlueSky headless), headings uniform, altitude 2000-39000 ft and speed
    250-450 kts unless given. Callsigns are two random letters and a number.
    More aircraft than the simulation's bound leaves room for (``aamsim run --max-aircraft``) is
    refused whole: none is created, and the error says how many would fit.
    """
    if count <= 0 or count > 100_000:
        raise CommandError(f"MCRE needs 1..100000 aircraft, not {count}")
    room = sim.limits.room(sim.view.n)
    if room is not None and count > room:
        raise CommandError(sim.limits.refusal(
            f"MCRE {count:,}: this simulation flies at most {sim.limits.max_aircraft:,} aircraft at once, and "
            f"{sim.view.n:,} fly at t = {sim.simt:.2f} s: {room:,} more fit; none created"))
    rng = sim.rng
    lat0, lon0, lat1, lon1 = sim.settings.mcre_area
    actype = actype or "B744"
    if actype in ("*",):
        actype = "B744"
    prefix = chr(int(rng.integers(65, 91))) + chr(int(rng.integers(65, 91)))
    number = 0
    for _ in range(count):
        while f"{prefix}{number:05d}" in sim.view:
            number += 1
        acid = f"{prefix}{number:05d}"
        number += 1
        lat = float(rng.uniform(lat0, lat1))
        lon = float(rng.uniform(lon0, lon1))
        hdg = float(rng.integers(1, 360))
        a = alt if alt is not None else float(rng.integers(2000, 39000)) * FT
        s = spd if spd is not None else Speed(float(rng.integers(250, 450)) * KTS)
        i = sim.create_aircraft(acid, actype, lat, lon, hdg, a, s)
        if dest:
            sim.stack(f"DEST {acid} {dest}", sim.current_source)
        _ = i


@command("DEL", aliases=("DELETE",), group="traffic")
def delete(sim: CommandContext, *targets: Word) -> None:
    """DEL acid/shape, [acid/shape, ...]: delete aircraft or shapes. ``DEL *`` deletes all aircraft, ``DEL WIND``
    the wind field."""
    if not targets:
        raise CommandError("DEL needs a callsign (or * for all aircraft)")
    names = [t.upper() for t in targets if t]
    if names[:1] == ["WIND"] and "WIND" not in sim.view:  # an aircraft called WIND goes first, as in BlueSky
        sim.clear_wind()
        return
    if "*" in names:
        for slot in range(sim.view.n - 1, -1, -1):
            sim.delete_aircraft(slot)
        return
    missing = [name for name in names if name not in sim.view]
    for name in names:
        i = sim.view.find(name)
        if i is not None:
            sim.delete_aircraft(i)
    # BlueSky's DEL also removes a shape (BOX, POLY, ...) of that name.
    missing = [name for name in missing if not delete_shape(sim, name)]
    if missing:
        hint = " (DEL * deletes all aircraft)" if "ALL" in missing else ""
        raise CommandError(f"no aircraft {', '.join(missing)}{hint}")


@command("MOVE", group="traffic")
def move(
    sim: CommandContext,
    acid: AcIndex,
    pos: PositionValue,
    alt: Altitude | None = None,
    hdg: Heading | None = None,
    spd: SpeedArg | None = None,
    vspd: VSpeed | None = None,
) -> None:
    """MOVE acid, lat, lon, [alt, hdg, spd, vspd]: put an aircraft somewhere else."""
    sim.move(acid, pos.lat, pos.lon, alt, hdg, spd, vspd)


@command("SPD", aliases=("SPEED",), group="autopilot")
def spd(sim: CommandContext, acid: AcIndex, speed: SpeedArg) -> None:
    """SPD acid, spd: select a speed (kts CAS, or Mach); VNAV speed control off."""
    sim.select_speed(acid, speed)


@command("ALT", aliases=("ALTITUDE",), group="autopilot")
def alt(sim: CommandContext, acid: AcIndex, altitude: Altitude, vspd: VSpeed | None = None) -> None:
    """ALT acid, alt, [vspd]: select an altitude (ft or FLnnn), optionally a vertical speed (fpm); VNAV off.

    Without a vertical speed, a previously selected one pointing the other way
    is dropped in favour of the default 1500 fpm.
    """
    sim.select_altitude(acid, altitude, vspd)


@command("VS", aliases=("VSPD",), group="autopilot")
def vs(sim: CommandContext, acid: AcIndex, vspd: VSpeed) -> None:
    """VS acid, vspd: select a vertical speed (fpm), used while the selected altitude differs; VNAV off."""
    sim.select_vertical_speed(acid, vspd)


@command("HDG", aliases=("HEADING", "TURN"), group="autopilot")
def hdg(sim: CommandContext, acid: AcIndex, heading: Heading) -> None:
    """HDG acid, hdg: fly a heading (degrees true); LNAV off."""
    sim.select_heading(acid, heading)


@command("BANK", aliases=("BANKLIM",), group="autopilot")
def bank(sim: CommandContext, acid: AcIndex, bank_deg: Number | None = None) -> str | None:
    """BANK acid, [bank]: set (or show) the bank angle used in turns [deg]."""
    if bank_deg is None:
        return f"{sim.view.callsign(acid)} bank angle {math.degrees(sim.view.bankdef[acid]):.1f} deg"
    if not 0.0 < bank_deg < 90.0:
        raise CommandError(f"bank angle must be between 0 and 90 deg, not {bank_deg:g}")
    sim.set_bank(acid, math.radians(bank_deg))
    return None


@command("POS", group="traffic")
def pos(sim: CommandContext, name: Text) -> str:
    """POS acid/waypoint: show an aircraft's state or a waypoint's position."""
    i = sim.view.find(name)
    if i is not None:
        v = sim.view
        route = sim.view.route(i)
        active = route.waypoints[route.iactwp].name if 0 <= route.iactwp < len(route) else "-"
        return (
            f"{name} {sim.view.actype(i)} lat {v.lat[i]:.6f} lon {v.lon[i]:.6f} "
            f"alt {v.alt[i] / FT:.0f} ft hdg {v.hdg[i]:.1f} CAS {v.cas[i] / KTS:.1f} kts "
            f"TAS {v.tas[i] / KTS:.1f} kts VS {v.vs[i] / FPM:.0f} fpm "
            f"LNAV {'ON' if v.lnav[i] else 'OFF'} VNAV {'ON' if v.vnav[i] else 'OFF'} "
            f"active waypoint {active}"
        )
    found = sim.navdb.lookup(name)
    if found is None:
        raise CommandError(f"{name} is not a command, an aircraft or a known waypoint")
    return f"{name} at lat {found[0]:.6f} lon {found[1]:.6f}"


@command("CASMACHTHR", group="autopilot")
def casmachthr(sim: CommandContext, threshold: Number | None = None) -> str:
    """CASMACHTHR [threshold]: accepted for BlueSky compatibility; it has no effect.

    aamsim keeps CAS and Mach apart (``M.78`` or 0.1 < value < 1 is Mach,
    anything else knots), so no speed threshold can turn a slow drone into a
    Mach number.
    """
    return "CASMACHTHR has no effect in aamsim: CAS and Mach are never confused"


@command("NOISE", group="traffic")
def noise(sim: CommandContext, on: OnOff | None = None) -> str | None:
    """NOISE [ON/OFF]: turbulence, BlueSky's random walk of the positions (seeded by SEED)."""
    if on is None:
        return f"Noise is currently {'on' if noise_on(sim) else 'off'}"
    set_noise(sim, on)
    return None


COMMANDS = (cre, mcre, delete, move, spd, alt, vs, hdg, bank, pos, casmachthr, noise)
