"""Figures of an RBRLG calibration (``gyro-calib calibrate --plot DIR``), matplotlib Agg.

* ``rbrlg_k_tilde_pairs.png``: K̃ of every forward/reverse pair with its predicted standard
  uncertainty, the running mean and its ±1σ band (METHODS §A.2, eq. 3).
* ``rbrlg_stations.png``: N_og at each station against the rate-table angle β with the fitted
  c₀ + c₁·cos β + c₂·sin β (eq. 10), and the residuals below (METHODS §A.3).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.rbrlg.scale_factor import mean_estimate

if TYPE_CHECKING:
    from gyro_calib.rbrlg.calibration import RbrlgCalibrator


def plot_rbrlg(calibrator: RbrlgCalibrator, out_dir: Path) -> list[Path]:
    """Write the RBRLG figures that the data allow into ``out_dir``; return their paths."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    pairs = calibrator.k_tilde.pairs
    if pairs:
        k = np.array([p.k_tilde_arcsec_per_pulse for p in pairs])
        u = np.array([p.k_tilde_std for p in pairs])
        t = np.array([p.forward.start_ns for p in pairs]) / 1e9
        ref = float(np.median(k))
        fig, ax = plt.subplots(figsize=(8, 4.5))
        ax.errorbar(t - t[0], (k / ref - 1) * 1e9, yerr=u / ref * 1e9, fmt='o', capsize=3,
                    label='K̃ per pair (± predicted 1σ)')
        means, bands = [], []
        for i in range(1, len(k) + 1):
            try:
                est = mean_estimate(list(k[:i]), predicted_std=list(u[:i]),
                                    prediction_complete=all(p.prediction_complete
                                                            for p in pairs[:i]))
            except InsufficientDataError:
                means.append(k[0])
                bands.append(u[0])
            else:
                means.append(est.value)
                bands.append(est.std_uncertainty)
        m, b = (np.array(means) / ref - 1) * 1e9, np.array(bands) / ref * 1e9
        ax.plot(t - t[0], m, '-', color='C1', label='running mean')
        ax.fill_between(t - t[0], m - b, m + b, color='C1', alpha=0.2, label='running mean ± 1σ')
        ax.set_xlabel('time of the pair from the first, s')
        ax.set_ylabel(f'K̃ / {ref:.10f} ″/pulse − 1, ppb')
        ax.set_title(f'K̃ from {len(k)} forward/reverse pairs (docs/methods.md §A eq. (3))')
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        written.append(_save(fig, out_dir / 'rbrlg_k_tilde_pairs.png'))
    stations = calibrator.stations.stations
    res = calibrator.results()
    if stations and res.fix_error is not None:
        psi = np.array([s.rate_table_angle_rad for s in stations])
        n_og = np.array([s.half_difference_pulses for s in stations])
        u = np.array([s.half_difference_std_pulses for s in stations])
        c0, c1, c2 = res.fix_error.coefficients
        grid = np.linspace(0, 2 * np.pi, 361)
        model = c0 + c1 * np.cos(psi) + c2 * np.sin(psi)
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True,
                                          gridspec_kw={'height_ratios': [2, 1]})
        top.plot(np.degrees(grid), c0 + c1 * np.cos(grid) + c2 * np.sin(grid), '-',
                 label='fit c₀ + c₁·cos β + c₂·sin β')
        top.errorbar(np.degrees(psi) % 360, n_og, yerr=u, fmt='o', label='N_og at each station')
        theta = res.fix_error.fix_error_angle_rad
        top.set_title(f'θ = {np.degrees(theta.value) * 3600:.3f}″ ± '
                      f'{np.degrees(theta.std_uncertainty) * 3600:.3f}″ from {len(psi)} stations '
                      '(docs/methods.md §A eq. (10))')
        top.set_ylabel('N_og = (N⁺ − N⁻)/2, pulses')
        top.legend(fontsize=8)
        top.grid(alpha=0.3)
        bottom.errorbar(np.degrees(psi) % 360, n_og - model, yerr=u, fmt='o')
        bottom.axhline(0.0, color='k', lw=0.8)
        bottom.set_xlabel('rate-table angle β (encoder), °')
        bottom.set_ylabel('residual, pulses')
        bottom.grid(alpha=0.3)
        written.append(_save(fig, out_dir / 'rbrlg_stations.png'))
    return written


def _save(fig: Any, path: Path) -> Path:
    """Lay out, write and close a figure; its path."""
    import matplotlib.pyplot as plt  # the caller chose the Agg backend

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
