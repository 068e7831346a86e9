"""Run a Markdown page's code blocks in order, as a reader would: how the tutorials are executed in CI.

    python tests/doc_runner.py docs/tutorials/simulate.md --workdir /tmp/tut --clone-root .

The rules (docs/tutorials/index.md states them for readers):

* a ```` ```python ```` block runs in one Python namespace shared by the page's blocks;
* a ```` ```bash ```` block runs in ``bash -euo pipefail``;
* a block with a title (```` ```python title="my_usecase.py" ````) is a file: it is written to
  that path, not run;
* any other block (``console``, ``text``, ``yaml`` without a title, ...) is shown, not run.

Everything runs in ``--workdir``. With ``--clone-root``, the folders ``examples`` and
``tests`` of that checkout are linked into the work folder, so that paths written as "from
the root of a clone" work while the page's outputs stay out of the checkout. A failing
block stops the run with the page, line and block named; the exit status is 1.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

FENCE = re.compile(r"^(?P<indent> *)(?P<fence>```+|~~~+)(?P<info>[^\n`]*)$")
RUN = {"python": "python", "py": "python", "bash": "bash", "sh": "bash"}


@dataclass(frozen=True)
class Block:
    """One fenced code block of a page."""

    lang: str
    title: str | None
    code: str
    line: int  # of the opening fence, 1-based


def blocks(text: str) -> list[Block]:
    """The fenced code blocks of a Markdown text, in order."""
    out: list[Block] = []
    lines = text.splitlines()
    k = 0
    while k < len(lines):
        m = FENCE.match(lines[k])
        if not m:
            k += 1
            continue
        fence, indent, info = m["fence"], len(m["indent"]), m["info"].strip()
        lang = info.split()[0].strip("{}.").lower() if info else ""
        title = re.search(r'title="([^"]+)"', info)
        body: list[str] = []
        j = k + 1
        while j < len(lines) and not (lines[j].strip().startswith(fence) and set(lines[j].strip()) <= set(fence)):
            body.append(lines[j][indent:] if lines[j][:indent].strip() == "" else lines[j])
            j += 1
        out.append(Block(lang, title.group(1) if title else None, "\n".join(body) + "\n", k + 1))
        k = j + 1
    return out


def run_page(page: Path, workdir: Path, clone_root: Path | None = None) -> int:
    """Run a page's blocks in ``workdir``; 0, or 1 after naming the failing block."""
    workdir.mkdir(parents=True, exist_ok=True)
    if clone_root is not None:
        for name in ("examples", "tests"):
            link = workdir / name
            if not link.exists():
                link.symlink_to(clone_root.resolve() / name, target_is_directory=True)
    os.chdir(workdir)
    namespace: dict[str, object] = {"__name__": "__main__"}
    sys.path.insert(0, str(workdir))  # modules a page writes (title="x.py") import as in a script's folder
    for block in blocks(page.read_text(encoding="utf-8")):
        where = f"{page}:{block.line}"
        if block.title is not None:
            target = workdir / block.title
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.code, encoding="utf-8")
            print(f"--- {where}: wrote {block.title}", flush=True)
            continue
        kind = RUN.get(block.lang)
        if kind is None:
            continue
        print(f"--- {where}: {kind}", flush=True)
        if kind == "bash":
            print("\n".join(f"$ {line}" for line in block.code.strip().splitlines()), flush=True)
            proc = subprocess.run(["bash", "-euo", "pipefail", "-c", block.code], check=False)
            if proc.returncode != 0:
                print(f"FAILED {where}: bash exited with {proc.returncode}: {shlex.quote(block.code[:200])}",
                      file=sys.stderr)
                return 1
        else:
            try:
                exec(compile(block.code, where, "exec"), namespace)  # noqa: S102  (the page is the program)
            except BaseException as exc:  # noqa: BLE001  (any failure of the page's code fails the page)
                import traceback

                traceback.print_exc()
                print(f"FAILED {where}: {type(exc).__name__}: {exc}", file=sys.stderr)
                return 1
            sys.stdout.flush()
    print(f"--- {page}: every block ran", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("page", type=Path)
    ap.add_argument("--workdir", type=Path, required=True)
    ap.add_argument("--clone-root", type=Path, default=None)
    args = ap.parse_args(argv)
    return run_page(args.page.resolve(), args.workdir, args.clone_root)


if __name__ == "__main__":
    sys.exit(main())
