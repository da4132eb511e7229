"""Seed 001's Table 1 and the fit of the simulator's front end to its shape (METHODS §B).

The paper injects a ladder of equal steps and fits N_i = K·ω_i + N₀ over the first n
plateaus: K over 55, 45, 35, 25, 15, 10 and 6 plateaus is 1021.57, 933.07, 885.69,
856.62, 838.60, 832.25 and 829.10 against a turntable value of 823.19 (|K|; the paper's
turntable K is −823.186333, its sense axis pointing the other way). Larger ranges give
larger K because the injection holds the loop at a real optical phase error, where the
fringe's sine and the pre-amplifier's compression bend the response
(:mod:`sim_nodes.fog.front_end`). No smooth response with unit slope at zero gives both
+24 % at 55 plateaus and +0.7 % at 6 while leaving a linear range, so the small-range
excess is modelled as a mapping error: the injection's small-signal gain differs from
the 1 the paper's equivalence mapping assumes (``injection_gain_error``).

:func:`fit_front_end_to_table1` fits three physical parameters — the pre-amplifier gain
G (with the rail and detector amplitude fixed), the ladder step and that mapping error —
to the seven ratios K(n)/K_lab with the simulator's own static balance. The defaults in
:class:`~sim_nodes.fog.config.FogConfig` and :data:`PAPER_PLATEAU_STEP_DEG_S` are its
result; ``python benchmarks/fog_paper_table1.py`` re-runs it and prints the residuals.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import least_squares

from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.front_end import FrontEnd

if TYPE_CHECKING:
    import numpy.typing as npt

PAPER_TABLE1: tuple[tuple[int, float], ...] = (
    (55, 1021.565972), (45, 933.074765), (35, 885.694428), (25, 856.618706),
    (15, 838.598396), (10, 832.254999), (6, 829.095731))
"""(plateaus used, self-calibrated K) of seed 001 Table 1 (x axis)."""
PAPER_LAB_K = 823.186333
"""|K| of the same gyro from the laboratory turntable calibration (seed 001 Fig. 2)."""
PAPER_PLATEAU_COUNT = 55
"""Plateaus in the paper's ladder (zero injection counted as the first)."""
PAPER_PLATEAU_STEP_DEG_S = 0.67948
"""Ladder step, in °/s of equivalent rate, fitted to Table 1 for the default coil."""


def static_ladder_outputs(config: FogConfig, step_counts_s: float, n_plateaus: int,
                          *, sagnac_phase_rad: float = 0.0) -> npt.NDArray[np.float64]:
    """Noise-free balanced output rate on each plateau J_i = i·step, i = 0..n−1, counts/s."""
    fe = FrontEnd(config)
    j = np.arange(n_plateaus) * step_counts_s
    a, _ = fe.balance(sagnac_phase_rad, fe.injection_word(j))
    return fe.output_rate_counts_s(sagnac_phase_rad, a)


def ladder_k_ratios(config: FogConfig, step_counts_s: float,
                    counts: tuple[int, ...]) -> npt.NDArray[np.float64]:
    """K over the first n plateaus divided by the true K, for each n in ``counts``.

    With ω_i = J_i / K (a perfect equivalence mapping) the LS slope of N_i against ω_i
    divided by K is the LS slope of N_i against J_i.
    """
    y = static_ladder_outputs(config, step_counts_s, max(counts))
    j = np.arange(max(counts)) * step_counts_s
    out = []
    for n in counts:
        slope = np.polyfit(j[:n], y[:n], 1)[0] if np.all(np.isfinite(y[:n])) else math.nan
        out.append(slope)
    return np.asarray(out)


@dataclass(frozen=True, slots=True)
class Table1Fit:
    """Result of fitting the front end to Table 1.

    Attributes:
        config: the input configuration with the fitted preamp_gain and injection_gain_error.
        plateau_step_deg_s: fitted ladder step, °/s of equivalent rate.
        counts: plateau counts of Table 1.
        paper_ratio: K(n)/K_lab from the paper.
        model_ratio: K(n)/K from the fitted simulator.
        residual_percent: (model − paper)/paper, %.
    """

    config: FogConfig
    plateau_step_deg_s: float
    counts: tuple[int, ...]
    paper_ratio: npt.NDArray[np.float64]
    model_ratio: npt.NDArray[np.float64]
    residual_percent: npt.NDArray[np.float64]


def fit_front_end_to_table1(config: FogConfig | None = None) -> Table1Fit:
    """Fit preamp_gain, the ladder step and injection_gain_error to Table 1's shape."""
    base = config or FogConfig()
    counts = tuple(n for n, _ in PAPER_TABLE1)
    paper = np.array([k for _, k in PAPER_TABLE1]) / PAPER_LAB_K
    k_counts = base.scale_factor_counts_per_rad

    def model(q: npt.NDArray[np.float64]) -> tuple[FogConfig, npt.NDArray[np.float64]]:
        cfg = dataclasses.replace(base, preamp_gain=float(q[0]),
                                  injection_gain_error=float(q[2]))
        step = math.radians(float(q[1])) * k_counts
        return cfg, ladder_k_ratios(cfg, step, counts)

    def residual(q: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        ratio = model(q)[1]
        return np.where(np.isfinite(ratio), ratio / paper - 1.0, 1.0)

    start = np.array([base.preamp_gain, PAPER_PLATEAU_STEP_DEG_S, base.injection_gain_error])
    fit = least_squares(residual, start, x_scale=np.array([1.0, 0.01, 0.001]),
                        bounds=([1.0, 0.05, -0.05], [200.0, 5.0, 0.05]))
    cfg, ratio = model(fit.x)
    return Table1Fit(cfg, float(fit.x[1]), counts, paper, ratio, (ratio / paper - 1.0) * 100)
