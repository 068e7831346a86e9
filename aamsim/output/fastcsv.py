"""Fixed-point CSV formatting compiled with Numba.

Trajectory logs of a simulated day run to millions of rows; formatting them
with Python or numpy string routines would take longer than simulating.
Each numeric column is written with a fixed number of decimals (stated in the
column docs), rounding half away from zero; NaN is written as an empty field,
infinities as ``inf`` / ``-inf``.

The compiled writer works in 64-bit integers, exact while ``|value| * 10**decimals``
stays below 2**53. Rows holding a larger or infinite value (an aircraft flown to
longitude 2.34e16 was written as ``.5224192``) are written by Python's exact
decimal formatting instead, in their place.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from aamsim.numba_cache import njit


@njit(cache=True, inline="always")
def _write_scaled(out: np.ndarray, pos: int, scaled: int | np.int64, decimals: int) -> int:
    """The digits of ``scaled / 10**decimals`` (``scaled >= 0``) at ``out[pos:]``; returns the end."""
    intpart = scaled
    for _ in range(decimals):
        intpart //= 10
    if intpart == 0:
        out[pos] = 48
        pos += 1
    else:
        ndig = 0
        tmp = intpart
        while tmp > 0:
            tmp //= 10
            ndig += 1
        tmp = intpart
        for k in range(ndig - 1, -1, -1):
            out[pos + k] = 48 + tmp % 10
            tmp //= 10
        pos += ndig
    if decimals > 0:
        out[pos] = 46  # '.'
        pos += 1
        frac = scaled
        for k in range(decimals - 1, -1, -1):
            out[pos + k] = 48 + frac % 10
            frac //= 10
        pos += decimals
    return pos


@njit(cache=True)
def _write_number(out: np.ndarray, pos: int, value: float, decimals: int, scale: float) -> int:
    if value != value:  # NaN -> empty field
        return pos
    if value < 0.0:
        q = -value * scale + 0.5
        neg = True
    else:
        q = value * scale + 0.5
        neg = False
    iv = np.int64(q)
    if neg and iv != 0:
        out[pos] = 45  # '-'
        pos += 1
    return _write_scaled(out, pos, iv, decimals)


# Largest |value * 10**decimals| the integer writer renders exactly.
FAST_LIMIT = float(2**53)


@njit(cache=True, nogil=True)  # without the GIL: the trajectory recorder formats in a thread while the run goes on
def _format_rows_fast(
    name_bytes: np.ndarray,
    name_offsets: np.ndarray,
    name_index: np.ndarray,
    columns: np.ndarray,
    decimals: np.ndarray,
) -> np.ndarray:
    """The compiled writer behind :func:`format_rows`, exact while ``|value| * 10**decimals < 2**53``."""
    ncol, nrow = columns.shape
    scales = np.empty(ncol)
    for c in range(ncol):
        scales[c] = 10.0 ** decimals[c]
    # Upper bound: name + per column (sign, 20 digits, dot, decimals, comma) + newline
    maxname = 0
    for k in range(name_offsets.shape[0] - 1):
        maxname = max(maxname, name_offsets[k + 1] - name_offsets[k])
    width = maxname + 1
    for c in range(ncol):
        width += 24 + decimals[c]
    out = np.empty(nrow * width, dtype=np.uint8)
    pos = 0
    for r in range(nrow):
        k = name_index[r]
        for b in range(name_offsets[k], name_offsets[k + 1]):
            out[pos] = name_bytes[b]
            pos += 1
        for c in range(ncol):
            out[pos] = 44  # ','
            pos += 1
            pos = _write_number(out, pos, columns[c, r], decimals[c], scales[c])
        out[pos] = 10
        pos += 1
    return out[:pos]


def pack_names(names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate names into (bytes, offsets) for :func:`format_rows`."""
    encoded = [n.encode("utf-8") for n in names]
    offsets = np.zeros(len(encoded) + 1, dtype=np.int64)
    np.cumsum([len(e) for e in encoded], out=offsets[1:])
    data = np.frombuffer(b"".join(encoded), dtype=np.uint8) if encoded else np.zeros(0, dtype=np.uint8)
    return data, offsets


def _format_cell(value: float, decimals: int) -> str:
    if math.isnan(value):
        return ""
    if value in (np.inf, -np.inf):
        return "inf" if value > 0 else "-inf"
    text = f"{value:.{decimals}f}"
    return "0" + text[1:] if text.startswith("-") and not text.strip("-0.") else text  # no "-0.000"


def format_rows(
    name_bytes: np.ndarray,
    name_offsets: np.ndarray,
    name_index: np.ndarray,
    columns: np.ndarray,
    decimals: np.ndarray,
) -> np.ndarray:
    """Rows ``name,col0,col1,...\\n`` as UTF-8 bytes, exact for every float (see the module doc).

    Args:
        name_bytes, name_offsets: the concatenated names; name k is
            ``name_bytes[name_offsets[k]:name_offsets[k+1]]``.
        name_index: per row, which name.
        columns: float array (ncol, nrow).
        decimals: decimals per column.
    """
    scales = 10.0 ** decimals.astype(np.float64)
    if not columns.size:
        return _format_rows_fast(name_bytes, name_offsets, name_index, columns, decimals)
    with np.errstate(invalid="ignore", over="ignore"):
        # One pass for the usual case, no wide value at all (fmax skips NaN, written fast as empty).
        if not (np.fmax.reduce(np.abs(columns), axis=1) * scales >= FAST_LIMIT).any():
            return _format_rows_fast(name_bytes, name_offsets, name_index, columns, decimals)
        wide = np.abs(columns) * scales[:, None] >= FAST_LIMIT  # NaN compares False: written fast
    slow_rows = np.flatnonzero(wide.any(axis=0))
    if slow_rows.size == 0:
        return _format_rows_fast(name_bytes, name_offsets, name_index, columns, decimals)
    parts: list[bytes] = []
    start = 0
    for r in slow_rows.tolist():
        if r > start:
            parts.append(_format_rows_fast(name_bytes, name_offsets, name_index[start:r],
                                           np.ascontiguousarray(columns[:, start:r]), decimals).tobytes())
        k = int(name_index[r])
        name = bytes(name_bytes[name_offsets[k]:name_offsets[k + 1]]).decode("utf-8")
        cells = [_format_cell(float(columns[c, r]), int(decimals[c])) for c in range(columns.shape[0])]
        parts.append((",".join([name, *cells]) + "\n").encode("utf-8"))
        start = r + 1
    if start < columns.shape[1]:
        parts.append(_format_rows_fast(name_bytes, name_offsets, name_index[start:],
                                       np.ascontiguousarray(columns[:, start:]), decimals).tobytes())
    return np.frombuffer(b"".join(parts), dtype=np.uint8)


# ------------------------------------------------------------------ Python's own fixed-point text
# Largest |value * 10**decimals| the exact writer below handles: under 2**52 the product's rounding
# error is at most a quarter, so the rounded integer is one of two neighbours, told apart exactly.
EXACT_LIMIT = float(2**52)
_SPLITTER = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two 26-bit halves


@njit(cache=True, inline="always")
def _two_product(a: float, b: float) -> tuple[float, float]:
    """``(p, e)`` with ``p = fl(a * b)`` and ``a * b == p + e`` exactly (Dekker; no FMA needed)."""
    p = a * b
    c = _SPLITTER * a
    a_hi = c - (c - a)
    a_lo = a - a_hi
    c = _SPLITTER * b
    b_hi = c - (c - b)
    b_lo = b - b_hi
    e = ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return p, e


@njit(cache=True)
def _write_python_fixed(out: np.ndarray, pos: int, value: float, decimals: int, scale: float) -> int:
    """``format(value, f".{decimals}f")`` for a finite value with ``|value| * scale < 2**52``: the exact
    binary value rounded half to even, a minus sign whenever the sign bit is set (``-0.00``)."""
    negative = value < 0.0 or (value == 0.0 and math.copysign(1.0, value) < 0.0)
    a = -value if negative else value
    if a < 1e-200:  # the product's error term would underflow; far below half a unit of any decimal
        n = np.int64(0)
    else:
        p, e = _two_product(a, scale)
        whole = math.floor(p)
        r = (p - whole - 0.5) + e  # exact sign: p - whole is exact, and so is its difference from 0.5
        n = np.int64(whole)
        if r > 0.0 or (r == 0.0 and n % 2 == 1):
            n += 1
    if negative:
        out[pos] = 45  # '-'
        pos += 1
    return _write_scaled(out, pos, n, decimals)


@njit(cache=True, inline="always")
def _write_text(out: np.ndarray, pos: int, text_bytes: np.ndarray, text_offsets: np.ndarray, t: int) -> int:
    for b in range(text_offsets[t], text_offsets[t + 1]):
        out[pos] = text_bytes[b]
        pos += 1
    return pos


@njit(cache=True)
def _format_table(text_bytes: np.ndarray, text_offsets: np.ndarray, lead: np.ndarray, columns: np.ndarray,
                  decimals: np.ndarray, trail: np.ndarray) -> np.ndarray:
    """Rows ``lead texts, numbers, trail texts`` joined by commas, each ended by ``\\r\\n`` (at least one field
    a row)."""
    nrow = columns.shape[1]
    ncol = columns.shape[0]
    scales = np.empty(ncol)
    width = 2
    for c in range(ncol):
        scales[c] = 10.0 ** decimals[c]
        width += 26 + decimals[c]
    longest = 0
    for k in range(text_offsets.shape[0] - 1):
        longest = max(longest, text_offsets[k + 1] - text_offsets[k])
    width += (lead.shape[1] + trail.shape[1]) * (longest + 1)
    out = np.empty(nrow * width, dtype=np.uint8)
    pos = 0
    for r in range(nrow):
        # Every field is followed by a comma; the row's last comma becomes its line end.
        for k in range(lead.shape[1]):
            pos = _write_text(out, pos, text_bytes, text_offsets, lead[r, k])
            out[pos] = 44
            pos += 1
        for c in range(ncol):
            x = columns[c, r]
            if math.isfinite(x):  # not finite: an empty field
                pos = _write_python_fixed(out, pos, x, decimals[c], scales[c])
            out[pos] = 44
            pos += 1
        for k in range(trail.shape[1]):
            pos = _write_text(out, pos, text_bytes, text_offsets, trail[r, k])
            out[pos] = 44
            pos += 1
        out[pos - 1] = 13
        out[pos] = 10
        pos += 1
    return out[:pos]


def _plain_csv_field(text: str) -> bool:
    """Whether :mod:`csv`'s default writer puts ``text`` as it is (no quotes, nothing escaped)."""
    return not any(ch in text for ch in ',"\r\n')


def format_csv_table(lead: Sequence[Sequence[str]], columns: np.ndarray, decimals: Sequence[int],
                     trail: Sequence[Sequence[str]]) -> bytes | None:
    """The bytes ``csv.writer`` writes for rows ``(*lead[r], *numbers, *trail[r])``, each number as
    ``format(x, f".{d}f")`` (empty when not finite): rows ended by ``\\r\\n``, UTF-8.

    ``columns``: float array (numbers per row, rows). None when a text needs quoting or a number is too
    wide for the compiled writer (:data:`EXACT_LIMIT`): the caller writes with :mod:`csv` then.
    """
    columns = np.ascontiguousarray(columns, dtype=np.float64)
    nrow = columns.shape[1]
    texts: dict[str, int] = {}

    def numbered(rows: Sequence[Sequence[str]]) -> np.ndarray:
        return np.array([[texts.setdefault(t, len(texts)) for t in row] for row in rows],
                        dtype=np.int64).reshape(nrow, -1)

    lead_index, trail_index = numbered(lead), numbered(trail)
    if not all(_plain_csv_field(t) for t in texts) or lead_index.shape[1] + len(decimals) + trail_index.shape[1] < 2:
        return None  # (the csv module quotes a row's only field when it is empty)
    scales = 10.0 ** np.asarray(decimals, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        if (np.abs(columns) * scales[:, None] >= EXACT_LIMIT).any():  # (inf too: it is written empty)
            finite = np.isfinite(columns)
            if (np.abs(np.where(finite, columns, 0.0)) * scales[:, None] >= EXACT_LIMIT).any():
                return None
    text_bytes, text_offsets = pack_names(list(texts))
    return _format_table(text_bytes, text_offsets, lead_index, columns, np.asarray(decimals, dtype=np.int64),
                         trail_index).tobytes()
