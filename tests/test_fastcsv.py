"""The compiled CSV writer is exact for every float it may receive (issue 19: large values were garbage)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim.output.fastcsv import format_rows, pack_names


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
