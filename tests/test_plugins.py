"""Plugins: the documented example plugin, PLUGINS LIST/LOAD, module paths, the BRIDGE plugin."""

from __future__ import annotations

import json
import re
import sys

import pytest
from bridge_util import ROOT

from aamsim import Simulation
from aamsim.errors import CommandError
from aamsim.plugins import available, load_plugin, plugin_module

DOC = ROOT / "docs" / "plugins.md"
TWO_AIRCRAFT = "00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 0.1 0 0 1000 100\n"


@pytest.fixture
def documented_plugin(tmp_path, monkeypatch):
    """The first python block of docs/plugins.md, as the importable module ``occupancy``."""
    block = re.search(r"```python\n(.*?)```", DOC.read_text(), re.DOTALL)
    assert block, "docs/plugins.md has no python block"
    code = block.group(1)
    assert 15 <= sum(1 for line in code.splitlines() if line.strip()) <= 30  # "a 20-line example"
    (tmp_path / "occupancy.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "occupancy", raising=False)
    return "occupancy"


def last_text(sim: Simulation) -> str:
    return sim.reporter.messages[-1].text


def test_the_documented_plugin_loads_and_two_simulations_stay_independent(documented_plugin):
    one, two = Simulation(seed=1, use_bluesky_navdata=False), Simulation(seed=1, use_bluesky_navdata=False)
    state = load_plugin(one, documented_plugin)
    assert load_plugin(one, documented_plugin) is state  # once per simulation
    assert one.commands.get("OCCUPANCY") is not None and "occupancy.sample" in one.hooks.post_step.names()
    assert "occupancy.clear" in one.hooks.reset.names()
    assert two.commands.get("OCCUPANCY") is None  # nothing leaked into the other simulation
    load_plugin(two, documented_plugin)
    one.load_text(TWO_AIRCRAFT)
    two.load_text(TWO_AIRCRAFT[: TWO_AIRCRAFT.index("\n") + 1])
    one.run_until(30.0)
    two.run_until(60.0)
    one.stack("OCCUPANCY")
    two.stack("OCCUPANCY")
    assert last_text(one) == "peak 2 aircraft in 4 samples"  # t = 0, 10, 20, 30 s
    assert last_text(two) == "peak 1 aircraft in 7 samples"
    one.stack("RESET")
    one.stack("OCCUPANCY")
    assert last_text(one) == "peak 0 aircraft in 0 samples"  # the reset hook ran
    assert one.plugins["OCCUPANCY"] is state and two.plugins["OCCUPANCY"] is not state


def test_plugins_list_shows_bridge_and_load_takes_registered_plugins_only(documented_plugin):
    sim = Simulation(use_bluesky_navdata=False)
    sim.stack("PLUGINS LIST")
    assert re.search(r"available plugins: .*BRIDGE", last_text(sim)) and "EXAMPLE" in last_text(sim)
    assert set(available()) >= {"BRIDGE", "EXAMPLE"}
    assert sim.stack("PLUGIN LOAD BRIDGE")
    assert sim.stack("BRIDGE") and "protocol v1" in last_text(sim) and "aamsim serve" in last_text(sim)
    sim.stack("PLUGINS LIST")
    assert last_text(sim).endswith("loaded: BRIDGE")
    # A module path works from Python and the command line, never from the stack.
    assert not sim.stack(f"PLUGINS LOAD {documented_plugin}")
    assert "unknown plugin" in last_text(sim)
    assert not sim.stack("PLUGINS LOAD os.path")
    with pytest.raises(CommandError, match="unknown plugin no_such_module"):
        load_plugin(sim, "no_such_module")
    with pytest.raises(CommandError, match="has no init_plugin"):
        load_plugin(sim, "json")
    assert plugin_module("BRIDGE").serve is not None and json


def test_aamsim_run_with_plugins(tmp_path, documented_plugin):
    from bridge_util import run_cli

    scn = tmp_path / "two.scn"
    scn.write_text(TWO_AIRCRAFT + "00:00:30.00>OCCUPANCY\n00:00:30.00>COUNTSTEPS\n00:00:40.00>QUIT\n")
    proc = run_cli("run", str(scn), "--plugin", "EXAMPLE", "--plugin", "occupancy", "--out", str(tmp_path / "r"),
                   extra_path=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "peak 2 aircraft in 4 samples" in proc.stderr and "31 samples, 60 aircraft-samples" in proc.stderr  # t = 0 sampled before CRE
