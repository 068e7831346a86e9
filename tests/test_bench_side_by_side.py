"""bench/side_by_side.py: the order of the runs and the medians it prints."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# A "benchmark" that appends its tree's name to a shared log (the order of the runs) and prints a figure
# that grows with each run of its tree: run k of a tree prints its base + k.
SCRIPT = """
import sys
from pathlib import Path
tree = Path(__file__).parent.name
log = Path(sys.argv[1])
log.write_text(log.read_text() + tree + " " if log.exists() else tree + " ")
runs = log.read_text().split().count(tree)
base = {"old": 100, "new": 200}[tree]
print("header without numbers")
print(f"rate {base + runs} steps/s")
"""


def test_rounds_alternate_abba_and_medians_are_per_tree(tmp_path):
    for tree in ("old", "new"):
        (tmp_path / tree).mkdir()
        (tmp_path / tree / "bench.py").write_text(SCRIPT)
    log = tmp_path / "order.log"
    out = subprocess.run([sys.executable, str(ROOT / "bench" / "side_by_side.py"), "--before", str(tmp_path / "old"),
                          "--after", str(tmp_path / "new"), "--rounds", "4", "--", "bench.py", str(log)],
                         capture_output=True, text=True, check=True).stdout
    assert log.read_text().split() == ["old", "new", "new", "old", "old", "new", "new", "old"]
    # Old printed 101..104, new 201..204: medians 102.5 and 202.5, +97.6 %.
    assert "rate" in out and "102.5 -> 202.5 (+97.6 %)" in out
    assert "header without numbers" in out
