"""Synthetic trip demand between vertiports: a taxi-trip-like gravity model.

The expected number of trip requests from vertiport *i* to *j* during hour
*h* of the day is::

    lambda_ij(h) = D * p(h) / sum(p) * g_ij(h) / sum_kl g_kl(h)
    g_ij(h)      = w_i * w_j * exp(-d_ij / d0) * b_ij(h)     for d_ij >= d_min, else 0

with D the daily number of requests, p(h) the hourly profile (NYC for-hire
trips: a night trough at 04-05, a morning peak at 08-09 and an evening peak
at 18-19), w the vertiports' demand weights, d_ij their great-circle
distance, d0 the distance scale and b_ij(h) the commuter bias: trips into a
central business district (``cbd`` vertiports) from outside are multiplied
by ``1 + peak_bias`` in the morning peak hours, and trips out of it in the
evening peak hours. Requests are a Poisson process with these rates,
piecewise constant per hour; their times are uniform within the hour.
Trips shorter than d_min are left to ground transport. See
``docs/nyc-network.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uamtoolkit_import.network import Network

# Relative for-hire trip volume by hour of day, 00-01 ... 23-24 (stylised NYC shape).
HOURLY_PROFILE: tuple[float, ...] = (
    0.55,
    0.40,
    0.30,
    0.22,
    0.18,
    0.22,
    0.45,
    0.85,
    1.10,
    1.05,
    0.92,
    0.92,
    0.95,
    0.95,
    1.00,
    0.98,
    0.95,
    1.05,
    1.15,
    1.15,
    1.05,
    1.00,
    0.95,
    0.80,
)

# Passengers per request: P(1), P(2), P(3), P(4).
PASSENGER_PROBS: tuple[float, ...] = (0.70, 0.17, 0.06, 0.07)


@dataclass(frozen=True)
class DemandModel:
    """Parameters of the gravity model (see the module docstring).

    Attributes:
        daily_requests: expected trip requests per day (all pairs).
        distance_scale_km: d0 [km].
        min_distance_km: d_min [km].
        peak_bias: commuter bias toward (morning) and away from (evening) CBD vertiports.
        morning_hours, evening_hours: [first, last) hour of each peak.
        profile: 24 relative hourly volumes.
        baggage_kg_per_pax: upper bound of the uniform baggage mass per passenger [kg].
    """

    daily_requests: float = 6000.0
    distance_scale_km: float = 20.0
    min_distance_km: float = 5.0
    peak_bias: float = 1.0
    morning_hours: tuple[int, int] = (7, 10)
    evening_hours: tuple[int, int] = (16, 20)
    profile: tuple[float, ...] = HOURLY_PROFILE
    baggage_kg_per_pax: float = 20.0

    def __post_init__(self) -> None:
        if len(self.profile) != 24 or min(self.profile) < 0 or sum(self.profile) <= 0:
            raise ValueError("the hourly profile needs 24 non-negative values, not all zero")
        if self.daily_requests < 0 or self.distance_scale_km <= 0 or self.min_distance_km < 0:
            raise ValueError("daily_requests and min_distance_km must be >= 0, distance_scale_km > 0")


@dataclass(frozen=True)
class TripRequest:
    """A request to fly ``passengers`` from ``origin`` to ``destination``, made at ``t_s`` [s since midnight]."""

    t_s: float
    origin: str
    destination: str
    passengers: int
    cargo_kg: float


def distance_matrix_km(network: Network) -> np.ndarray:
    """Great-circle distances between vertiports [km] (network order)."""
    ids = list(network.vertiports)
    n = len(ids)
    d = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            d[i, j] = d[j, i] = network.leg_length_m(ids[i], ids[j]) / 1000.0
    return d


def hourly_rates(network: Network, model: DemandModel) -> np.ndarray:
    """Expected requests per OD pair and hour, shape (24, n, n); the diagonal is 0."""
    vps = list(network.vertiports.values())
    w = np.array([v.demand_weight for v in vps])
    cbd = np.array([v.cbd for v in vps])
    d = distance_matrix_km(network)
    base = np.outer(w, w) * np.exp(-d / model.distance_scale_km)
    base[d < model.min_distance_km] = 0.0
    np.fill_diagonal(base, 0.0)
    inbound = np.outer(~cbd, cbd)  # from outside into a CBD
    outbound = np.outer(cbd, ~cbd)
    profile = np.asarray(model.profile, dtype=float)
    share = profile / profile.sum()
    rates = np.empty((24, len(vps), len(vps)))
    for h in range(24):
        g = base.copy()
        if model.morning_hours[0] <= h < model.morning_hours[1]:
            g[inbound] *= 1.0 + model.peak_bias
        if model.evening_hours[0] <= h < model.evening_hours[1]:
            g[outbound] *= 1.0 + model.peak_bias
        total = g.sum()
        rates[h] = g * (model.daily_requests * share[h] / total) if total > 0 else 0.0
    return rates


def generate_requests(network: Network, model: DemandModel, rng: np.random.Generator) -> list[TripRequest]:
    """Draw a day of trip requests, sorted by time (deterministic for a seeded ``rng``)."""
    ids = list(network.vertiports)
    rates = hourly_rates(network, model)
    counts = rng.poisson(rates)
    requests: list[TripRequest] = []
    probs = np.asarray(PASSENGER_PROBS)
    for h, i, j in zip(*np.nonzero(counts)):
        k = int(counts[h, i, j])
        times = 3600.0 * h + rng.uniform(0.0, 3600.0, size=k)
        pax = rng.choice(len(probs), size=k, p=probs) + 1
        cargo = rng.uniform(0.0, model.baggage_kg_per_pax, size=k) * pax
        for t, p, c in zip(times, pax, cargo):
            requests.append(TripRequest(float(t), ids[i], ids[j], int(p), float(round(c, 1))))
    requests.sort(key=lambda r: (r.t_s, r.origin, r.destination))
    return requests
