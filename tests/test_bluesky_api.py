"""BlueSky's Python API on aamsim (``aamsim.compat.bluesky``): its semantics, hand-checked.

The shim is used here as ``aamsim.compat.bluesky`` (no ``install()``), so the
real BlueSky stays importable in the same process; ``install()`` itself is
tested in subprocesses (``tests/test_bluesky_install.py``). bluesky-gym's seven
environments against BlueSky itself: ``tests/test_bluesky_gym.py``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import aamsim.compat.bluesky as bs
from aamsim.compat.bluesky.stack import StackWarning

FT, KTS, NM = 0.3048, 0.514444, 1852.0


@pytest.fixture
def echoes():
    """A fresh BlueSky API simulation; yields the texts and flags sent to BlueSky's echo."""
    bs.init(mode="sim", detached=True)
    bs.sim.reset()
    sent: list[tuple[str, int]] = []
    bs.net.send = lambda topic, data="", to_group=b"": sent.append((data["text"], data["flags"]))
    yield sent
    bs.sim.reset()


def _create(*names: str, alt: float = 3000.0) -> None:
    for k, name in enumerate(names):
        assert bs.traf.cre(name, actype="A320", aclat=52.0 + 0.1 * k, aclon=4.0, achdg=90.0, acalt=alt,
                           acspd=150.0) is True


# ---------------------------------------------------------------------------- aircraft order and identity


def test_positions_shift_on_deletion_as_in_bluesky(echoes):
    _create("A", "B", "C", "D")
    ids = bs.traf.id
    bs.traf.delete(1)
    # BlueSky shifts the aircraft after the deleted one; aamsim moves its last aircraft into the
    # freed slot, so the shim's order is not the simulation's.
    assert bs.traf.id == ["A", "C", "D"] and bs.traf.id is ids
    assert list(bs.sim._session.simulation.view.ids) == ["A", "D", "C"]
    assert bs.traf.lat.tolist() == pytest.approx([52.0, 52.2, 52.3])
    assert bs.traf.id2idx("D") == 2 and bs.traf.id2idx("nobody") == -1 and bs.traf.id2idx(["C", "X"]) == [1, -1]
    assert bs.traf.id2idx("*") == 2 and bs.traf.ntraf == 3


def test_deleting_while_iterating_the_id_list_skips_as_in_bluesky(echoes):
    """bluesky-gym ends an episode with ``for acid in bs.traf.id: bs.traf.delete(bs.traf.id2idx(acid))``."""
    _create("A", "B", "C", "D")
    for acid in bs.traf.id:
        bs.traf.delete(bs.traf.id2idx(acid))
    assert bs.traf.id == ["B", "D"]  # the list shrinks under the loop: every second aircraft stays


def test_callsigns_are_kept_as_given_and_a_second_one_is_refused(echoes):
    assert bs.traf.cre("kl001", actype="A320", acspd=150.0) is True
    assert bs.traf.id == ["kl001"]
    assert bs.traf.id2idx("kl001") == -1  # BlueSky looks up the upper-case name
    _create("KL002")
    assert bs.traf.cre("KL002", actype="A320") == (False, "KL002 already exists.")
    # BlueSky compares the upper-case callsign with the stored ones and so creates "KL001" beside
    # "kl001"; aamsim's callsigns ignore case, so the shim refuses it, with aamsim's reason.
    with pytest.warns(StackWarning):
        assert bs.traf.cre("KL001", actype="A320") == (False, "aircraft KL001 already exists")
    assert bs.traf.id == ["kl001", "KL002"]


def test_creation_units_and_a_mach_number(echoes):
    bs.traf.cre("M", actype="A320", aclat=52.0, aclon=4.0, achdg=90.0, acalt=10668.0, acspd=0.78)
    bs.traf.cre("C", actype="A320", aclat=52.0, aclon=4.1, achdg=90.0, acalt=3000.0, acspd=150.0)
    t = 288.15 - 0.0065 * 10668.0
    assert bs.traf.tas[0] == pytest.approx(0.78 * math.sqrt(1.4 * 287.05287 * t), rel=1e-12)
    assert bs.traf.M[0] == pytest.approx(0.78, rel=1e-12)
    assert bs.traf.selspd[0] == pytest.approx(bs.traf.cas[0], rel=1e-12)  # BlueSky selects the CAS of the Mach
    assert bs.traf.cas[1] == pytest.approx(150.0, rel=1e-12) and bs.traf.alt[1] == 3000.0


def test_creation_draws_one_number_per_aircraft_from_numpys_global_generator(echoes):
    """As BlueSky's ADS-B model does: scenarios drawn from that generator stay the same."""
    np.random.seed(7)
    bs.traf.cre(["P", "Q", "R"], actype="A320", aclat=[52.0, 52.1, 52.2], aclon=4.0, acspd=150.0)
    after = np.random.random()
    np.random.seed(7)
    np.random.rand(3)
    assert after == np.random.random()
    assert bs.traf.id == ["P", "Q", "R"]


# ---------------------------------------------------------------------------- stack and stepping


def test_stacked_commands_wait_for_the_step_which_advances_one_dt(echoes):
    _create("A")
    bs.stack.stack("DT 5;FF", "HDG A 180")
    assert bs.sim.simdt == 0.05 and bs.traf.ap.trk[0] == 90.0  # nothing has run yet
    bs.sim.step()
    assert bs.sim.simt == 5.0 and bs.sim.simdt == 5.0 and bs.sim.state == bs.OP
    assert bs.traf.ap.trk[0] == 180.0
    bs.sim.step()
    assert bs.sim.simt == 10.0


def test_without_traffic_the_simulation_waits_in_init(echoes):
    bs.sim.step()
    assert bs.sim.simt == 0.0 and bs.sim.state == bs.INIT
    _create("A")
    assert bs.sim.state == bs.INIT  # until a step finds the traffic, as in BlueSky
    bs.sim.step()
    assert bs.sim.state == bs.OP and bs.sim.simt == pytest.approx(0.05)


def test_hold_stops_the_clock_and_op_restarts_it(echoes):
    _create("A")
    bs.stack.stack("HOLD")
    bs.sim.step()
    assert bs.sim.state == bs.HOLD and bs.sim.simt == 0.0
    bs.stack.stack("OP")
    bs.sim.step()
    assert bs.sim.state == bs.OP and bs.sim.simt == pytest.approx(0.05)


def test_sim_reset_clears_everything_and_traf_reset_keeps_the_time(echoes):
    _create("A")
    bs.stack.stack("DT 1")
    bs.sim.step()
    bs.sim.step()
    bs.traf.reset()
    assert bs.traf.ntraf == 0 and bs.sim.simt == 2.0 and bs.sim.simdt == 1.0
    _create("B")
    bs.stack.stack("HDG B 10")
    bs.sim.reset()
    assert bs.traf.ntraf == 0 and bs.sim.simt == 0.0 and bs.sim.simdt == 0.05 and bs.sim.state == bs.INIT
    bs.sim.step()
    assert echoes == []  # the stacked HDG went with the reset


# ---------------------------------------------------------------------------- writing the arrays


def test_written_selections_are_flown(echoes):
    """DescentEnv's way: ``selalt[0] = 1e6; selvs[0] = v`` with VNAV off climbs at v."""
    _create("A", alt=1000.0)
    bs.traf.swvnav[0] = False
    bs.traf.selalt[0] = 1_000_000.0
    bs.traf.selvs[0] = 5.0
    bs.stack.stack("DT 1")
    for _ in range(60):
        bs.sim.step()
    view = bs.sim._session.simulation.view
    assert view.selvs[0] == 5.0 and not view.vnav[0]
    assert bs.traf.vs[0] == pytest.approx(5.0)
    # Vertical speed ramps up by 300 fpm (1.524 m/s) per 1 s step to 5 m/s, then holds it (Euler steps).
    assert bs.traf.alt[0] == pytest.approx(1000.0 + 1.524 + 3.048 + 4.572 + 57 * 5.0, abs=1e-6)


def test_written_heading_and_autopilot_track_hold(echoes):
    """StaticObstacleEnv's way: ``hdg[i] = q; ap.trk[i] = q`` turns the aircraft at once."""
    _create("A")
    bs.traf.hdg[0] = 123.0
    bs.traf.ap.trk[0] = 123.0
    bs.sim.step()
    assert bs.traf.hdg[0] == 123.0 and bs.traf.trk[0] == 123.0


def test_a_one_element_array_goes_into_an_element_as_with_numpy_1(echoes):
    _create("A")
    bs.traf.selvs[0] = np.array([2.5])  # bluesky-gym's action of shape (1,): NumPy 2 refuses it on BlueSky
    with pytest.raises(ValueError):
        bs.traf.selvs[0] = np.array([1.0, 2.0])
    bs.sim.step()
    assert bs.sim._session.simulation.view.selvs[0] == 2.5


def test_assigning_a_whole_array_writes_each_element(echoes):
    _create("A", "B")
    bs.traf.selalt = np.array([1500.0, 2500.0])
    bs.sim.step()
    assert bs.sim._session.simulation.view.selalt.tolist() == [1500.0, 2500.0]


def test_derived_arrays_refuse_writes(echoes):
    _create("A")
    with pytest.raises(ValueError, match="read-only"):
        bs.traf.p[0] = 1.0
    p, rho, t = bs.tools.aero.vatmos(3000.0)
    assert (bs.traf.p[0], bs.traf.rho[0], bs.traf.Temp[0]) == pytest.approx((p, rho, t), rel=1e-15)


def test_autopilot_commands(echoes):
    _create("A")
    bs.traf.ap.selaltcmd(0, 4000.0, 10.0)
    bs.traf.ap.selspdcmd(0, 0.7)  # below the CAS/Mach threshold: Mach
    bs.traf.ap.selhdgcmd(0, 45.0)
    view = bs.sim._session.simulation.view
    assert view.selalt[0] == 4000.0 and view.selvs[0] == 10.0 and not view.vnav[0]
    assert view.selspd[0] == 0.7 and view.selspd_mach[0] and view.ap_trk[0] == 45.0 and not view.lnav[0]


def test_creconfs_puts_a_head_on_intruder_where_the_conflict_starts_at_tlosh(echoes):
    bs.traf.cre("OWN", actype="A320", aclat=52.0, aclon=4.0, achdg=0.0, acalt=3000.0, acspd=150.0)
    gs = float(bs.traf.gs[0])
    assert bs.traf.creconfs("INT", "A320", 0, dpsi=180, dcpa=0, tlosh=100) is True
    # Closing at twice the ground speed, 5 NM apart (the protected zone) after 100 s; kwikpos
    # puts 1/60 degree of latitude per NM straight ahead (north).
    dist_nm = (100 * 2 * gs + 5 * NM) / NM
    assert bs.traf.lat[1] - bs.traf.lat[0] == pytest.approx(dist_nm / 60.0, rel=1e-12)
    assert bs.traf.hdg[1] % 360.0 == pytest.approx(180.0, abs=1e-9)
    # Within 3e-5: BlueSky turns the ground speed into a CAS with its scalar (layered) atmosphere and
    # creates the aircraft from it with its vector one, whose density constant differs slightly.
    assert bs.traf.tas[1] == pytest.approx(gs, rel=1e-4) and bs.traf.tas[1] != gs and bs.traf.vs[1] == 0.0
    assert bs.sim._session.simulation.view.selalt[bs.sim._session.order()[1]] == 3000.0


# ---------------------------------------------------------------------------- bad input


def test_a_command_the_shim_cannot_run_is_echoed_and_the_caller_keeps_going(echoes):
    _create("A")
    bs.stack.stack("FOO 1", "HDG NOBODY 90")
    with pytest.warns(StackWarning) as caught:
        bs.sim.step()
    assert bs.sim.simt == pytest.approx(0.05)  # the step went on
    assert [flags for _, flags in echoes] == [bs.BS_CMDERR, bs.BS_FUNERR]
    assert echoes[0][0].startswith("FOO 1\n") and "unknown command FOO" in echoes[0][0]
    assert "NOBODY" in echoes[1][0]
    assert len(caught) == 2


def test_names_not_provided_raise_not_implemented_naming_them(echoes):
    cases = [lambda: bs.traf.cd.confpairs, lambda: bs.traf.asas, lambda: bs.navdb.getaptidx, lambda: bs.foo,
             lambda: bs.tools.misc, lambda: bs.stack.command, lambda: bs.sim.run, lambda: bs.traf.ap.route,
             lambda: bs.tools.geo.magdec]
    names = ["bluesky.traf.cd.confpairs", "bluesky.traf.asas", "bluesky.navdb.getaptidx", "bluesky.foo",
             "bluesky.tools.misc", "bluesky.stack.command", "bluesky.sim.run", "bluesky.traf.ap.route",
             "bluesky.tools.geo.magdec"]
    for case, name in zip(cases, names, strict=True):
        with pytest.raises(NotImplementedError, match="docs/bluesky-api.md") as info:
            case()
        assert name in str(info.value)
    assert not hasattr(bs.traf, "cd_whatever")  # still an AttributeError for hasattr
    with pytest.raises(NotImplementedError, match=r"mode='client'"):
        bs.init(mode="client")


# ---------------------------------------------------------------------------- tools


def test_kwik_distances_by_hand():
    one_degree_nm = 6371000.0 * math.pi / 180.0 / NM
    assert bs.tools.geo.kwikdist(0.0, 0.0, 1.0, 0.0) == pytest.approx(one_degree_nm, rel=1e-15)
    qdr, dist = bs.tools.geo.kwikqdrdist(60.0, 10.0, 60.0, 11.0)  # one degree east at 60N: half as far
    assert qdr == pytest.approx(90.0) and dist == pytest.approx(one_degree_nm * math.cos(math.radians(60.0)))
    assert bs.tools.geo.kwikpos(52.0, 4.0, 0.0, 60.0) == pytest.approx((53.0, 4.0))
    lat = np.array([52.0, 52.5])
    assert bs.tools.geo.kwikdist_matrix(52.0, 4.0, lat, np.array([4.0, 4.0])).tolist() == pytest.approx(
        [0.0, one_degree_nm / 2])


def test_areas(echoes):
    areafilter = bs.tools.areafilter
    square = [52.0, 4.0, 52.0, 5.0, 53.0, 5.0, 53.0, 4.0]
    assert areafilter.defineArea("sector", "POLY", square) is True
    inside = areafilter.checkInside("sector", np.array([52.5, 54.0]), np.array([4.5, 4.5]), np.array([0.0, 0.0]))
    assert inside.tolist() == [True, False] and areafilter.hasArea("sector")
    assert areafilter.defineArea("box", "BOX", [52.0, 4.0, 53.0, 5.0], top=1000.0)
    assert areafilter.checkInside("box", np.array([52.5]), np.array([4.5]), np.array([2000.0])).tolist() == [False]
    areafilter.deleteArea("sector")
    assert areafilter.checkInside("sector", np.array([52.5]), np.array([4.5]), np.array([0.0])).tolist() == [False]
    ok, message = areafilter.defineArea("x", "TRIANGLE", [1, 2, 3, 4, 5, 6])
    assert not ok and "TRIANGLE" in message
    ok, message = areafilter.defineArea("y", "POLY", [1.0, 2.0])
    assert not ok and "POLY Y" in message


def test_wind_is_read_as_bluesky_returns_it(echoes):
    assert bs.traf.wind.getdata(52.0, 4.0, 1000.0) == (0.0, 0.0)  # floats for a position
    bs.traf.wind.addpoint(52.0, 4.0, 270.0, 10.0)  # from the west: blows east
    vn, ve = bs.traf.wind.getdata(np.array([52.0, 52.1]), np.array([4.0, 4.0]))
    assert isinstance(vn, np.ndarray) and vn.tolist() == pytest.approx([0.0, 0.0], abs=1e-12)
    assert ve.tolist() == pytest.approx([10.0, 10.0])
    vn, ve = bs.traf.wind.getdata([52.0], [4.0])
    assert isinstance(ve, list) and ve == pytest.approx([10.0])
    bs.traf.wind.addpointvne(52.0, 4.0, 3.0, 4.0)
    assert bs.traf.wind.winddim == 2
    bs.traf.reset()
    assert bs.traf.wind.winddim == 0


def test_echo_of_a_screen_that_swallows_it_still_warns(echoes):
    """bluesky-gym replaces bs.scr with a screen whose echo does nothing; errors still surface."""

    class Silent(bs.simulation.ScreenIO):
        def echo(self, text="", flags=0):
            pass

    bs.scr = Silent()
    bs.stack.stack("NOSUCHCOMMAND")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bs.sim.step()
    assert any("NOSUCHCOMMAND" in str(w.message) for w in caught)
