"""BlueSky's ``bluesky.tools``: ``geo``, ``aero`` and ``areafilter`` (the other tools are not provided)."""

from __future__ import annotations

from typing import NoReturn

from aamsim.compat.bluesky._errors import not_provided
from aamsim.compat.bluesky.tools import aero, areafilter, geo

__all__ = ["aero", "areafilter", "geo", "init"]


def init() -> None:
    """BlueSky initialises its tools at ``bluesky.init()``; these need nothing."""


def __getattr__(name: str) -> NoReturn:
    if name.startswith("__"):
        raise AttributeError(name)
    raise not_provided(f"bluesky.tools.{name}")
