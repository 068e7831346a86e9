"""Packaging (metadata in setup.cfg): installs ``aamsim_bluesky.pth`` beside the packages.

The ``.pth`` file is Python's startup hook: with ``AAMSIM_BLUESKY=1`` in the
environment, every Python process of the installation makes ``import bluesky``
give aamsim's BlueSky API (``aamsim.compat.bluesky``); unset (or 0) it does
nothing. It is added to regular wheels (``build_py``) and to editable installs
(``pip install -e``), whose wheel setuptools builds in ``editable_wheel``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Self

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.command.editable_wheel import editable_wheel

STARTUP_HOOK = "aamsim_bluesky.pth"
HERE = Path(__file__).resolve().parent


class BuildPyWithStartupHook(build_py):
    """``build_py`` that also puts the startup hook at the top of the wheel (site-packages when installed)."""

    def run(self) -> None:
        super().run()
        self.copy_file(str(HERE / STARTUP_HOOK), os.path.join(self.build_lib, STARTUP_HOOK))

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        return [*super().get_outputs(include_bytecode), os.path.join(self.build_lib, STARTUP_HOOK)]


class _StrategyWithStartupHook:
    """Wraps setuptools' editable strategy: the editable wheel gets the startup hook too."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def __enter__(self) -> Self:
        self.inner.__enter__()
        return self

    def __exit__(self, *exc: object) -> Any:
        return self.inner.__exit__(*exc)

    def __call__(self, wheel: Any, files: Any, mapping: Any) -> None:
        self.inner(wheel, files, mapping)
        wheel.writestr(STARTUP_HOOK, (HERE / STARTUP_HOOK).read_bytes())


class EditableWheelWithStartupHook(editable_wheel):
    """``editable_wheel`` whose wheel holds the startup hook (setuptools >= 64)."""

    def _select_strategy(self, *args: Any, **kwargs: Any) -> Any:
        return _StrategyWithStartupHook(super()._select_strategy(*args, **kwargs))


setup(cmdclass={"build_py": BuildPyWithStartupHook, "editable_wheel": EditableWheelWithStartupHook})
