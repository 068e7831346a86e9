"""Agent-transitions per second of the multi-agent environment, in-process and over ZeroMQ; decisions per
second of the planner environments (strategic_planning, hierarchical) in-process.

An agent-transition is one aircraft's observation and reward delivered by a
``step`` of the PettingZoo environment (``rlbridge.parallel_env``). Random
actions, one episode per configuration, decision intervals 10 s (the
default) and 1 s; the ZMQ backend talks to ``aamsim serve`` in a subprocess
on loopback. CPU time counts both processes for ZMQ, so "per CPU-second" is
the per-core figure.

    python bench/bench_env.py                          # nyc_train_100.scn, or a synthetic stand-in
    python bench/bench_env.py --scenario my.scn --intervals 10 --backends local
    python bench/bench_env.py --intervals 10 --backends local --planners strategic_planning hierarchical

A planner decision decides one departure request (one flight) and then flies the simulation to
the next request, so "s per flight" of a planner env compares with "s per aircraft-decision" of
the corridor env (random valid actions; the hierarchical env's tactical layer is MVP).
"""

from __future__ import annotations

import argparse
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rlbridge
from aamsim.scenarios import resolve_scenario

VERTIPORTS = {  # NYC heliports and airports [deg]
    "VP_DMH": (40.7013, -74.0090), "VP_E34": (40.7425, -73.9718), "VP_W30": (40.7546, -74.0076),
    "VP_JFK": (40.6413, -73.7781), "VP_LGA": (40.7769, -73.8740), "VP_EWR": (40.6895, -74.1745),
    "VP_TEB": (40.8501, -74.0608), "VP_BKN": (40.6782, -73.9442),
}


def synthetic_scenario(n_flights: int = 100, span_s: float = 1500.0, seed: int = 0) -> str:
    """N EC135 flights between NYC vertiports over ``span_s`` of departures, UAMToolkit-style lines.

    Each flight: CRE at its origin at 0 kt, ORIG/DEST, one or two route nodes
    near the straight line, VNAV OFF (keeps its lane altitude), SPD cruise,
    deleted on arrival by ATDIST ... DEL.
    """
    rng = np.random.default_rng(seed)
    names = list(VERTIPORTS)
    lines = [f"00:00:00.00>DEFWPT {n} {la:.6f} {lo:.6f}" for n, (la, lo) in VERTIPORTS.items()]
    flights = []
    for k in range(n_flights):
        o, d = rng.choice(len(names), 2, replace=False)
        (la0, lo0), (la1, lo1) = VERTIPORTS[names[o]], VERTIPORTS[names[d]]
        nodes = [(la0 + f * (la1 - la0) + rng.normal(0, 0.004), lo0 + f * (lo1 - lo0) + rng.normal(0, 0.005))
                 for f in sorted(rng.uniform(0.25, 0.75, rng.integers(1, 3)))]
        hdg = np.degrees(np.arctan2((nodes[0][1] - lo0) * np.cos(np.radians(la0)), nodes[0][0] - la0)) % 360
        alt_ft = 1000 + 250 * rng.integers(0, 5)
        flights.append((rng.uniform(0, span_s), f"UAM{k:03d}", names[o], names[d], la0, lo0, la1, lo1, nodes, hdg,
                        alt_ft, rng.uniform(90, 130)))
    for t, cs, orig, dest, la0, lo0, la1, lo1, nodes, hdg, alt_ft, kts in sorted(flights):
        stamp = f"{int(t // 3600):02d}:{int(t % 3600 // 60):02d}:{t % 60:05.2f}>"
        body = [f"CRE {cs} EC35 {la0:.6f} {lo0:.6f} {hdg:.1f} {alt_ft} 0", f"ORIG {cs} {orig}", f"DEST {cs} {dest}",
                *(f"ADDWPT {cs} {la:.6f} {lo:.6f}" for la, lo in nodes), f"VNAV {cs} OFF", f"SPD {cs} {kts:.1f}",
                f"{cs} ATDIST {la1:.6f} {lo1:.6f} 0.05 DEL {cs}"]
        lines += [stamp + line for line in body]
    return "\n".join(lines) + "\n"


@dataclass
class Result:
    backend: str
    interval_s: float
    agents: int
    steps: int
    transitions: int
    reset_s: float
    wall_s: float
    cpu_s: float
    sim_s: float


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_episode(scenario: Path, interval_s: float, backend: str, address: str | None, server_pid: int | None,
                seed: int) -> Result:
    env = rlbridge.parallel_env(scenario, backend=backend, address=address, decision_interval_s=interval_s,
                                timeout_s=120.0, **fixed_traffic("corridor_sa"))
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    env.reset(seed=seed)
    reset_s = time.perf_counter() - t0
    steps = transitions = 0
    cpu0 = time.process_time() + (cpu_seconds(server_pid) if server_pid else 0.0)
    t0 = time.perf_counter()
    while env.agents:
        actions = dict(zip(env.agents, rng.integers(0, 3, len(env.agents)).tolist()))
        _, rewards, *_ = env.step(actions)
        steps += 1
        transitions += len(rewards)
    wall = time.perf_counter() - t0
    cpu = time.process_time() + (cpu_seconds(server_pid) if server_pid else 0.0) - cpu0
    sim_s = env.last_result.simt if env.last_result else 0.0
    agents = len(env.possible_agents)
    env.close()
    return Result(backend, interval_s, agents, steps, transitions, reset_s, wall, cpu, sim_s)


def fixed_traffic(usecase: str) -> dict:
    """The parameters that switch a use case's per-seed draws off (none in versions before it had draws)."""
    from rlbridge.usecases.registry import usecase_class

    return dict(getattr(usecase_class(usecase), "fixed_traffic", {}))


def run_planner_episode(env: rlbridge.AamParallelEnv, seed: int) -> tuple[int, int, float, float, float]:
    """One episode of a planner env with random valid actions: (decisions, flights, wall s, CPU s, sim s).

    The env is reused between episodes, as a rollout worker does: the intent probe of the
    scenario runs at its first episode only.
    """
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    decisions = 0
    cpu0, t0 = time.process_time(), time.perf_counter()
    while env.agents:
        mask = obs["planner"]["action_mask"]
        valid = np.flatnonzero(mask) if mask.any() else np.array([0])
        obs, *_ = env.step({"planner": int(rng.choice(valid))})
        decisions += 1
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    flights = len(env.core.sim.flight_log) + env.core.sim.view.n if env.core.sim is not None else 0
    sim_s = env.last_result.simt if env.last_result else 0.0
    return decisions, flights, wall, cpu, sim_s


def start_server(root: Path) -> tuple[subprocess.Popen, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "serve", "--bind", "tcp://127.0.0.1:*",
                             "--scenario-root", str(root), "--log-level", "WARNING"],
                            stdout=subprocess.PIPE, text=True, env=env)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    line = lines.get(timeout=120)
    return proc, line.split("listening on ", 1)[1].strip()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="nyc_train_100.scn", help="scenario (path or shipped name)")
    parser.add_argument("--intervals", type=float, nargs="+", default=[10.0, 1.0], help="decision intervals [s]")
    parser.add_argument("--backends", nargs="+", default=["local", "zmq"], choices=["local", "zmq"])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--planners", nargs="*", default=["strategic_planning", "hierarchical"],
                        help="planner use cases to measure in-process (decisions per second)")
    args = parser.parse_args()

    found = resolve_scenario(args.scenario)
    workdir = Path(tempfile.mkdtemp(prefix="bench_env_"))
    if found is None:
        found = workdir / "synthetic_nyc_100.scn"
        found.write_text(synthetic_scenario())
        print(f"note: {args.scenario} not found; using a synthetic stand-in: 100 EC135 flights between 8 NYC "
              f"vertiports, departures over 25 min ({found})")
    scenario = found.resolve()
    print(f"scenario {scenario.name}; multi-agent env (corridor_sa), random actions, dt 0.05 s; "
          f"{os.cpu_count()} CPUs")
    server = None
    address = None
    if "zmq" in args.backends:
        server, address = start_server(scenario.parent)
    # Warm-up (Numba caches, imports) so that the first measurement is not penalised.
    run_episode(scenario, 60.0, "local", None, None, args.seed)
    header = (f"{'backend':8} {'interval':>8} {'agents':>6} {'steps':>6} {'transitions':>11} {'wall s':>7} "
              f"{'trans/s':>9} {'trans/CPU-s':>11} {'sim speed-up':>12}")
    print(header)
    try:
        for interval in args.intervals:
            for backend in args.backends:
                r = run_episode(scenario, interval, backend, address, server.pid if backend == "zmq" else None,
                                args.seed)
                print(f"{r.backend:8} {r.interval_s:7g}s {r.agents:6d} {r.steps:6d} {r.transitions:11d} "
                      f"{r.wall_s:7.2f} {r.transitions / r.wall_s:9,.0f} {r.transitions / r.cpu_s:11,.0f} "
                      f"{r.sim_s / r.wall_s:11,.0f}x", flush=True)
    finally:
        if server is not None:
            server.send_signal(signal.SIGTERM)
            server.wait(30)
    if args.planners:
        print(f"\n{'planner env':20} {'decisions':>9} {'flights':>7} {'wall s':>7} {'decisions/s':>11} "
              f"{'decisions/CPU-s':>15} {'ms/flight':>9} {'sim speed-up':>12}")
        for usecase in args.planners:
            # On its fixed traffic (the use case's -v0 settings): the same episode whatever the version, so
            # that side-by-side runs compare the code, not two draws of altitude noise.
            env = rlbridge.parallel_env(scenario, usecase=usecase, **fixed_traffic(usecase))
            run_planner_episode(env, args.seed)  # warm-up: the intent probe, compilation
            d, f, wall, cpu, sim_s = run_planner_episode(env, args.seed)
            env.close()
            print(f"{usecase:20} {d:9d} {f:7d} {wall:7.2f} {d / wall:11,.0f} {d / cpu:15,.0f} "
                  f"{1000 * wall / max(f, 1):9.2f} {sim_s / wall:11,.0f}x", flush=True)


if __name__ == "__main__":
    main()
