"""The compiled CSV writer is exact for every float it may receive (issue 19: large values were garbage)."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim.output.fastcsv import format_csv_table, format_rows, pack_names


def write(values: list[float], decimals: list[int], names: list[str] | None = None) -> list[list[str]]:
    """One column per decimals entry, one row per value (every column gets the row's value)."""
    names = names or ["A1"]
    data, offsets = pack_names(names)
    cols = np.array([values] * len(decimals), dtype=np.float64)
    index = np.arange(len(values), dtype=np.int64) % len(names)
    text = format_rows(data, offsets, index, cols, np.array(decimals, dtype=np.int64)).tobytes().decode()
    return [line.split(",") for line in text.splitlines()]


def test_values_beyond_the_integer_range_are_written_exactly() -> None:
    rows = write([2.34e16, 5e299, -1.5e20, 181.42], [7, 4])
    assert [r[1:] for r in rows] == [["23400000000000000.0000000", "23400000000000000.0000"],
                                     [f"{5e299:.7f}", f"{5e299:.4f}"],
                                     ["-150000000000000000000.0000000", "-150000000000000000000.0000"],
                                     ["181.4200000", "181.4200"]]
    assert float(rows[1][1]) == 5e299


def test_nan_is_empty_and_infinities_are_named() -> None:
    rows = write([math.nan, math.inf, -math.inf, 1.0], [2])
    assert [r[1] for r in rows] == ["", "inf", "-inf", "1.00"]


def test_rows_keep_their_order_and_names_around_slow_rows() -> None:
    rows = write([1.0, 1e300, 2.0, 3.0, math.inf, 4.0], [1], names=["A", "BB", "CCC"])
    assert [r[0] for r in rows] == ["A", "BB", "CCC", "A", "BB", "CCC"]
    assert [r[1] for r in rows] == ["1.0", f"{1e300:.1f}", "2.0", "3.0", "inf", "4.0"]


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf)), min_size=1,
                max_size=20), st.lists(st.integers(0, 7), min_size=1, max_size=4))
def test_every_float_round_trips_within_half_a_unit_of_the_last_decimal(values: list[float],
                                                                        decimals: list[int]) -> None:
    rows = write(values, decimals)
    assert len(rows) == len(values)
    for value, row in zip(values, rows):
        for d, text in zip(decimals, row[1:]):
            if math.isnan(value):
                assert text == ""
                continue
            back = float(text)
            if math.isinf(value):
                assert back == value
                continue
            assert len(text.partition(".")[2]) == d
            assert abs(back - value) <= 0.5 * 10.0**-d * (1 + 1e-9) + abs(value) * 2.0**-52, (value, d, text)


# ------------------------------------------------------------- format_csv_table: Python's own text
def csv_module_bytes(lead: list[list[str]], columns: np.ndarray, decimals: list[int],
                     trail: list[list[str]]) -> bytes:
    """What the csv module writes for these rows, numbers by ``format(x, ".Nf")`` (empty when not finite)."""
    buf = io.StringIO(newline="")
    writer = csv.writer(buf)
    for r in range(columns.shape[1]):
        cells = [format(float(columns[c, r]), f".{d}f") if math.isfinite(columns[c, r]) else ""
                 for c, d in enumerate(decimals)]
        writer.writerow([*lead[r], *cells, *trail[r]])
    return buf.getvalue().encode()


def table(values: list[float], decimals: list[int]) -> tuple[bytes | None, bytes]:
    """Each value in a row of its own, once per decimals entry; the compiled bytes and the csv module's."""
    columns = np.array([values] * len(decimals), dtype=np.float64).reshape(len(decimals), len(values))
    lead = [["lowc", f"UAM{k}", "UAM9"] for k in range(len(values))]
    trail = [["crossing", "AAM vs AAM"] for _ in values]
    return format_csv_table(lead, columns, decimals, trail), csv_module_bytes(lead, columns, decimals, trail)


def test_ties_round_half_to_even_on_the_exact_binary_value_and_negative_zero_keeps_its_sign() -> None:
    # 0.125 and 0.375 are exact binary ties (to even: 0.12, 0.38); 2.675 is just below its tie (2.67);
    # 1.005 just below (1.00); -0.001 rounds to a negative zero, written "-0.00" as Python does.
    values = [0.125, 0.375, 2.675, 1.005, -0.001, -0.0, 0.0, 2.5, 3.5, -2.5, 1e-300, 99.995, 40.7128,
              -74.006, math.nan, math.inf]
    compiled, expected = table(values, [2, 0, 7, 1])
    assert compiled == expected
    first = expected.decode().splitlines()[:6]
    assert [line.split(",")[3:5] for line in first] == [["0.12", "0"], ["0.38", "0"], ["2.67", "3"],
                                                         ["1.00", "1"], ["-0.00", "-0"], ["-0.00", "-0"]]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64).filter(
    lambda x: not math.isfinite(x) or abs(x) < 4e8), min_size=1, max_size=40),
    st.lists(st.integers(min_value=0, max_value=7), min_size=1, max_size=4))
def test_every_float_is_written_as_python_formats_it(values: list[float], decimals: list[int]) -> None:
    compiled, expected = table(values, decimals)
    assert compiled == expected


@settings(max_examples=200, deadline=None)
@given(st.integers(min_value=-10**9, max_value=10**9), st.integers(min_value=1, max_value=7))
def test_decimal_ties_and_their_neighbours(units: int, decimals: int) -> None:
    """Values at and next to a half unit of the last decimal, where a rounding error would show."""
    tie = (units + 0.5) / 10**decimals
    values = [tie, math.nextafter(tie, math.inf), math.nextafter(tie, -math.inf)]
    compiled, expected = table(values, [decimals])
    assert compiled == expected


def test_texts_that_need_quotes_or_numbers_too_wide_are_left_to_the_csv_module() -> None:
    columns = np.array([[1.5]])
    assert format_csv_table([["lowc", "A,1"]], columns, [2], [[]]) is None
    assert format_csv_table([['say "hi"']], columns, [2], [[]]) is None
    assert format_csv_table([["lowc"]], np.array([[1e12]]), [7], [[]]) is None  # 1e19 > 2**52
    assert format_csv_table([["lowc"]], np.array([[1e12]]), [2], [[]]) == b"lowc,1000000000000.00\r\n"
    assert format_csv_table([[]], np.array([[math.nan]]), [2], [[]]) is None  # csv writes '""' for that row
