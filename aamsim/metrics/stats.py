"""Confidence intervals that fit their sample size: Student's t, exact for any number of samples.

A study has a handful of training seeds: with 2 seeds the 95 % interval of a mean is
``12.71 * s / sqrt(2)``, not ``1.96 * s / sqrt(2)`` (a normal quantile would draw it 6.5 times too
narrow). The t quantile comes from the closed forms of Student's distribution for integer degrees of
freedom (Abramowitz & Stegun 26.7.3 and 26.7.4), inverted by bisection: no SciPy needed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache


def _central_probability(t: float, dof: int) -> float:
    """P(|T| < t) for Student's T with ``dof`` degrees of freedom (A&S 26.7.3 odd, 26.7.4 even)."""
    theta = math.atan(t / math.sqrt(dof))
    s, c = math.sin(theta), math.cos(theta)
    if dof % 2 == 1:
        if dof == 1:
            return 2.0 * theta / math.pi
        term, total = c, c
        for k in range(3, dof - 1, 2):  # c + (2/3) c^3 + (2*4)/(3*5) c^5 + ... up to c^(dof-2)
            term *= c * c * (k - 1) / k
            total += term
        return 2.0 / math.pi * (theta + s * total)
    term, total = 1.0, 1.0
    for k in range(2, dof - 1, 2):  # 1 + (1/2) c^2 + (1*3)/(2*4) c^4 + ... up to c^(dof-2)
        term *= c * c * (k - 1) / k
        total += term
    return s * total


@lru_cache(maxsize=256)
def t_critical(dof: int, confidence: float = 0.95) -> float:
    """The two-sided Student's t quantile: ``P(|T| < t) = confidence`` with ``dof`` degrees of freedom."""
    if dof < 1:
        raise ValueError(f"a t interval needs at least 1 degree of freedom (2 samples), not {dof}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), not {confidence}")
    lo, hi = 0.0, 1.0
    while _central_probability(hi, dof) < confidence:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _central_probability(mid, dof) < confidence:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12 * hi:
            break
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class MeanInterval:
    """A sample's mean with the half-width of its t interval (``None`` with one sample: no interval)."""

    n: int
    mean: float
    std: float  # sample standard deviation (ddof=1); 0.0 with one sample
    half_width: float | None

    @property
    def low(self) -> float | None:
        return None if self.half_width is None else self.mean - self.half_width

    @property
    def high(self) -> float | None:
        return None if self.half_width is None else self.mean + self.half_width


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> MeanInterval | None:
    """Mean and Student's t interval of the mean of ``values`` (NaN and None dropped); None when empty."""
    xs = [float(v) for v in values if v is not None and not math.isnan(float(v))]
    n = len(xs)
    if n == 0:
        return None
    mean = sum(xs) / n
    if n == 1:
        return MeanInterval(1, mean, 0.0, None)
    std = math.sqrt(sum((x - mean) ** 2 for x in xs) / (n - 1))
    return MeanInterval(n, mean, std, t_critical(n - 1, confidence) * std / math.sqrt(n))
