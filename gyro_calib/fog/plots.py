"""Figures of the FOG calibration a user looks at instead of reading numbers (issue 10 Part 0).

- ``fog_turntable_nonlinearity.png``: the turntable fit's residuals against table rate, in
  ppm of full-scale output, with their standard uncertainties — the scale-factor
  nonlinearity curve as IEEE Std 952 plots it;
- ``fog_self_cal_range.png``: the self-calibrated K against the range used (the paper's
  Table 1 as a curve), with the turntable K, the linear range marked and, below, the
  nonlinearity of each range against the spec.

matplotlib is imported inside :func:`plot_fog` (Agg backend), so the core imports fast.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.fog.self_cal import SelfCalFit
from gyro_calib.fog.turntable import TurntableFit

if TYPE_CHECKING:
    from gyro_calib.estimate import Estimate
    from gyro_calib.fog.calibrator import FogCalibrator


def plot_fog(calibrator: FogCalibrator, out_dir: Path) -> list[Path]:
    """Write the FOG figures that the measured results allow; return their paths."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fits = calibrator.fits()
    written: list[Path] = []
    if isinstance(fits.turntable, TurntableFit):
        written.append(_turntable_figure(plt, fits.turntable, out_dir))
    if isinstance(fits.self_cal, SelfCalFit) and fits.self_cal.table:
        k_tt = fits.turntable.scale_factor if isinstance(fits.turntable, TurntableFit) else None
        written.append(_self_cal_figure(plt, fits.self_cal, k_tt,
                                        calibrator.settings.self_cal_nonlinearity_spec_ppm,
                                        out_dir))
    return written


def _turntable_figure(plt: ModuleType, fit: TurntableFit, out_dir: Path) -> Path:
    rates = np.degrees(fit.rates_rad_s)
    full_scale = float(np.max(np.abs(fit.outputs_counts_s)))
    resid = fit.residuals / full_scale * 1e6
    err = np.sqrt(np.maximum(np.diag(fit.line.residual_cov), 0.0)) / full_scale * 1e6
    order = np.argsort(rates)
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.axhline(0.0, color='0.6', lw=0.8)
    ax.errorbar(rates[order], resid[order], yerr=err[order], fmt='o-', ms=4, capsize=3,
                label='residual of N = K·ω + B (±1σ)')
    at = int(np.argmax(np.abs(resid)))
    nl = fit.nonlinearity_ppm
    ax.plot(rates[at], resid[at], 'o', mfc='none', mec='C3', ms=12,
            label=(f'nonlinearity {nl.value:.3g} ± {nl.std_uncertainty:.2g} ppm' if nl else
                   'nonlinearity not measurable from two rates'))
    k = fit.scale_factor
    ax.set_title(f'FOG turntable fit: K = {k.value:.6f} ± {k.std_uncertainty:.2g} counts/rad '
                 f'({len(rates)} rates)')
    ax.set_xlabel('table rate (°/s)')
    ax.set_ylabel('residual (ppm of full-scale output)')
    ax.legend(loc='best', fontsize=8)
    ax.grid(alpha=0.3)
    path = out_dir / 'fog_turntable_nonlinearity.png'
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _self_cal_figure(plt: ModuleType, fit: SelfCalFit, k_tt: Estimate | None, spec_ppm: float,
                     out_dir: Path) -> Path:
    rows = list(fit.table)
    mapped = rows[0].scale_factor is not None
    if mapped:
        x = np.array([math.degrees(r.range_rad_s) for r in rows])
        xlabel = 'range used: largest equivalent rate (°/s)'
        y = np.array([r.scale_factor.value for r in rows])  # type: ignore[union-attr]
        ey = np.array([r.scale_factor.std_uncertainty for r in rows])  # type: ignore[union-attr]
        ylabel = 'self-calibrated K (counts/rad)'
    else:
        x = np.array([r.max_injection_counts_s for r in rows])
        xlabel = 'range used: largest injection (counts/s)'
        y = np.array([r.slope.value for r in rows])
        ey = np.array([r.slope.std_uncertainty for r in rows])
        ylabel = 'output change / injection (no mapping)'
    nl = np.array([r.nonlinearity_ppm.value for r in rows])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True,
                                      gridspec_kw={'height_ratios': [2, 1]})
    top.errorbar(x, y, yerr=ey, fmt='o-', ms=3, capsize=2, label='K over the plateaus up to x')
    if mapped and k_tt is not None:
        top.axhline(k_tt.value, color='C2', lw=1.2,
                    label=f'turntable K = {k_tt.value:.6g} counts/rad')
    if fit.small_signal is not None:
        top.axhline(fit.small_signal.value, color='C4', ls=':', lw=1.2,
                    label=f'zero-amplitude K = {fit.small_signal.value:.6g} ± '
                          f'{fit.small_signal.std_uncertainty:.2g}')
    if fit.linear is not None:
        edge = x[rows.index(fit.linear)]
        for ax in (top, bottom):
            ax.axvspan(0, edge, color='C1', alpha=0.15)
        label = f'linear range ({fit.linear.plateaus} plateaus, ≤ {spec_ppm:g} ppm)'
        top.plot([], [], color='C1', alpha=0.3, lw=8, label=label)
    top.set_ylabel(ylabel)
    top.set_title('FOG self-calibration: K against the range used')
    top.legend(loc='best', fontsize=8)
    top.grid(alpha=0.3)
    bottom.semilogy(x, np.maximum(nl, 1e-3), 'o-', ms=3, color='C3')
    bottom.axhline(spec_ppm, color='k', ls='--', lw=0.8, label=f'spec {spec_ppm:g} ppm')
    bottom.set_ylabel('nonlinearity (ppm)')
    bottom.set_xlabel(xlabel)
    bottom.legend(loc='best', fontsize=8)
    bottom.grid(alpha=0.3, which='both')
    path = out_dir / 'fog_self_cal_range.png'
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
