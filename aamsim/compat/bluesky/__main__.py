"""Run a Python script with ``import bluesky`` on aamsim: ``python -m aamsim.compat.bluesky script.py [args]``.

The same as setting ``AAMSIM_BLUESKY=1`` for that one script: the shim is
installed (:func:`aamsim.compat.bluesky.install`), then the script runs as
``__main__`` with its arguments.
"""

from __future__ import annotations

import runpy
import sys

from aamsim.compat.bluesky import install


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help"):
        print(__doc__.strip().splitlines()[0])
        raise SystemExit(0 if args else 2)
    install()
    sys.argv = list(args)
    runpy.run_path(args[0], run_name="__main__")


if __name__ == "__main__":
    main()
