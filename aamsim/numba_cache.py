"""Numba's on-disk cache, in a directory named after the source code that was compiled.

Numba checks a cached function against the modification time of its own file
only. The step kernel and the conflict pass call compiled functions from other
modules (navigation maths, pair tests, the spatial index) and inline them, so
after an update of one of those modules Numba would go on loading the old
machine code: results from a stale build, without a warning. Keying the cache
directory by a hash of every source file of the packages makes any change a
fresh cache (compiled once, about a minute).

``NUMBA_CACHE_DIR`` set by the user is respected. The directory is also passed
on to subprocesses (Ray workers, the simulation server) through the environment.

None of this happens at import: the package's compiled functions are made with
:func:`njit` below, which leaves the cache off until the function is first
compiled or loaded; that first time, :func:`prepare` hashes the sources, picks
the directory (once a process) and Numba's cache is switched on for the
function. An entry point may also call :func:`configure` itself.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

_PACKAGES = ("aamsim", "rlbridge", "uamtoolkit_import")
# Folders without compiled code, that no compiled code reads: a change there keeps the cache.
# (``aamsim.compat`` sits above everything else: .importlinter; tests/test_numba_cache.py checks it has no Numba.)
_NOT_COMPILED = ("aamsim/compat",)
# Cache directories of other source versions are kept while used in the last _KEEP_DAYS, up to
# _KEEP of them: several checkouts (git worktrees, a CI clone) share this cache, and keeping only
# the last three made them delete each other's directories, so every run compiled again (a minute).
_KEEP = 32
_KEEP_DAYS = 14


def package_roots() -> list[Path]:
    """The source directories of the packages (those installed)."""
    roots = [Path(__file__).parent]
    for name in _PACKAGES[1:]:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.origin:
            roots.append(Path(spec.origin).parent)
    return roots


def source_digest(roots: list[Path]) -> str:
    """A short hash of every ``.py`` file under ``roots`` (relative name and content)."""
    h = hashlib.sha256()
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            if f"{root.name}/{path.relative_to(root).as_posix()}".startswith(_NOT_COMPILED):
                continue
            h.update(f"{root.name}/{path.relative_to(root).as_posix()}\0".encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def default_base() -> Path:
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "aamsim" / "numba"


def configure() -> str | None:
    """Point Numba's cache at a directory for this exact source; returns it (None: the user chose one)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    base = default_base()
    directory = base / source_digest(package_roots())
    try:
        directory.mkdir(parents=True, exist_ok=True)
        _prune(base, directory)
    except OSError:
        return None  # not writable: Numba's own default (next to the sources, or none)
    os.environ["NUMBA_CACHE_DIR"] = str(directory)
    import numba

    numba.config.CACHE_DIR = str(directory)  # type: ignore[attr-defined]
    return str(directory)


def prepare() -> None:
    """What a process needs before it compiles or loads its first function of these packages.

    Numba's cache directory for this exact source (:func:`configure`, once a process: later calls
    find ``NUMBA_CACHE_DIR`` set and return at once) and the deferred SciPy import.
    """
    configure()
    defer_scipy_import()


class SourceKeyedDispatcher(CPUDispatcher):  # type: ignore[misc]
    """A compiled function that switches Numba's on-disk cache on at its first compilation, not at import.

    Numba picks a function's cache directory when its cache is switched on; ``njit(cache=True)`` does that
    when the module is imported, which would force the source hash and the directory to exist before any
    import of the package. Every compilation and every load from the cache goes through :meth:`compile`
    (a call from Python with new argument types, and the typing of a call from another compiled
    function), so switching the cache on there is the same cache, chosen later.
    """

    def compile(self, sig: Any) -> Any:
        if isinstance(getattr(self, "_cache", None), NullCache):  # (Numba sets it in __init__)
            prepare()
            self.enable_caching()
            _load_without_refresh(self._cache)  # type: ignore[attr-defined]
        return super().compile(sig)


def _load_without_refresh(cache: Any) -> None:
    """Load ``cache``'s machine code without first installing every implementation Numba has.

    Numba's ``Cache.load_overload`` refreshes the target context before it loads: it imports and
    installs all of Numba's typing and lowering registries (linear algebra, random numbers, strings,
    ...), 0.2 s of a process that only runs machine code loaded from the cache (a third of
    ``aamsim run`` with one aircraft). Loading needs none of them: the code is linked already and
    parallel code re-runs its own set-up (``reload_init``). What it does need are the C symbols the
    refresh installs: the runtime's memory functions (an array allocated by loaded code segfaulted
    without them) and the hash secrets; those are installed here. A cache miss compiles, and the
    compiler refreshes the context itself. Numba versions without these internals keep their own
    ``load_overload``.
    """
    load = getattr(cache, "_load_overload", None)
    guard = getattr(cache, "_guard_against_spurious_io_errors", None)
    try:
        import numba.cpython.hashing  # noqa: F401  (installs the hash secrets' symbols)
        from numba.core.runtime import rtsys
    except ImportError:
        return
    if load is None or guard is None or not hasattr(rtsys, "initialize"):
        return

    def load_overload(sig: Any, target_context: Any) -> Any:
        rtsys.initialize(target_context)  # the runtime's symbols (once a process; later calls return)
        with guard():
            return load(sig, target_context)
        return None  # the guard swallowed an I/O error: compile instead

    cache.load_overload = load_overload


_F = TypeVar("_F", bound=Callable[..., Any])


def njit(*, cache: bool = False, **options: Any) -> Callable[[_F], _F]:
    """``numba.njit(**options)`` whose ``cache=True`` takes effect at the first compilation (see above).

    Args:
        cache: keep the machine code on disk, in the directory keyed by the sources (:func:`configure`).
        **options: Numba's other options (``inline``, ``parallel``, ``error_model``, ...), unchanged.
    """
    import numba

    def decorate(fn: _F) -> _F:
        dispatcher = numba.njit(**options)(fn)
        if cache and type(dispatcher) is CPUDispatcher:  # (NUMBA_DISABLE_JIT returns the plain function)
            dispatcher.__class__ = SourceKeyedDispatcher  # the same object; only its compile() differs
        return dispatcher  # type: ignore[no-any-return]

    return decorate


def defer_scipy_import() -> None:
    """Spare every process the import of SciPy that Numba does before loading its first compiled function.

    Before it loads or compiles anything, Numba imports its array-function
    module, which asks once whether BLAS is there by importing
    ``scipy.linalg`` (0.2-0.3 s: SciPy's array-API layer walks numpy and
    imports ``numpy.f2py``); the answer only picks the inner product of
    ``np.convolve``/``np.correlate``. Here that one question is answered by
    whether SciPy is installed, without importing it; every later BLAS or
    LAPACK use (``np.dot``, ``np.linalg``) still imports and checks SciPy as
    before. Numba versions without that module layout are left alone.
    """
    if "numba.np.arraymath" in sys.modules:
        return
    try:
        from numba.np import linalg
    except ImportError:
        return
    ensure_blas = getattr(linalg, "ensure_blas", None)
    if ensure_blas is None:
        return

    def scipy_installed() -> None:
        if importlib.util.find_spec("scipy") is None:
            raise ImportError("scipy 0.16+ is required for linear algebra")

    linalg.ensure_blas = scipy_installed
    try:
        from numba.np import arraymath
    finally:
        linalg.ensure_blas = ensure_blas
    if getattr(arraymath, "ensure_blas", None) is scipy_installed:
        arraymath.ensure_blas = ensure_blas


def _prune(base: Path, current: Path) -> None:
    """Remove all but the most recently used cache directories."""
    current.touch()
    others = sorted((p for p in base.iterdir() if p.is_dir() and p != current), key=lambda p: p.stat().st_mtime,
                    reverse=True)
    cutoff = time.time() - _KEEP_DAYS * 86400
    for k, old in enumerate(others):
        if k >= _KEEP - 1 or old.stat().st_mtime < cutoff:
            shutil.rmtree(old, ignore_errors=True)
