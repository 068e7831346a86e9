"""``aamsim batch``: planning, BlueSky batch files, statistics, and a two-node Ray cluster on loopback."""

from __future__ import annotations

import csv
import json
import math
import os
import secrets
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aamsim.batch import BatchError, load_sources, parse_settings, plan_jobs
from aamsim.batch.aggregate import describe, flatten_metrics
from aamsim.batch.plan import folder_name, scenario_sources

# Random traffic (seeded by --seed) dense enough for separation events at one level.
RANDOM_TRAFFIC = "00:00:00.00>MCRE 60 B744 FL100 300\n"

BATCH_FILE = """# a BlueSky batch file: two scenarios
00:00:00.00>SCEN ONE
00:00:00.00>CRE A1 B744 0 0 90 FL100 250
00:00:00.00>CRE A2 B744 0 0.3 270 FL100 250
00:10:00.00>QUIT
00:00:00.00>SCEN TWO
00:00:00.00>CRE B1 B744 0 0 90 FL100 250
00:00:00.00>NOSUCHCOMMAND 1 2
00:05:00.00>QUIT
"""


def test_a_file_without_scen_blocks_is_one_scenario(tmp_path: Path) -> None:
    sources, warnings = scenario_sources(tmp_path / "plain.scn", RANDOM_TRAFFIC)
    assert [(s.name, s.text) for s in sources] == [("plain", RANDOM_TRAFFIC)] and warnings == []


def test_batch_file_splits_at_scen_lines_as_bluesky_does(tmp_path: Path) -> None:
    sources, warnings = scenario_sources(tmp_path / "b.scn", BATCH_FILE)
    assert [s.name for s in sources] == ["ONE", "TWO"]
    assert [s.first_line for s in sources] == [2, 6]
    assert "CRE A2" in sources[0].text and "CRE B1" not in sources[0].text
    # Line numbers inside a block stay those of the file: line 8 is the unknown command.
    assert sources[1].text.splitlines()[7] == "00:00:00.00>NOSUCHCOMMAND 1 2"
    assert warnings == []


def test_lines_before_the_first_scen_are_reported_not_run(tmp_path: Path) -> None:
    text = "00:00:00.00>CRE X B744 0 0 0 FL100 250\n" + BATCH_FILE
    sources, warnings = scenario_sources(tmp_path / "b.scn", text)
    assert [s.name for s in sources] == ["ONE", "TWO"]
    assert len(warnings) == 1 and "b.scn:1:" in warnings[0] and "before the first SCEN" in warnings[0]
    assert all("CRE X" not in s.text for s in sources)


def test_scenario_names_are_unique_across_files(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for d in ("a", "b"):
        (tmp_path / d / "same.scn").write_text(RANDOM_TRAFFIC)
    sources, _ = load_sources([tmp_path / "a" / "same.scn", tmp_path / "b" / "same.scn"])
    assert [s.name for s in sources] == ["same", "same-2"]


@pytest.mark.parametrize("given, folder", [
    ("../../../../tmp/x", "_.._.._.._.._tmp_x"), ("/tmp/x", "_tmp_x"), ("..", "_.."), (".", "_."),
    (".hidden", "_.hidden"), ("a\\..\\b", "a_.._b"), ("ONE", "ONE"), ("lowc=450,76", "lowc=450,76"),
])
def test_folder_names_stay_inside_the_batch_folder(given: str, folder: str) -> None:
    assert folder_name(given) == folder


def test_scen_names_that_are_paths_are_renamed_with_a_warning(tmp_path: Path) -> None:
    text = "".join(f"00:00:00.00>SCEN {name}\n00:00:00.00>CRE A B744 0 0 0 FL100 250\n"
                   for name in ("../../../../tmp/x", "/tmp/x", "..", "OK"))
    sources, warnings = scenario_sources(tmp_path / "b.scn", text)
    assert [s.name for s in sources] == ["_.._.._.._.._tmp_x", "_tmp_x", "_..", "OK"]
    assert [w.split(": ")[0] for w in warnings] == [f"{tmp_path / 'b.scn'}:{k}" for k in (1, 3, 5)]
    assert "'/tmp/x' is not a plain folder name; the scenario is named '_tmp_x'" in warnings[1]
    jobs = plan_jobs(sources, parse_settings([]), [0])
    root = (tmp_path / "out").resolve()
    assert all((root / j.relpath).resolve().is_relative_to(root) for j in jobs)


def test_a_setting_given_twice_is_refused() -> None:
    """Found by the batch fuzzer: both runs went to one folder, the second overwriting the first."""
    with pytest.raises(BatchError, match='--set "lowc=450,76": given twice'):
        parse_settings(["lowc=450,76", "nmac=150", "lowc=450,76"])


def test_long_scenario_names_cut_to_one_folder_name_stay_apart(tmp_path: Path) -> None:
    """Found by the batch fuzzer: two names cut to the same 120 characters shared a folder."""
    text = "".join(f"00:00:00.00>SCEN {'x' * 200}{tail}\n00:00:00.00>CRE A B744 0 0 0 FL100 250\n"
                   for tail in ("", "-rf", "+1"))
    sources, _ = scenario_sources(tmp_path / "b.scn", text)
    folders = [j.relpath for j in plan_jobs(sources, parse_settings([]), [0])]
    assert len(set(folders)) == 3 and all(len(f.split("/")[0]) <= 120 for f in folders)


def test_settings_are_the_cartesian_product_of_repeated_keys() -> None:
    points = parse_settings(["lowc=450", "nmac=150", "lowc=600", "nmac=100,50"])
    assert [p.label for p in points] == ["lowc=450,nmac=150", "lowc=450,nmac=100,50",
                                         "lowc=600,nmac=150", "lowc=600,nmac=100,50"]
    fields = points[1].run_config_fields()
    nmac, lowc = fields["volumes"]
    assert (nmac.radius_m, nmac.half_height_m, lowc.radius_m, lowc.half_height_m) == (100.0, 50.0, 450.0, None)
    assert parse_settings([])[0].label == "default"


@pytest.mark.parametrize("item, message", [
    ("wind=3", "unknown key 'wind'; known: dt, until"),
    ("lowc", "expected KEY=VALUE"),
    ("dt=-1", 'dt="-1": must be a positive number'),
    ("dt=nan", 'dt="nan": must be a positive number'),
    ("dt=1e300", 'dt="1e300": time step must be between 0.0001 s and 10 s'),  # docs/batch.md promised it
    ("dt=0.00001", 'dt="0.00001": time step must be between 0.0001 s and 10 s'),
    ("lowc=0", "positive metres"),
    ("until=soon", "until:"),
    ("delete_on_arrival=maybe", "expected true or false"),
])
def test_bad_settings_are_refused_before_anything_runs(item: str, message: str) -> None:
    with pytest.raises(BatchError, match=None) as info:
        parse_settings([item])
    assert message in str(info.value)


def test_plan_is_scenario_major_with_every_seed(tmp_path: Path) -> None:
    sources, _ = scenario_sources(tmp_path / "b.scn", BATCH_FILE)
    jobs = plan_jobs(sources, parse_settings(["lowc=450", "lowc=600"]), [3, 4])
    assert [j.relpath for j in jobs[:4]] == ["ONE/lowc=450/seed-3", "ONE/lowc=450/seed-4",
                                             "ONE/lowc=600/seed-3", "ONE/lowc=600/seed-4"]
    assert len(jobs) == 8 and [j.index for j in jobs] == list(range(8))


def test_statistics_by_hand() -> None:
    st = describe([1.0, 2.0, 3.0])
    # mean 2, sample std 1, t(0.975, 2 dof) = 4.302652729911275 -> half-width 4.3027 / sqrt(3) = 2.484138
    assert st.n == 3 and st.mean == 2.0 and st.std == 1.0
    assert st.ci95_low == pytest.approx(2.0 - 2.484138, abs=1e-6)
    assert st.ci95_high == pytest.approx(2.0 + 2.484138, abs=1e-6)
    one = describe([5.0])
    assert (one.n, one.mean, one.std, one.ci95_low) == (1, 5.0, None, None)
    assert describe([]).mean is None


def test_flatten_keeps_numbers_and_leaves_out_descriptions() -> None:
    summary = {"scenario": "x", "seed": 3, "flights_created": 4, "errors": 0,
               "safety": {"nmac_events": 2, "min_separation_m": None},
               "operational": {"mean_delay_s": 1.5, "holding_flight_share": 0.25}}
    assert flatten_metrics(summary) == {"flights_created": 4.0, "errors": 0.0, "safety.nmac_events": 2.0,
                                        "safety.min_separation_m": None, "operational.mean_delay_s": 1.5,
                                        "operational.holding_flight_share": 0.25}


def _aamsim(*args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "aamsim", *args], check=False, cwd=cwd, capture_output=True,
                          text=True, timeout=600, env=env)


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_batch_file_runs_each_block_and_reports_errors_with_file_lines(tmp_path: Path) -> None:
    (tmp_path / "b.scn").write_text(BATCH_FILE)
    proc = _aamsim("batch", "b.scn", "--no-ray", "--quiet", "--out", "out", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    runs = _read_csv(tmp_path / "out" / "runs.csv")
    assert [(r["scenario"], r["flights_created"], r["sim_time_s"]) for r in runs] == [
        ("ONE", "2.0", "600.0"), ("TWO", "1.0", "300.0")]
    log = (tmp_path / "out" / "TWO" / "default" / "seed-0" / "messages.log").read_text()
    assert "b.scn:8:" in log and "NOSUCHCOMMAND" in log
    summary = json.loads((tmp_path / "out" / "ONE" / "default" / "seed-0" / "summary.json").read_text())
    assert summary["scenario"] == "ONE"


def test_batch_file_scen_paths_write_nothing_outside_out(tmp_path: Path) -> None:
    """Issue 26 item 2: ``SCEN ../../x``, ``SCEN /abs`` and ``SCEN ..`` wrote run directories outside --out."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    outside = tmp_path / "abs"
    names = ["../../escaped", str(outside), "..", "fine"]
    (work / "b.scn").write_text("".join(f"00:00:00.00>SCEN {name}\n00:00:00.00>CRE A B744 0 0 0 FL100 250\n"
                                        "00:00:05.00>QUIT\n" for name in names))
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    proc = _aamsim("batch", "b.scn", "--no-ray", "--quiet", "--out", "out", cwd=work)
    assert proc.returncode == 0, proc.stderr
    after = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    new = [p for p in after if p not in before]
    assert new and all(p.parts[:3] == ("a", "b", "out") for p in new), new
    assert not outside.exists() and not (tmp_path / "escaped").exists()
    runs = _read_csv(work / "out" / "runs.csv")
    assert [r["scenario"] for r in runs] == ["_.._.._escaped", "_" + str(outside)[1:].replace("/", "_"), "_..", "fine"]
    assert all((work / "out" / r["run_dir"] / "summary.json").is_file() for r in runs)
    assert proc.stderr.count("is not a plain folder name") == 3


def test_batch_refuses_a_huge_time_step_before_running(tmp_path: Path) -> None:
    (tmp_path / "r.scn").write_text(RANDOM_TRAFFIC)
    proc = _aamsim("batch", "r.scn", "--set", "dt=1e300", "--no-ray", "--out", "out", cwd=tmp_path)
    assert proc.returncode == 2 and "time step must be between" in proc.stderr
    assert not (tmp_path / "out").exists()


def test_unknown_scenario_and_bad_set_exit_2(tmp_path: Path) -> None:
    proc = _aamsim("batch", "nope.scn", "--no-ray", cwd=tmp_path)
    assert proc.returncode == 2 and "not found: nope.scn" in proc.stderr
    (tmp_path / "r.scn").write_text(RANDOM_TRAFFIC)
    proc = _aamsim("batch", "r.scn", "--set", "speed=3", "--no-ray", cwd=tmp_path)
    assert proc.returncode == 2 and "unknown key 'speed'" in proc.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _ray_node(cmd: list[str], env: dict[str, str], log: Path) -> subprocess.Popen:
    with open(log, "wb") as fh:
        return subprocess.Popen(cmd, env=env, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)


def _wait_for_ray_nodes(port: int, count: int, env: dict[str, str], nodes: list[subprocess.Popen],
                        timeout_s: float = 300.0) -> None:
    """Wait until the cluster at ``port`` has ``count`` live nodes (a node that exits fails the test)."""
    probe = ("import ray, sys; ray.init(address=sys.argv[1], logging_level='ERROR'); "
             "print(sum(1 for n in ray.nodes() if n['Alive']))")
    deadline = time.monotonic() + timeout_s
    while True:
        for node in nodes:
            assert node.poll() is None, f"ray start exited with {node.returncode}: {node.args}"
        out = subprocess.run([sys.executable, "-c", probe, f"127.0.0.1:{port}"], env=env, capture_output=True,
                             text=True, timeout=180, check=False)
        if out.returncode == 0 and out.stdout.strip().splitlines()[-1:] == [str(count)]:
            return
        assert time.monotonic() < deadline, f"the cluster never had {count} nodes: {out.stdout}{out.stderr}"
        time.sleep(2.0)


def _end_process_group(proc: subprocess.Popen) -> None:
    """End ``ray start --block`` and the node's processes it started (one process group)."""
    for sig, wait_s in ((signal.SIGTERM, 60), (signal.SIGKILL, 30)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            continue
        # The leader is gone; what it started may linger a moment in the group.
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        return


@pytest.mark.slow
def test_two_node_ray_cluster_matches_runs_one_by_one(tmp_path: Path) -> None:
    ray_bin = Path(sys.executable).with_name("ray")
    if not ray_bin.exists():
        pytest.skip("the ray command is not installed (pip install -e '.[test]')")
    (tmp_path / "random.scn").write_text(RANDOM_TRAFFIC)
    port = _free_port()
    # Token authentication for every process of the cluster (head, second node, driver) with a token of
    # the test's own: Ray 2.5x turns it on for a head by itself once ~/.ray/auth_token exists (any earlier
    # ray.init makes one), and a second node without the token then cannot join.
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "token",
           "RAY_AUTH_TOKEN": secrets.token_hex(32)}
    ray_tmp = Path("/tmp") / f"aamsim-ray-{os.getpid()}"  # Ray's socket paths must stay short
    common = ["--num-cpus=1", "--node-ip-address=127.0.0.1", "--disable-usage-stats", "--block"]
    # Each node is a `ray start --block` in a process group of its own, ended by signalling that group:
    # `ray stop` would end every Ray process of the machine (a study running beside the tests, another
    # test worker's cluster).
    nodes: list[subprocess.Popen] = []
    try:
        nodes.append(_ray_node([str(ray_bin), "start", "--head", f"--port={port}", "--include-dashboard=false",
                                f"--temp-dir={ray_tmp}", *common], env, tmp_path / "head.log"))
        _wait_for_ray_nodes(port, 1, env, nodes)
        nodes.append(_ray_node([str(ray_bin), "start", f"--address=127.0.0.1:{port}", *common], env,
                               tmp_path / "node.log"))
        _wait_for_ray_nodes(port, 2, env, nodes)
        proc = _aamsim("batch", "random.scn", "--seeds", "3", "--set", "until=300", "--set", "lowc=450",
                       "--set", "lowc=900", "--address", f"127.0.0.1:{port}", "--out", "out", cwd=tmp_path, env=env)
        assert proc.returncode == 0, proc.stderr
        assert "Ray: 2 node(s), 2 CPU(s)" in proc.stderr
    finally:
        for node in reversed(nodes):
            _end_process_group(node)
        shutil.rmtree(ray_tmp, ignore_errors=True)
    runs = _read_csv(tmp_path / "out" / "runs.csv")
    assert len(runs) == 6 and all(r["error"] == "" for r in runs)
    assert len({r["node"] for r in runs}) == 2, "both nodes of the cluster ran jobs"

    # The same seeds one by one through `aamsim run`, then mean/std/CI by hand.
    aggregate = {(r["setting"], r["metric"]): r for r in _read_csv(tmp_path / "out" / "aggregate.csv")}
    for lowc in ("450", "900"):
        events: dict[str, list[float]] = {"safety.lowc_events": [], "safety.nmac_events": [], "flights_created": []}
        for seed in range(3):
            out = tmp_path / f"single-{lowc}-{seed}"
            proc = _aamsim("run", "random.scn", "--seed", str(seed), "--until", "300", "--lowc", lowc,
                           "--log-period", "0", "--quiet", "--out", str(out), cwd=tmp_path)
            assert proc.returncode == 0, proc.stderr
            summary = json.loads((out / "summary.json").read_text())
            events["safety.lowc_events"].append(summary["safety"]["lowc_events"])
            events["safety.nmac_events"].append(summary["safety"]["nmac_events"])
            events["flights_created"].append(summary["flights_created"])
        for metric, values in events.items():
            row = aggregate[(f"until=300,lowc={lowc}", metric)]
            assert int(row["n"]) == 3
            assert float(row["mean"]) == pytest.approx(statistics.fmean(values), rel=1e-12)
            assert float(row["std"]) == pytest.approx(statistics.stdev(values), rel=1e-12, abs=1e-12)
        half = 4.302652729911275 * statistics.stdev(events["safety.lowc_events"]) / math.sqrt(3)
        row = aggregate[(f"until=300,lowc={lowc}", "safety.lowc_events")]
        assert float(row["ci95_high"]) == pytest.approx(statistics.fmean(events["safety.lowc_events"]) + half)
    # A bigger LoWC volume cannot see fewer LoWC events on the same traffic, and there are some.
    mean_450 = float(aggregate[("until=300,lowc=450", "safety.lowc_events")]["mean"])
    mean_900 = float(aggregate[("until=300,lowc=900", "safety.lowc_events")]["mean"])
    assert 0 < mean_450 <= mean_900
    assert "| safety.lowc_events |" in (tmp_path / "out" / "aggregate.md").read_text()
