"""Scenario lines for fuzzing, and the harness that runs them.

Lines come from three sources, mixed: real lines of the shipped scenarios,
mutated; lines built from the command table's argument specs (the same
table ``aamsim commands`` prints), with values drawn from each argument
type's good, edge and absurd values; and raw noise (random tokens, control
and unicode characters, huge and non-finite numbers, nested SCHEDULE/DELAY,
PCALL/IC of odd names). Each line runs in a simulation for two simulated
seconds; a failure is an exception that escapes the simulation's reporting
(anything but an error message) or a line that takes longer than the time
budget.
"""

from __future__ import annotations

import json
import random
import signal
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from aamsim import Simulation
from aamsim.scenarios import packaged_dir

CALLSIGNS = ["UAM1", "UAM2", "KL204", "X"]
NUMBERS = ["0", "-0", "1", "-1", "0.5", "90", "-90", "180", "-180", "360", "1e3", "1e-320", "1e308", "-1e308",
           "1e309", "nan", "inf", "-inf", "9" * 400, "0x10", "1_000", "١٢٣", "12:00:00", "FL" + "9" * 40, "M0.8",
           "M78", "250", "FL350", "-99999999", "3.4028235e38", ".", "-", "+", "e", "1e", "E5"]
WORDS = ["ON", "OFF", "", "REL", "ABS", "DEL", "ALL", "DO", "*", "#", ";", ",", ">", "\\", '"', "'", "WP_HUD",
         "EHAM", "EC35", "B744", "ZZZZ", "/tmp", ".", "..", "scn/demo.scn", "demo", "nyc_day", "/etc/passwd",
         "\x00", "\x0b", "\x1e", "\u2028", "é", "🚁", "\ufeff", " " * 50]
TYPE_VALUES = {
    "acid": CALLSIGNS + ["NOPE", "", "uam1"],
    "alt": ["1500", "FL100", "0", "-2000", "200000", "200001", "FL2000", "FL2001", "-1e6", "1e300", "FL"],
    "spd": ["120", "0", "-50", "M0.5", "M.8", "1e6", "1e300", "0.5", "M9"],
    "vspd": ["500", "-500", "0", "1e300", "-1e300"],
    "hdg": ["0", "90", "360", "-45", "270T", "090M", "1e300"],
    "float": ["0", "1", "-1", "0.05", "1e-9", "1e300", "nan"],
    "int": ["0", "1", "-1", "100000", "9" * 50],
    "latlon": ["40.7 -74.0", "N40'42'00.0 W074'00'00.0", "-3.061616997868383e-17 0.5", "91 0", "0 181", "UAM1",
               "WP_HUD", "EHAM"],
    "time": ["00:00:01", "1", "01:00:00", "1e308", "-1", "99:99:99", "9" * 400 + ":00"],
    "onoff": ["ON", "OFF", "1", "0", "maybe"],
    "wpinroute": ["WP_HUD", "UAM1001", "*", "NOPE"],
    "string": ["ECHO hi", "SPD UAM1 100", "SCHEDULE 1 ECHO x", "", "PCALL demo"],
    "txt": ["EC35", "B744", "UAM9", "", "x" * 300],
    "word": WORDS,
}

SETUP = ("00:00:00.00>DEFWPT WP_HUD 40.7300 -74.0150; CRE UAM1 EC35 40.70 -74.01 0 1500 60; "
         "ADDWPT UAM1 WP_HUD; CRE UAM2 EC35 40.71 -74.02 90 1500 60")
# Run once, untimed, before any line is timed: two aircraft head to head with conflict detection and
# resolution on and wind set, so that the step kernel, the conflict pass and the wind field are compiled
# (or loaded from Numba's cache) outside every line's budget. On a cold cache that takes over a minute on
# a loaded machine; the first timed line used to pay it and fail the 60 s limit.
WARM_UP = (SETUP + "; ASAS ON; RESO MVP; WIND 40.70 -74.0 1500 90 20; "
           "CRE WARM1 EC35 40.70 -74.00 90 1500 60; CRE WARM2 EC35 40.70 -73.99 270 1500 60")


def real_lines() -> list[str]:
    """Every command line of the shipped scenarios (the day files are sampled, not read whole)."""
    lines: list[str] = []
    for path in sorted(packaged_dir().glob("*.scn")):
        with open(path, encoding="utf-8", errors="replace") as fh:
            for k, line in enumerate(fh):
                if k > 3000:
                    break
                if ">" in line and not line.lstrip().startswith("#"):
                    lines.append(line.rstrip("\n"))
    return lines


@dataclass
class LineMaker:
    """Draws fuzz lines from the three sources (seeded)."""

    seed: int = 0
    rng: random.Random = field(init=False)
    real: list[str] = field(init=False)
    specs: list = field(init=False)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)
        self.real = real_lines()
        self.specs = list(Simulation(use_bluesky_navdata=False).commands.specs())

    def token(self) -> str:
        r = self.rng.random()
        if r < 0.45:
            return self.rng.choice(NUMBERS)
        if r < 0.8:
            return self.rng.choice(WORDS + CALLSIGNS)
        return "".join(chr(self.rng.choice([self.rng.randint(0, 0x7F), self.rng.randint(0x80, 0x2FFF)]))
                       for _ in range(self.rng.randint(1, 12)))

    def from_spec(self) -> str:
        spec = self.rng.choice(self.specs)
        args = []
        for param in spec.params:
            if param.optional and self.rng.random() < 0.3:
                break
            values = TYPE_VALUES.get(param.argtype.name, WORDS)
            args.append(self.rng.choice(values) if self.rng.random() < 0.85 else self.token())
        if spec.raw or self.rng.random() < 0.1:
            args += [self.token() for _ in range(self.rng.randint(0, 6))]
        sep = self.rng.choice([" ", ",", ", ", " ,"])
        return f"{spec.name} {sep.join(args)}".strip()

    def mutate(self, line: str) -> str:
        body = line.split(">", 1)[-1]
        words = body.replace(",", " ").split()
        for _ in range(self.rng.randint(1, 3)):
            op = self.rng.random()
            if not words or op < 0.2:
                words.insert(self.rng.randint(0, len(words)), self.token())
            elif op < 0.55:
                words[self.rng.randrange(len(words))] = self.token()
            elif op < 0.7:
                del words[self.rng.randrange(len(words))]
            elif op < 0.85:
                words = words + words[: self.rng.randint(1, len(words))]
            else:
                k = self.rng.randrange(len(words))
                w = words[k]
                cut = self.rng.randint(0, len(w))
                words[k] = w[:cut] + self.token() + w[cut:]
        return " ".join(words)

    def nested(self) -> str:
        inner = self.from_spec()
        for _ in range(self.rng.randint(1, 60)):
            inner = f"{self.rng.choice(['SCHEDULE', 'DELAY'])} {self.rng.choice(['0', '1', '00:00:01'])} {inner}"
        return inner

    def stamp(self) -> str:
        r = self.rng.random()
        if r < 0.85:
            return f"00:00:{self.rng.randint(0, 1):02d}.{self.rng.randint(0, 99):02d}>"
        return self.rng.choice(["", ">", "00:00>", "-1:00:00>", "9" * 400 + ":00:00.00>", "00:00:nan>",
                                "00:00:1e308>", "00:00:00.00>>", "\u2028>", "00:00:00.00"])

    def line(self) -> str:
        r = self.rng.random()
        if r < 0.35 and self.real:
            text = self.mutate(self.rng.choice(self.real))
        elif r < 0.75:
            text = self.from_spec()
        elif r < 0.85:
            text = self.nested()
        elif r < 0.93:
            text = "; ".join(self.from_spec() for _ in range(self.rng.randint(2, 8)))
        else:
            text = " ".join(self.token() for _ in range(self.rng.randint(1, 10)))
        return self.stamp() + text

    def lines(self, n: int) -> Iterator[str]:
        for _ in range(n):
            yield self.line()


@dataclass
class Failure:
    kind: str  # "crash" or "slow"
    line: str
    detail: str
    seconds: float


# A line that leaves more aircraft than this does work in proportion to them (creating and flying
# 100,000 aircraft takes seconds); it is counted apart, not held to the one-second budget.
HEAVY_AIRCRAFT = 10_000


class LineTimeout(Exception):
    """Raised by the alarm when one line runs far past its budget."""


@dataclass
class Harness:
    """Runs lines in simulations (a fresh one every ``fresh_every`` lines) and collects failures."""

    folder: Path
    budget_s: float = 1.0
    hard_limit_s: float = 20.0
    fresh_every: int = 100
    lines_run: int = 0
    heavy_lines: int = 0  # lines that created more than HEAVY_AIRCRAFT aircraft (no time budget)
    slowest_s: float = 0.0
    failures: list[Failure] = field(default_factory=list)
    log_path: Path | None = None  # failures are appended here as JSON lines as they happen
    # Lines that were slow among the others but not when run again alone, in a fresh simulation
    # (a loaded machine, Numba compiling on the first line): counted, never a failure.
    unconfirmed_slow: list[Failure] = field(default_factory=list)
    # The limit of a slow line's first rerun alone (default: 5 x hard_limit_s). That rerun may have to
    # compile again a kernel whose compilation the alarm interrupted, so it is long; the line is then
    # run alone once more, warm, and only that run is held to the budget and the hard limit.
    rerun_limit_s: float | None = None
    _sim: Simulation | None = None
    _warm: bool = False

    max_aircraft: int = 200  # a line that made more (MCRE 100000) is followed by a fresh simulation

    def warm_up(self) -> None:
        """Compile (or load) the simulation's kernels once, untimed, before the first line is timed."""
        if self._warm:
            return
        sim = Simulation(seed=1, use_bluesky_navdata=False)
        sim.load_text(WARM_UP, "warm_up.scn")
        sim.run_until(sim.simt + 10.0)
        self._warm = True

    def _simulation(self) -> Simulation:
        self.warm_up()
        crowded = self._sim is not None and self._sim.view.n > self.max_aircraft
        if self._sim is None or crowded or self.lines_run % self.fresh_every == 0:
            self._sim = self._fresh()
        return self._sim

    def _fresh(self) -> Simulation:
        sim = Simulation(seed=1, use_bluesky_navdata=False)
        sim.files.search_path.insert(0, self.folder)
        sim.load_text(SETUP, "setup.scn")
        sim.run_until(sim.simt)  # the setup line runs now
        return sim

    def _run_alone(self, line: str, limit_s: float) -> tuple[float, bool, bool]:
        """Run the line alone in a fresh simulation: (seconds, timed out, left over HEAVY_AIRCRAFT aircraft)."""
        sim = self._fresh()
        t0 = time.perf_counter()
        previous = signal.signal(signal.SIGALRM, _alarm) if hasattr(signal, "SIGALRM") else None
        if previous is not None:
            signal.setitimer(signal.ITIMER_REAL, limit_s)
        try:
            sim.load_text(line, "fuzz.scn")
            sim.run_until(sim.simt + 2.0)
        except LineTimeout:
            return time.perf_counter() - t0, True, False
        except Exception:  # noqa: BLE001, S110 - alone it crashes: the time it took counts (the crash was not seen)
            pass
        finally:
            if previous is not None:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, previous)
        return time.perf_counter() - t0, False, sim.view.n > HEAVY_AIRCRAFT

    def _slow_alone(self, line: str) -> str | None:
        """How the line is slow run again alone after the warm-up, None when it is not.

        The first rerun (limit ``rerun_limit_s``) finishes any compilation the alarm cut short; only the
        second, warm, is held to the budget and the hard limit.
        """
        self.warm_up()
        elapsed, timed_out, _ = self._run_alone(line, self.rerun_limit_s or 5 * self.hard_limit_s)
        if timed_out:
            return f"still running after {elapsed:.2f} s"
        elapsed, timed_out, heavy = self._run_alone(line, self.hard_limit_s)
        if timed_out:
            return f"still running after {elapsed:.2f} s"
        return f"{elapsed:.2f} s" if elapsed > self.budget_s and not heavy else None

    def _slow(self, line: str, detail: str, elapsed: float) -> None:
        """A slow line is a failure only when it is slow again alone (then both times are given)."""
        again = self._slow_alone(line)
        if again is None:
            self.unconfirmed_slow.append(Failure("slow", line, detail, elapsed))
        else:
            self.failures.append(Failure("slow", line, f"{detail}; again alone: {again}", elapsed))

    def run(self, line: str) -> None:
        """Run one line, written to ``fuzz.scn`` in the harness folder first (PCALL/IC of it is a case too)."""
        (self.folder / "fuzz.scn").write_text(line + "\n", encoding="utf-8")
        self.run_in_memory(line)

    def run_in_memory(self, line: str) -> None:
        """Run one line in the harness's simulation; record a crash or a line over the budget."""
        sim = self._simulation()
        known_before = len(self.failures)
        timed_out = ""
        t0 = time.perf_counter()
        previous = signal.signal(signal.SIGALRM, _alarm) if hasattr(signal, "SIGALRM") else None
        if previous is not None:
            signal.setitimer(signal.ITIMER_REAL, self.hard_limit_s)
        try:
            sim.load_text(line, "fuzz.scn")
            sim.run_until(sim.simt + 2.0)
        except LineTimeout:
            self._sim = None
            timed_out = f"still running after {self.hard_limit_s:g} s"
        except Exception as exc:  # noqa: BLE001 - that is what the harness looks for
            self.failures.append(Failure("crash", line, f"{type(exc).__name__}: {exc}"[:500],
                                         time.perf_counter() - t0))
            self._sim = None
        finally:
            if previous is not None:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, previous)
        elapsed = time.perf_counter() - t0
        self.slowest_s = max(self.slowest_s, elapsed)
        crowd = self._sim.view.n if self._sim is not None else 0
        if timed_out:
            self._slow(line, timed_out, elapsed)
        elif crowd > HEAVY_AIRCRAFT:
            self.heavy_lines += 1  # its work grows with the traffic it made (MCRE 100000): not a hang
        elif elapsed > self.budget_s and not any(f.line == line for f in self.failures[-1:]):
            self._slow(line, f"took {elapsed:.2f} s", elapsed)
        if self.log_path is not None and len(self.failures) > known_before:
            with open(self.log_path, "a", encoding="utf-8") as fh:
                fh.writelines(json.dumps(f.__dict__) + "\n" for f in self.failures[known_before:])
        self.lines_run += 1


def _alarm(signum: int, frame: object) -> None:
    raise LineTimeout()
