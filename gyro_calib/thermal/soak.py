"""Soak plateaus: where the cavity temperature has settled at a chamber set point.

The fixed-point calibration style (METHODS §D.2) measures the bias once the gyro has
settled at each set point. A plateau is a run of intervals with |Ḣ| at most
``max_rate_c_per_min`` lasting at least ``min_s``; its settled part is its last
(1 − ``settle_fraction``), where the self-heating and soak transients have died out.
Ḣ here is the least-squares slope of H over ``min_s``/2 (much longer than the model's Ḣ
window), so sensor noise and rounding do not break a plateau into pieces.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.thermal.intervals import causal_slope

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class Plateau:
    """A soak plateau, as interval indices into the table.

    Attributes:
        start: first interval of the plateau.
        settled: first interval of its settled part.
        end: one past its last interval.
    """

    start: int
    settled: int
    end: int


def find_plateaus(h_c: npt.NDArray[np.float64], *, interval_s: float,
                  max_rate_c_per_min: float, min_s: float,
                  settle_fraction: float) -> list[Plateau]:
    """Runs of |Ḣ| ≤ max_rate at least ``min_s`` long (NaN breaks a run); H per interval."""
    window = max(2, int(round(0.5 * min_s / interval_s)))
    r = causal_slope(np.asarray(h_c, np.float64), window, interval_s) * 60.0
    calm = np.isfinite(r) & (np.abs(r) <= max_rate_c_per_min)
    d = np.diff(np.concatenate(([0], calm.astype(np.int8), [0])))
    starts = np.nonzero(d == 1)[0]
    ends = np.nonzero(d == -1)[0]
    min_n = max(2, int(round(min_s / interval_s)))
    out = []
    for a, b in zip(starts.tolist(), ends.tolist()):
        if b - a >= min_n:
            out.append(Plateau(a, a + int(round(settle_fraction * (b - a))), b))
    return out
