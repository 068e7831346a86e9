"""The server process's heap: give freed memory back to the system (glibc only; elsewhere nothing).

A server that accepts messages of up to many megabytes from any client must
not keep the memory of every large message it has seen. glibc keeps freed
memory for reuse, and after a large free it raises its own thresholds, so a
freed 15 MB message stays resident until :func:`release_memory` gives it back.

That works only for memory of the main heap: ZeroMQ's I/O thread allocates
the buffer of every message it receives, in a heap (an *arena*) of its own,
and ``malloc_trim`` does not give back the free top of such a heap. One
freed 15 MB message stayed there at random (14.7 MB of the I/O thread's heap
resident after a burst, none after the next), so the server's resident size
after the same requests differed by 15 or 30 MB from run to run.
:func:`use_one_arena` makes every thread allocate from the main heap.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

M_ARENA_MAX = -8  # mallopt() parameter, from glibc's malloc.h


@functools.cache
def _glibc() -> ctypes.CDLL | None:
    """The C library if it is glibc (it has ``malloc_trim`` and ``mallopt(M_ARENA_MAX)``), else None."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None
    if not all(hasattr(libc, name) for name in ("gnu_get_libc_version", "malloc_trim", "mallopt")):
        return None  # musl, macOS: other allocators, nothing to do
    return libc


def release_memory() -> None:
    """Give the heap's free memory back to the operating system.

    glibc keeps freed memory for reuse, so the server's resident size only grew
    after large or malformed messages (195.6 -> 283.7 MB over 21,000 of them) and
    after sessions were freed. Called once the last reference to a large request
    is gone (before that, its buffers are not free yet) and after freed sessions.
    """
    libc = _glibc()
    if libc is not None:
        libc.malloc_trim(0)


def use_one_arena() -> bool:
    """Have threads started from now on allocate from the main heap (glibc's ``M_ARENA_MAX`` = 1).

    Call before the ZeroMQ context starts its I/O thread. The server answers
    requests in one thread; the others that allocate (ZeroMQ's I/O thread, the
    live viewer's) gain little from heaps of their own, which only spare them
    waiting for a lock that is seldom taken (glibc's per-thread caches serve
    small allocations without it), and what such a heap keeps cannot be given
    back by :func:`release_memory`.
    Same effect as ``MALLOC_ARENA_MAX=1`` in the environment. Returns whether
    the setting was made (False where the C library is not glibc).
    """
    libc = _glibc()
    return libc is not None and libc.mallopt(M_ARENA_MAX, 1) == 1
