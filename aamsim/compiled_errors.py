"""The real exception behind Numba's ``SystemError: CPUDispatcher(...) returned a result with an exception set``.

A compiled function that returns arrays builds their Python objects in its wrapper, and that
wrapper calls back into Python (Numba's ``_numba_unpickle``) for each array without checking
for an error in between. A Python signal handler that raises (``KeyboardInterrupt`` on Ctrl-C
outside ``aamsim run``, an alarm that ends a case in a test harness) runs at the first Python
code after the signal: when the signal came during a long compiled call, that is inside the
wrapper. The exception is then chained under one ``SystemError`` per array, and the caller sees an
opaque ``SystemError`` instead of the interruption; a ``MemoryError`` while the arrays are
boxed ends the same way. :func:`original_errors` raises the exception that started the chain.
"""

from __future__ import annotations

from contextlib import AbstractContextManager


def original_error(exc: SystemError) -> BaseException | None:
    """The first exception of ``exc``'s chain of causes that is not a ``SystemError`` (None: there is none).

    Only causes (``raise ... from``, which is how CPython chains a result returned with an exception
    set) are followed, not the exception being handled when ``exc`` was raised.
    """
    seen: set[int] = set()
    cause: BaseException | None = exc
    while isinstance(cause, SystemError) and id(cause) not in seen:
        seen.add(id(cause))
        cause = cause.__cause__
    return None if isinstance(cause, SystemError) else cause


class _OriginalErrors:
    """The context manager :func:`original_errors` returns: one stateless object, no generator, because it
    wraps the per-step compiled calls (a conflict check, a kernel batch; some 35,000 per corridor episode)
    and ``contextlib.contextmanager`` cost a generator and two frames each time."""

    __slots__ = ()

    def __enter__(self) -> None:
        return None

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        if exc_type is not None and issubclass(exc_type, SystemError) and isinstance(exc, SystemError):
            cause = original_error(exc)
            if cause is not None:
                raise cause.with_traceback(cause.__traceback__) from None
        # Returning None (falsy): anything else propagates as it is.


_ORIGINAL_ERRORS = _OriginalErrors()


def original_errors() -> AbstractContextManager[None]:
    """Around a compiled call: a ``SystemError`` chained onto another exception raises that exception."""
    return _ORIGINAL_ERRORS
