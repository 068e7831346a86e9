"""The use-case spec (rlbridge/usecases/spec.py): every registry entry declares one, readers use it,
and baselines that need a capability a use case lacks are refused by name (docs/usecases.md, "The spec")."""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import pytest

from aamsim import Simulation
from rlbridge.agents import BASELINE_KINDS, baseline_needs, check_baseline_fits, make_actor
from rlbridge.agents.rollout import EnvSpec, RolloutWorker
from rlbridge.core import EpisodeCore
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases import available, make_usecase, usecase_spec
from rlbridge.usecases.reach import ReachDestination, ReachParams
from rlbridge.usecases.spec import SPEED_ROLES, SPEED_TARGETS, CapabilityError, Needs, UseCaseSpec, check_fits
from rlbridge.usecases.strategic import PLANNING_METRICS, planning_metrics

DATA = Path(__file__).parent / "data"
THREE_WAY = str(DATA / "three_way.scn")
TINY = str(DATA / "tiny_conflict.scn")
CROSS = str(DATA / "strategic_cross.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}


def test_mvp_speed_is_refused_on_reach_destination_instead_of_holding_at_60_kt():
    """Regression: mvp_speed's actions 0/1/2 are decelerate/hold/accelerate, but reach_destination's actions
    select 30/60/90 kt, so its "hold" (action 1) selected 60 kt. It is refused, naming the use case and the
    speed action layout it needs."""
    core = EpisodeCore(THREE_WAY, "reach_destination", {"cruise_speed_kts": ()}, time_limit_s=300)
    actor = make_actor({"kind": "mvp_speed"})
    refusal = (r"baseline mvp_speed does not fit use case reach_destination: it needs speed actions laid out as "
               r"decelerate_hold_accelerate \(its speed actions: fixed_targets\)")
    with pytest.raises(TypeError, match=refusal):
        actor.check_usecase(core.usecase)
    core.close()
    # The rollout worker asks before the first decision: no episode runs with mvp_speed on it.
    worker = RolloutWorker(EnvSpec(THREE_WAY, "reach_destination", {"cruise_speed_kts": ()}, time_limit_s=300),
                           {"policy": {"kind": "mvp_speed"}})
    with pytest.raises(TypeError, match=refusal):
        worker.collect([1])


@pytest.mark.parametrize("name", available())
def test_every_registry_entry_declares_a_spec_that_its_baselines_fit(name):
    spec = usecase_spec(name)
    assert isinstance(spec, UseCaseSpec)
    uc = make_usecase_with_policies(name)
    assert isinstance(uc.params, spec.params_class)  # the parameters it builds are the declared class
    assert "unequipped" not in spec.baselines and set(spec.baselines) <= set(BASELINE_KINDS)
    for kind in ("unequipped", *uc.spec.baselines):
        check_baseline_fits(kind, uc)  # no error: every declared baseline fits


def test_the_capability_table():
    """Which baseline fits which use case, from the baselines' needs and the specs' declarations."""
    fits = {}
    for name in available():
        for kind in BASELINE_KINDS:
            try:
                check_baseline_fits(kind, name)
                fits[name, kind] = True
            except CapabilityError:
                fits[name, kind] = False
    ok = sorted((n, k) for (n, k), f in fits.items() if f and k != "unequipped")
    assert ok == [("corridor_sa", "daa"), ("corridor_sa", "mvp_speed"), ("heading_altitude_sa", "daa"),
                  ("heading_altitude_sa", "mvp"), ("hierarchical", "fcfs"), ("hierarchical", "no_planning"),
                  ("reach_destination", "daa"), ("strategic_planning", "fcfs"), ("strategic_planning", "no_planning")]
    assert all(fits[n, "unequipped"] for n in available())
    assert baseline_needs("mvp_speed") == Needs(any_of=("speed",), speed_actions=SPEED_ROLES)


def test_hierarchical_instance_spec_follows_the_level_that_learns():
    planner = make_usecase_with_policies("hierarchical", planning=NO_LAYERS)
    assert planner.spec == usecase_spec("hierarchical")
    assert planner.spec.action_kinds == ("departure_slot",) and not planner.spec.aircraft_agents
    tactical = make_usecase_with_policies("hierarchical", train="tactical", planner="fcfs", planning=NO_LAYERS)
    assert tactical.spec.action_kinds == ("speed",) and tactical.spec.speed_actions == SPEED_ROLES
    assert tactical.spec.baselines == ("mvp_speed", "daa") and tactical.spec.aircraft_agents
    assert tactical.spec.plans_departures and tactical.spec.policy_params == ("tactical", "planner")
    check_baseline_fits("mvp_speed", tactical)
    with pytest.raises(CapabilityError, match="baseline mvp_speed does not fit use case hierarchical"):
        check_baseline_fits("mvp_speed", planner)


class _NoSpec(ReachDestination):
    name = "no_spec"
    spec = None  # type: ignore[assignment]


def test_a_use_case_without_a_spec_is_refused_by_name():
    with pytest.raises(CapabilityError, match=r"use case no_spec declares no spec: give its class a `spec = "
                                              r"UseCaseSpec\(...\)`"):
        make_usecase(_NoSpec)
    with pytest.raises(CapabilityError, match="use case no_spec declares no spec"):
        EpisodeCore(THREE_WAY, _NoSpec(), time_limit_s=100)


class _FixedSpeedsClaimingMVP(ReachDestination):
    name = "fixed_speeds"
    spec = replace(ReachDestination.spec, baselines=("mvp_speed", "daa"))


def test_a_declared_baseline_that_does_not_fit_is_refused():
    with pytest.raises(CapabilityError, match="baseline mvp_speed does not fit use case fixed_speeds"):
        check_baseline_fits("mvp_speed", _FixedSpeedsClaimingMVP)
    check_fits(Needs(any_of=("speed",)), _FixedSpeedsClaimingMVP, "a speed policy")


class _UndeclaredMetrics(ReachDestination):
    name = "undeclared_metrics"
    spec = replace(ReachDestination.spec, metrics=("arrivals",))


def test_extra_metrics_must_be_declared():
    core = EpisodeCore(THREE_WAY, _UndeclaredMetrics(), time_limit_s=100)
    core.reset(0)
    with pytest.raises(ValueError, match=r"use case undeclared_metrics: extra_metrics gave flights_ended, which "
                                         r"its spec does not declare \(UseCaseSpec.metrics: arrivals\)"):
        core.metrics()


def test_declared_metrics_are_what_the_use_cases_give():
    core = EpisodeCore(THREE_WAY, "reach_destination", {}, time_limit_s=100)
    core.reset(0)
    assert tuple(core.metrics()["reach_destination"]) == usecase_spec("reach_destination").metrics
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    assert tuple(planning_metrics([], 0, sim, 0)) == PLANNING_METRICS
    core = EpisodeCore(TINY, "heading_altitude_sa", {}, time_limit_s=60)
    core.reset(0)
    core.step({})
    assert tuple(core.metrics()["heading_altitude_sa"]) == usecase_spec("heading_altitude_sa").metrics


@pytest.mark.parametrize("kwargs, message", [
    ({"action_kinds": ("turn",)}, r"unknown kind\(s\) turn"),
    ({"action_kinds": ("speed",)}, "speed_actions is required with a speed action kind"),
    ({"action_kinds": ("heading",), "speed_actions": SPEED_TARGETS}, "speed_actions is required"),
    ({"action_kinds": ("speed",), "speed_actions": "slow"}, "speed_actions 'slow': expected one of"),
    ({"action_kinds": (), "advisory": "sometimes"}, "advisory 'sometimes': expected one of"),
])
def test_a_malformed_spec_is_an_error_naming_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        UseCaseSpec(**{"params_class": ReachParams, "baselines": (), "advisory": "non_hold", **kwargs})
    with pytest.raises(TypeError, match="params_class must be a dataclass"):
        UseCaseSpec(int, (), (), "non_hold")


def test_readers_use_the_spec():
    """The engine, the BlueSky backend and the server read aircraft_agents, plans_departures and policy_params."""
    planner = EpisodeCore(CROSS, "strategic_planning", NO_LAYERS)
    assert planner.possible_agents == ["planner"]  # aircraft_agents=False: no CRE callsigns
    from rlbridge.backends.bluesky import BlueSkyEpisode

    with pytest.raises(ValueError, match="use case strategic_planning plans departures, which the bluesky backend "
                                         "cannot hold back"):
        BlueSkyEpisode(CROSS, "strategic_planning", NO_LAYERS)
    from rlbridge.server import RequestError, _refuse_policy_files

    with pytest.raises(RequestError, match=r"hierarchical: planner='runs/x': over the bridge a frozen policy is a "
                                           "baseline"):
        _refuse_policy_files("hierarchical", {"tactical": "mvp_speed", "planner": "runs/x"})
    _refuse_policy_files("corridor_sa", {"tactical": "runs/x"})  # corridor_sa names no frozen policies
    assert {f.name for f in fields(usecase_spec("corridor_sa").params_class)} >= {"obs_format"}
