"""Scenario files shipped inside the package (``aamsim/scn/``)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def packaged_dir() -> Path:
    return Path(str(resources.files("aamsim").joinpath("scn")))


def packaged_scenario(name: str) -> Path | None:
    """Find a shipped scenario: ``nyc_day.scn``, ``scn/nyc_day.scn`` or ``nyc_day``."""
    p = Path(name)
    parts = p.parts[1:] if p.parts and p.parts[0] == "scn" else p.parts
    if not parts:
        return None
    candidate = packaged_dir().joinpath(*parts)
    for option in (candidate, candidate.with_suffix(".scn")):
        if option.is_file():
            return option
    return None


def resolve_scenario(name: str | Path) -> Path | None:
    """A scenario path as a user gives it: relative to the cwd first, then shipped."""
    p = Path(name)
    if p.is_file():
        return p
    return packaged_scenario(str(name))


def list_packaged() -> list[str]:
    return sorted(p.name for p in packaged_dir().glob("*.scn"))
