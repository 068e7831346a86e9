"""Optional features and the extra that installs each.

The base install (``pip install aamsim``) is the simulator, its environments and the viewer.
A feature that needs more checks for its modules before it starts and, when one is missing,
stops with :class:`MissingExtra`: one line naming the extra to install, e.g.

    aamsim batch runs its jobs on Ray, which is not installed: pip install "aamsim[batch]"

The console scripts print that line (``error: ...``) and exit with status 2; called from Python,
it is an ``ImportError`` whose message is that line.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable

# extra -> the modules it brings (what `require` looks for) and what it is for (docs/getting-started.md)
EXTRAS: dict[str, tuple[tuple[str, ...], str]] = {
    "rl": (("torch", "ray", "hydra", "omegaconf", "stable_baselines3"),
           "train and evaluate agents: aamgym, the RLlib and Stable-Baselines3 examples"),
    "batch": (("ray",), "aamsim batch on Ray, locally or on a cluster"),
    "video": (("imageio_ffmpeg", "moviepy"), "MP4 videos of runs and gymnasium.wrappers.RecordVideo"),
    "realtraffic": (("pyarrow",), "Parquet recordings of real traffic"),
    "bluesky": (("bluesky",), "BlueSky as the simulator behind the environments (backend=bluesky)"),
    "bluesky-gym": (("bluesky_gym", "pygame", "torch"),
                    "bluesky-gym's environments on aamsim (AAMSIM_BLUESKY=1, docs/bluesky-api.md)"),
    "docs": (("mkdocs", "material", "mkdocstrings"), "the documentation site"),
}


class MissingExtra(ImportError):
    """A feature's module is not installed; the message names the extra that installs it."""

    def __init__(self, feature: str, modules: Iterable[str], extra: str, hint: str = ""):
        self.feature = feature
        self.modules = tuple(modules)
        self.extra = extra
        what = " and ".join(self.modules)
        verb = "is" if len(self.modules) == 1 else "are"
        message = f'{feature} needs {what}, which {verb} not installed: pip install "aamsim[{extra}]"'
        super().__init__(message + (f" ({hint})" if hint else ""), name=self.modules[0])


def missing(modules: Iterable[str]) -> list[str]:
    """The top-level modules of ``modules`` that cannot be imported (looked up, not imported)."""
    out = []
    for name in modules:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):  # a parent package missing, or a module hidden as None
            found = False
        if not found:
            out.append(name)
    return out


def require(extra: str, feature: str, modules: Iterable[str] | None = None, hint: str = "") -> None:
    """Raise :class:`MissingExtra` if a module ``feature`` needs is not installed.

    Args:
        extra: the extra that installs the modules (a key of :data:`EXTRAS`).
        feature: what the user asked for, as the message names it (``"aamsim batch"``).
        modules: the modules to look for; default: every module of the extra.
        hint: an alternative that needs nothing more, added in parentheses.
    """
    if extra not in EXTRAS:
        raise KeyError(f"unknown extra {extra!r}; known: {', '.join(EXTRAS)}")
    absent = missing(EXTRAS[extra][0] if modules is None else modules)
    if absent:
        raise MissingExtra(feature, absent, extra, hint)


__all__ = ["EXTRAS", "MissingExtra", "missing", "require"]
