"""Scenario files shipped inside the package (``aamsim/scn/``)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def packaged_dir() -> Path:
    return Path(str(resources.files("aamsim").joinpath("scn")))


def packaged_scenario(name: str) -> Path | None:
    """Find a shipped scenario: ``nyc_day.scn``, ``scn/nyc_day.scn`` or ``nyc_day``.

    Only ``.scn`` files that lie inside the shipped folder after resolving
    ``..`` and symbolic links are found: the ZeroMQ server offers this lookup
    to remote clients, and ``scn/../../../etc/passwd`` once resolved outside.
    """
    if not name or "\x00" in name:
        return None
    p = Path(name)
    if p.is_absolute() or ".." in p.parts:
        return None
    parts = p.parts[1:] if p.parts and p.parts[0] == "scn" else p.parts
    if not parts:
        return None
    folder = packaged_dir().resolve()
    candidate = folder.joinpath(*parts)
    options = (candidate,) if candidate.suffix else (candidate, candidate.with_suffix(".scn"))
    for option in options:
        try:
            real = option.resolve()
            found = real.is_file()
        except (OSError, RuntimeError):  # a name the file system rejects, a symlink loop
            continue
        if found and real.suffix.lower() == ".scn" and real.is_relative_to(folder):
            return real
    return None


def resolve_scenario(name: str | Path) -> Path | None:
    """A scenario path as a user gives it: relative to the cwd first, then shipped."""
    p = Path(name)
    if p.is_file():
        return p
    return packaged_scenario(str(name))


def shipped_names() -> list[str]:
    """The names of the shipped scenarios (``nyc_day``, ...), for messages that say what exists."""
    return sorted(p.stem for p in packaged_dir().glob("*.scn"))
