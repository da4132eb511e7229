"""Figures of the thermal calibration and compensation (matplotlib, Agg, imported lazily).

:func:`plot_thermal` writes, from a calibrator (or its fit report) and optionally a
compensation report of another run:

- ``thermal_bias_vs_h.png``: bias (fit-block or soak-point means, coloured by Ḣ) against
  H, with the model at Ḣ = 0 and its ±1σ band (static part; dynamic terms at their
  calibrated centre);
- ``thermal_residuals.png``: residuals of the rows against time, held-out rows marked;
- ``thermal_before_after.png``: 100 s means of the raw and compensated rate against time
  (calibration run; and the validation run if given), with the noise floor;
- ``thermal_allan.png``: Allan deviation before/after compensation (validation run).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    from gyro_calib.thermal.calibrator import ThermalCalibrator
    from gyro_calib.thermal.compensate import CompensationReport
    from gyro_calib.thermal.fit import ThermalFitReport

DEG_H = np.pi / 180.0 / 3600.0


def _block_series(t_ns: np.ndarray, values: np.ndarray, block_s: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``values`` over consecutive ``block_s`` of stamp time (NaNs skipped)."""
    ok = np.isfinite(values)
    if not np.any(ok):
        return np.zeros(0), np.zeros(0)
    g = (t_ns[ok] // int(block_s * NS_PER_S)).astype(np.int64)
    uniq, inv = np.unique(g, return_inverse=True)
    means = np.bincount(inv, weights=values[ok]) / np.bincount(inv)
    return (uniq + 0.5) * block_s, means


def plot_thermal(calibrator_or_report: ThermalCalibrator | ThermalFitReport, out_dir: Path,
                 *, validation: CompensationReport | None = None) -> list[Path]:
    """Write the figures to ``out_dir`` (created if needed); return their paths."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    rep: Any = getattr(calibrator_or_report, 'report', calibrator_or_report)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    model = rep.model
    rows = rep.rows
    t0 = float(rep.t_mid_ns[0]) / NS_PER_S

    # bias vs H with the model
    fig, ax = plt.subplots(figsize=(8, 5))
    sc = ax.scatter(rows.variables['H'], rows.y_rad_s / DEG_H, c=rows.variables['Hdot'] * 60,
                    s=6 if rows.sigma_rad_s is None else 30, cmap='coolwarm')
    if rows.sigma_rad_s is not None:
        ax.errorbar(rows.variables['H'], rows.y_rad_s / DEG_H, yerr=rows.sigma_rad_s / DEG_H,
                    fmt='none', ecolor='k')
    fig.colorbar(sc, ax=ax, label='Ḣ (°C/min)')
    h = np.linspace(model.h_range_c[0], model.h_range_c[1], 200)
    sc_ = model.scaling
    b, s = model.bias_rad_s(h, 0.0, sc_.centre['dTab'], sc_.centre['dTcs'], check=False)
    ax.plot(h, b / DEG_H, 'k-', label='model (Ḣ = 0)')
    ax.fill_between(h, (b - s) / DEG_H, (b + s) / DEG_H, color='k', alpha=0.2, label='±1σ')
    ax.set_xlabel('H, mean cavity temperature (°C)')
    ax.set_ylabel('bias (°/h)')
    ax.set_title('bias = b0 + ' + (' + '.join(model.terms) or 'constant'))
    ax.legend()
    paths.append(out_dir / 'thermal_bias_vs_h.png')
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    # residuals vs time
    fig, ax = plt.subplots(figsize=(9, 4))
    x = np.column_stack([np.ones(len(rows.y_rad_s))] + [rows.columns[t] for t in model.terms])
    resid = rows.y_rad_s - x @ np.asarray(model.coefficients_rad_s)
    tr = rows.t_ns / NS_PER_S - t0
    ax.plot(tr[~rows.held_out] / 3600, resid[~rows.held_out] / DEG_H, '.', ms=3, label='fit')
    if np.any(rows.held_out):
        ax.plot(tr[rows.held_out] / 3600, resid[rows.held_out] / DEG_H, '.', ms=3,
                label='held out')
    ax.axhline(0, color='k', lw=0.5)
    ax.set_xlabel('time (h)')
    ax.set_ylabel('residual (°/h)')
    ax.legend()
    paths.append(out_dir / 'thermal_residuals.png')
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    # before / after
    n_ax = 2 if validation is not None else 1
    fig, axes = plt.subplots(n_ax, 1, figsize=(9, 4 * n_ax), squeeze=False)
    tm = rep.t_mid_ns
    # each series on its own blocks: the model is NaN where a sensor failed or H left the
    # calibrated range, so the compensated series may have fewer blocks than the raw one
    tb, raw = _block_series(tm, rep.bias_raw_rad_s, 100.0)
    tc, comp = _block_series(tm, rep.bias_raw_rad_s - rep.bias_model_rad_s, 100.0)
    ax = axes[0, 0]
    ax.plot((tb - t0) / 3600, raw / DEG_H, '.', ms=3, label='raw')
    ax.plot((tc - t0) / 3600, comp / DEG_H, '.', ms=3, label='raw − model')
    ax.set_title('calibration run: 100 s means of the bias')
    ax.set_ylabel('°/h')
    ax.legend()
    if validation is not None:
        v = validation
        vt0 = float(v.t_mid_ns[0]) / NS_PER_S
        e = v.earth_rate_along_axis_rad_s
        tb, raw = _block_series(v.t_mid_ns, v.rate_raw_rad_s - e, v.block_s)
        tc, comp = _block_series(v.t_mid_ns, v.rate_raw_rad_s - e - v.bias_model_rad_s,
                                 v.block_s)
        ax = axes[1, 0]
        ax.plot((tb - vt0) / 3600, raw / DEG_H, '.', ms=3,
                label=f'raw: {v.bias_stability_raw.value / DEG_H:.4f} °/h')
        ax.plot((tc - vt0) / 3600, comp / DEG_H, '.', ms=3,
                label=f'raw − model: {v.bias_stability_compensated.value / DEG_H:.4f} °/h')
        f = v.noise_floor.floor.value / DEG_H
        ax.axhspan(-f, f, color='g', alpha=0.15, label=f'± noise floor {f:.4f} °/h')
        ax.set_title(f'validation run ({v.improvement:.0%} better bias stability)')
        ax.set_ylabel('°/h')
        ax.legend()
    axes[-1, 0].set_xlabel('time (h)')
    paths.append(out_dir / 'thermal_before_after.png')
    fig.tight_layout()
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    if validation is not None and len(validation.adev_tau_s):
        paths.append(_allan_figure(validation, out_dir / 'thermal_allan.png'))
    return paths


def plot_compensation(report: CompensationReport, out_dir: Path) -> list[Path]:
    """Figures of one compensated recording (``gyro-calib compensate --plot``).

    - ``thermal_compensation.png``: 100 s means of the raw and compensated bias against
      time, with the noise floor band; the model bias and H underneath;
    - ``thermal_compensation_allan.png``: Allan deviation before/after.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    v = report
    t0 = float(v.t_mid_ns[0]) / NS_PER_S
    e = v.earth_rate_along_axis_rad_s
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    tb, raw = _block_series(v.t_mid_ns, v.rate_raw_rad_s - e, v.block_s)
    tc, comp = _block_series(v.t_mid_ns, v.rate_raw_rad_s - e - v.bias_model_rad_s, v.block_s)
    ax.plot((tb - t0) / 3600, raw / DEG_H, '.', ms=3,
            label=f'raw − Earth rate: {v.bias_stability_raw.value / DEG_H:.4f} °/h')
    ax.plot((tc - t0) / 3600, comp / DEG_H, '.', ms=3,
            label=('raw − Earth rate − model: '
                   f'{v.bias_stability_compensated.value / DEG_H:.4f} °/h'))
    f = v.noise_floor.floor.value / DEG_H
    ax.axhspan(-f, f, color='g', alpha=0.15, label=f'± noise floor {f:.4f} °/h')
    ax.set_ylabel(f'{v.block_s:g} s means (°/h)')
    ax.set_title(f'bias stability {v.improvement:.0%} better after compensation')
    ax.legend(fontsize=8)
    tm = (v.t_mid_ns / NS_PER_S - t0) / 3600
    ax2.plot(tm, v.bias_model_rad_s / DEG_H, 'k-', lw=1, label='model bias (°/h)')
    ax2.set_ylabel('model bias (°/h)')
    ax3 = ax2.twinx()
    ax3.plot(tm, v.h_c, 'r-', lw=0.8, alpha=0.6)
    ax3.set_ylabel('H (°C)', color='r')
    ax2.set_xlabel('time (h)')
    paths = [out_dir / 'thermal_compensation.png']
    fig.tight_layout()
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    if len(v.adev_tau_s):
        paths.append(_allan_figure(v, out_dir / 'thermal_compensation_allan.png'))
    return paths


def _allan_figure(report: CompensationReport, path: Path) -> Path:
    """Allan deviation of a compensated run before and after compensation, written to ``path``."""
    import matplotlib.pyplot as plt  # the caller chose the Agg backend

    fig, ax = plt.subplots(figsize=(7, 5))
    ax.loglog(report.adev_tau_s, report.adev_raw_rad_s / DEG_H, 'o-', ms=3, label='raw')
    ax.loglog(report.adev_tau_s, report.adev_compensated_rad_s / DEG_H, 'o-', ms=3,
              label='compensated')
    ax.set_xlabel('τ (s)')
    ax.set_ylabel('Allan deviation (°/h)')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
