"""The scenario files of one simulation: which one runs, where PCALL/IC look, who may be read.

:class:`ScenarioFiles` keeps the first file loaded (its name, path and exact
text, which the run directory records), the folders that relative names are
resolved against, the guard that a server uses to keep file access inside its
scenario roots, and the chains of PCALL/IC calls that catch cycles.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from aamsim.errors import CommandError


class ScenarioFiles:
    """Scenario files of one simulation (see the module's docstring)."""

    def __init__(self) -> None:
        self.name = ""
        self.path: Path | None = None
        self.text = ""
        self.search_path: list[Path] = []
        # Called with every file PCALL/IC resolve; raises CommandError to refuse it (the ZMQ server's roots).
        # A refused file is answered as a missing one, so that its existence is not told.
        self.guard: Callable[[Path], None] | None = None
        # File -> the chain of files whose PCALL/IC loaded it (kept across IC's reset, so that
        # files that IC each other are caught as a cycle too).
        self.call_chains: dict[str, tuple[str, ...]] = {}
        # Commands PCALL has queued and files it has loaded since the last reset, and the PCALLs
        # refused once either reached its budget (aamsim.stack.commands.sim_cmds.MAX_PCALL_COMMANDS): a fan-out of files that
        # each PCALL the next ten times grows tenfold per level.
        self.pcall_commands = 0
        self.pcall_files = 0
        self.pcall_refused = 0

    def reset_budget(self) -> None:
        """A new scenario (RESET, IC): PCALL's budget starts again."""
        self.pcall_commands = 0
        self.pcall_files = 0
        self.pcall_refused = 0

    def loaded(self, path: Path, text: str) -> None:
        """Note a file whose commands were queued: the first one names the scenario."""
        self.name = self.name or path.stem
        self.path = self.path or path
        self.text = self.text or text
        if path.parent not in self.search_path:
            self.search_path.insert(0, path.parent)

    def find(self, name: str) -> Path | None:
        """Resolve a scenario file name (PCALL, IC) against the search path, then ``guard`` it."""
        found = self._find(name)
        if found is not None and self.guard is not None:
            try:
                self.guard(found)
            except CommandError:
                return None  # "not found", like a file that is not there
        return found

    def _find(self, name: str) -> Path | None:
        candidate = Path(name)
        if not name.strip() or "\x00" in name or not candidate.name or candidate.name in (".", ".."):
            raise CommandError(f'"{name}" is not a file name')
        options = [candidate] if candidate.suffix else [candidate, candidate.with_suffix(".scn")]
        for option in options:
            try:
                if option.is_absolute():
                    if option.is_file():
                        return option
                    continue
                for folder in [*self.search_path, Path.cwd()]:
                    if (folder / option).is_file():  # a directory is not a scenario
                        return folder / option
            except OSError:  # a name the file system refuses (too long...)
                continue
            from aamsim.scenarios import packaged_scenario

            packaged = packaged_scenario(str(option))
            if packaged is not None:
                return packaged
        return None
