"""The quantisation floor of a window's count (METHODS §F.2 eq. (6a)).

A local fit of integer counts averages their ±½-pulse errors down only when the count's
fractional part runs through its cycle within the fit span: :func:`quantisation_floor` is the
least standard uncertainty that leaves, :func:`end_floor` that of a window's two ends.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.settings import TriadSettings

    Array = npt.NDArray[np.float64]


def quantisation_floor(rate_pulses_s: float, period_s: float, samples: int) -> float:
    """Least standard uncertainty of a fitted count at an instant under quantisation, pulses.

    A local fit of integer counts averages their ±½-pulse errors down only when the count's
    fractional part runs through its cycle within the fit span. With δ pulses per sample near
    p/q (q small) the pattern of fractional parts repeats every q samples and drifts by
    d_q = |q·δ − round(q·δ)| per q samples: amplitude 1/q, L·d_q/q cycles over L samples,

        u_q = 1/(√12·q) / max(1, L·d_q/q),   floor = max over q = 1…4 of u_q

    (near-integer δ: up to 1/√12 pulse however long the fit; METHODS §F.5 "Limits").
    """
    delta = abs(rate_pulses_s) * period_s
    worst = 0.0
    for q in range(1, 5):
        d_q = abs(q * delta - round(q * delta))
        worst = max(worst, 1.0 / (math.sqrt(12.0) * q) / max(1.0, samples * d_q / q))
    return worst


def end_floor(settings: TriadSettings, pulses: tuple[npt.NDArray[np.int64], Array], c: int,
              start_ns: int, end_ns: int) -> float:
    """The quantisation floor of a window's count: both ends, at their local count rates."""
    t, counts = pulses
    half = int(settings.fit_half_width_s * NS_PER_S)
    var = 0.0
    for at in (start_ns, end_ns):
        lo = int(np.searchsorted(t, at - half, 'left'))
        hi = int(np.searchsorted(t, at + half, 'right')) - 1
        if hi - lo < 2:
            continue
        period = (t[hi] - t[lo]) / NS_PER_S / (hi - lo)
        rate = float(counts[hi, c] - counts[lo, c]) / (period * (hi - lo))
        var += quantisation_floor(rate, period, hi - lo + 1) ** 2
    return math.sqrt(var)
