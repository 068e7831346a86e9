"""Which scenario files a remote client may make the server read.

A client names a scenario as ``aamsim run`` takes it: a path, or the name of
a scenario shipped with aamsim (``demo.scn``, ``scn/demo.scn``). The server
resolves it on its side and only reads ``.scn`` files that lie, after
resolving symbolic links and ``..``, inside one of its scenario roots (by
default its working directory) or among the shipped scenarios. The same
check guards the files that PCALL and IC open inside a remote session. A file
it refuses is answered exactly as a file that does not exist, so that a client
cannot learn which files exist elsewhere on the server.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from aamsim.errors import CommandError
from aamsim.scenarios import packaged_dir, packaged_scenario


class ScenarioAccessError(CommandError):
    """The scenario does not exist within the server's roots, or lies outside them."""

    def __init__(self, message: str, code: str):
        super().__init__(message)
        self.code = code


class ScenarioRoots:
    """The folders (and the shipped scenarios) a remote session may read scenarios from."""

    def __init__(self, roots: Sequence[str | Path] = ()):
        folders = [Path(r) for r in roots] or [Path.cwd()]
        self.roots: tuple[Path, ...] = tuple(p.resolve() for p in folders)
        self.shipped = packaged_dir().resolve()

    def allowed(self, path: Path) -> bool:
        """A regular ``.scn`` file inside a root or the shipped folder, after resolving links and ``..``."""
        try:
            real = path.resolve()
            if real.suffix.lower() != ".scn" or not real.is_file():
                return False
        except (OSError, RuntimeError, ValueError):  # too long, a symlink loop, a NUL
            return False
        return any(real.is_relative_to(root) for root in (*self.roots, self.shipped))

    def resolve(self, name: str) -> Path:
        """The file a client's scenario name refers to; raises :class:`ScenarioAccessError`."""
        if not name or "\x00" in name:
            raise ScenarioAccessError("scenario name is empty or contains a NUL character", "bad_request")
        given = Path(name)
        bases = [given] if given.is_absolute() else [root / given for root in self.roots]
        candidates = [c for base in bases for c in ((base,) if base.suffix else (base, base.with_suffix(".scn")))]
        for candidate in candidates:
            # A file outside the roots is answered as one that does not exist: a different answer
            # ("forbidden") told a client which files exist anywhere on the server.
            if self.allowed(candidate):
                return candidate.resolve()
        shipped = None if given.is_absolute() else packaged_scenario(name)
        if shipped is not None and self.allowed(shipped):  # the same check as every other file
            return shipped.resolve()
        raise ScenarioAccessError(f"scenario not found on the server: {name} (a client may open the .scn files "
                                  f"in {', '.join(map(str, self.roots))} and the shipped scenarios)", "not_found")

    def guard(self, path: Path) -> None:
        """``ScenarioFiles.guard``: refuse PCALL/IC of files outside the roots (as files that do not exist)."""
        if not self.allowed(path):
            raise ScenarioAccessError(f"{path.name}: not found", "not_found")
