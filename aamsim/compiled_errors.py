"""The real exception behind Numba's ``SystemError: CPUDispatcher(...) returned a result with an exception set``.

A compiled function that returns arrays builds their Python objects in its wrapper, and that
wrapper calls back into Python (Numba's ``_numba_unpickle``) for each array without checking
for an error in between. A Python signal handler that raises (``KeyboardInterrupt`` on Ctrl-C
outside ``aamsim run``, an alarm that ends a case in a test harness) runs at the first Python
code after the signal: when the signal came during a long compiled call, that is inside the
wrapper. The exception is then chained under one ``SystemError`` per array, and the caller sees an
opaque ``SystemError`` instead of the interruption; a ``MemoryError`` while the arrays are
boxed ends the same way. :func:`raise_original` raises the exception that started the chain.
"""

from __future__ import annotations

from typing import NoReturn


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


def raise_original(exc: SystemError) -> NoReturn:
    """Raise the exception behind ``exc`` (:func:`original_error`), or ``exc`` itself when there is none.

    Used as ``except SystemError as exc: raise_original(exc)`` around a compiled call: the call sites are
    per-step (a conflict check), and a ``try`` costs nothing until something is raised, where a context
    manager costs two calls each time.
    """
    cause = original_error(exc)
    if cause is not None:
        raise cause.with_traceback(cause.__traceback__) from None
    raise exc
