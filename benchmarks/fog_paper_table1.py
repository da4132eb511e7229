"""Seed 001 Table 1 from the simulator: the front-end fit and its residuals.

Re-fits the pre-amplifier gain, the ladder step and the injection (mapping) gain error to
the shape K(n)/K_lab of the paper's Table 1 with the simulator's static balance
(sim_nodes.fog.paper), prints the fit beside the defaults in FogConfig, and the noise-free
K over every plateau count with its IEEE nonlinearity.

    python benchmarks/fog_paper_table1.py
"""

from __future__ import annotations

import math
import os

import numpy as np

from sim_nodes.fog import FogConfig
from sim_nodes.fog.paper import (
    PAPER_LAB_K,
    PAPER_PLATEAU_STEP_DEG_S,
    fit_front_end_to_table1,
    static_ladder_outputs,
)


def main() -> None:
    """Fit and print."""
    cfg = FogConfig()
    fit = fit_front_end_to_table1(cfg)
    print(f'Table 1 fit ({os.cpu_count()} cores): preamp_gain {fit.config.preamp_gain:.5f} '
          f'(default {cfg.preamp_gain}), ladder step {fit.plateau_step_deg_s:.5f} °/s (default '
          f'{PAPER_PLATEAU_STEP_DEG_S}), injection_gain_error '
          f'{fit.config.injection_gain_error:.7f} (default {cfg.injection_gain_error})')
    print('plateaus   paper K   K/K_lab   model K/K   residual')
    for n, p, m, r in zip(fit.counts, fit.paper_ratio, fit.model_ratio, fit.residual_percent):
        print(f'{n:8d}  {p * PAPER_LAB_K:9.3f}  {p:8.5f}  {m:10.5f}   {r:+.3f} %')
    step = math.radians(PAPER_PLATEAU_STEP_DEG_S) * cfg.scale_factor_counts_per_rad
    y = static_ladder_outputs(cfg, step, 60)
    j = np.arange(60) * step
    locked = int(np.sum(np.isfinite(y)))
    print(f'lock held for {locked} plateaus of {step:.1f} counts/s '
          f'({PAPER_PLATEAU_STEP_DEG_S} °/s); noise-free K/K and nonlinearity over n plateaus:')
    for n in (3, 4, 5, 6, 8, 10, 15, 25, 35, 45, 55):
        b, a = np.polyfit(j[:n], y[:n], 1)
        nl = np.max(np.abs(y[:n] - (a + b * j[:n]))) / np.max(np.abs(y[:n])) * 1e6
        print(f'  n = {n:2d}: K/K = {b:.6f}, nonlinearity {nl:8.1f} ppm')


if __name__ == '__main__':
    main()
