"""Figures of a dither-misalignment calibration: what a bench engineer looks at.

* ``dither_spectrum_<axis>.png``: averaged amplitude spectrum of the count per orientation,
  the dither line, table lines and the sidebands f_d ± f_z marked, with the sideband height
  the fitted component implies and the height the floor can resolve.
* ``dither_residuals_<axis>.png``: the regression residual (last block and its averaged
  spectrum) and every block's own estimate against the whole-record one.
* ``dither_coning.png``: coning drift ε against a (eq. 24 under both rocking models, and the
  dither × rocking total), with this gyro marked and the acceptance limit.

matplotlib is imported inside the functions (Agg backend) so the core imports fast.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.dither.calibrator import (
    COMPONENT_KEYS,
    DitherCalibrator,
    describe_component,
)
from gyro_calib.dither.coning import PAPER_ROCKING_PER_MISALIGNMENT, coning_drift
from gyro_calib.dither.keys import KEY_A, KEY_CONING
from gyro_calib.dither.misalignment import RAD_PER_ARCMIN

if TYPE_CHECKING:
    from gyro_calib.estimate import Estimate

DEG_H_PER_RAD_S = 180.0 / math.pi * 3600.0


def _pyplot() -> ModuleType:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_dither(calibrator_or_results: DitherCalibrator | dict[str, Estimate],
                out_dir: Path) -> list[Path]:
    """Write the dither figures to ``out_dir``; return their paths.

    Given only a results mapping (hand-off keys → Estimate), only the ε-against-a figure is
    drawn (spectra and residuals need the calibrator).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    if isinstance(calibrator_or_results, DitherCalibrator):
        cal = calibrator_or_results
        results = cal.results()
        for axis, rec in cal.orientations.items():
            if rec.spectrum_sum is not None:
                paths.append(_plot_spectrum(cal, axis, out_dir))
                paths.append(_plot_residuals(cal, axis, out_dir))
        dither_hz = cal.summary().dither_frequency_hz
        theta_d = cal.summary().dither_amplitude_rad
        settings = cal.settings
        k, model, phase = (settings.rocking_per_misalignment, settings.rocking_model,
                           settings.rocking_phase_rad)
    else:
        results = calibrator_or_results
        dither_hz, theta_d = math.nan, math.nan
        k, model, phase = PAPER_ROCKING_PER_MISALIGNMENT, 'proportional', math.nan
    paths.append(_plot_coning(results, out_dir, dither_hz=dither_hz, theta_d=theta_d,
                              k=k, model=model, phase=phase))
    return paths


def _line_marks(ax: Any, fd: float, fz: float, harmonics: int) -> None:
    marks = [(fd, 'f_d', 'tab:red'), (fd - fz, 'f_d − f_z', 'tab:green'),
             (fd + fz, 'f_d + f_z', 'tab:green')]
    marks += [(h * fz, f'{h}·f_z' if h > 1 else 'f_z', 'tab:blue')
              for h in range(1, harmonics + 1)]
    for f, label, color in marks:
        ax.axvline(f, color=color, lw=0.8, ls='--', alpha=0.7)
        ax.text(f, 0.98, f' {label}', rotation=90, va='top', fontsize=7, color=color,
                transform=ax.get_xaxis_transform())


def _plot_spectrum(cal: DitherCalibrator, axis: str, out_dir: Path) -> Path:
    plt = _pyplot()
    rec = cal.orientations[axis]
    assert rec.spectrum_sum is not None  # plotted only for orientations with spectra
    spec = np.sqrt(rec.spectrum_sum / rec.n_spectra)
    freqs = np.fft.rfftfreq(cal.settings.spectrum_samples, 1.0 / rec.spectrum_rate_hz)
    fd, fz = rec.mean('dither_frequency_hz'), rec.mean('table_frequency_hz')
    fig, ax = plt.subplots(figsize=(9, 4.8))
    ax.semilogy(freqs[1:], spec[1:], lw=0.7, color='0.3', label='count spectrum (block mean)')
    comps, _ = cal.components()
    c = comps.get(axis)
    if c is not None:
        amp_p, amp_t = rec.mean('dither_amplitude_pulses'), rec.mean('table_rate_amplitude_rad_s')
        for f in (fd - fz, fd + fz):
            height = amp_t * amp_p * abs(c.signed_rad) / (2 * 2 * math.pi * f)
            floor = amp_t * amp_p * c.floor.component_std_rad / (2 * 2 * math.pi * f)
            ax.plot([f], [max(height, 1e-12)], 'v', color='tab:green', ms=7)
            ax.plot([f - 4, f + 4], [floor, floor], color='tab:orange', lw=1.5)
        ax.plot([], [], 'v', color='tab:green', label='sideband height of the fitted component')
        ax.plot([], [], color='tab:orange', label='1σ floor of this record (whole record)')
    _line_marks(ax, fd, fz, cal.settings.table_harmonics)
    ax.set_xlim(0, min(rec.spectrum_rate_hz / 2, fd + 4 * fz + 50))
    ax.set_xlabel('frequency (Hz)')
    ax.set_ylabel('count amplitude (pulses)')
    ax.set_title(f'Table along {axis.upper()}: output spectrum, {rec.n_spectra} blocks averaged\n'
                 '(a sideband under this noise is still resolved by the regression over the '
                 'whole record, down to the orange floor)', fontsize=9)
    ax.legend(fontsize=7, loc='lower left')
    fig.tight_layout()
    path = out_dir / f'dither_spectrum_{axis}.png'
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_residuals(cal: DitherCalibrator, axis: str, out_dir: Path) -> Path:
    plt = _pyplot()
    rec = cal.orientations[axis]
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(9, 9))
    if rec.last_residual is not None:
        tau, res = rec.last_residual
        ax1.plot(tau, res, lw=0.4, color='0.3')
        ax1.set_title(f'Residual of the last block, rms {np.sqrt(np.mean(res ** 2)):.3f} pulses '
                      f'(quantisation alone: {1 / math.sqrt(12):.3f})', fontsize=9)
        ax1.set_xlabel('time from block centre (s)')
        ax1.set_ylabel('pulses')
    assert rec.residual_spectrum_sum is not None  # set with spectrum_sum
    spec = np.sqrt(rec.residual_spectrum_sum / rec.n_spectra)
    freqs = np.fft.rfftfreq(cal.settings.spectrum_samples, 1.0 / rec.spectrum_rate_hz)
    ax2.semilogy(freqs[1:], spec[1:], lw=0.6, color='0.3')
    fd, fz = rec.mean('dither_frequency_hz'), rec.mean('table_frequency_hz')
    _line_marks(ax2, fd, fz, cal.settings.table_harmonics)
    ax2.set_title('Residual spectrum: no line should remain at the marks', fontsize=9)
    ax2.set_xlabel('frequency (Hz)')
    ax2.set_ylabel('pulses')
    t = np.array([b.start_ns for b in rec.blocks]) / 1e9
    sign = 1.0 if axis == 'z' else -1.0
    beta = sign * np.array([b.beta[0] for b in rec.blocks]) / RAD_PER_ARCMIN
    std = np.array([b.beta_std[0] for b in rec.blocks]) / RAD_PER_ARCMIN
    ax3.errorbar(t, beta, yerr=std, fmt='.', ms=3, lw=0.5, color='0.4', label='each block')
    summary = cal.summary()
    c = summary.components.get(axis)
    if c is not None:
        # the numbers the summary prints (describe_component), drawn with the blocks' sign
        sign = 1.0 if c.signed_rad >= 0 else -1.0
        v = sign * c.magnitude_rad / RAD_PER_ARCMIN
        s = c.random_std_rad / RAD_PER_ARCMIN
        ax3.axhspan(v - s, v + s, color='tab:green', alpha=0.3,
                    label=f'reported {abs(v):.2f}′, ± statistical {s:.2f}′')
        parts = cal.result_parts().get(COMPONENT_KEYS[axis])
        if parts is not None:
            low, high = (x / RAD_PER_ARCMIN for x in parts['interval'])
            if math.isfinite(high):
                edges = (sign * low, sign * high)
                ax3.axhspan(min(edges), max(edges), color='tab:green', alpha=0.1,
                            label=f'interval at k = {parts["coverage_factor"]:g} '
                                  f'(rocking allowance included): {low:.2f}′ – {high:.2f}′')
        ax3.set_title(describe_component(c), fontsize=8, wrap=True)
    ax3.set_xlabel('block start (s)')
    ax3.set_ylabel('signed component (′)')
    ax3.legend(fontsize=7)
    fig.tight_layout()
    path = out_dir / f'dither_residuals_{axis}.png'
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_coning(results: dict[str, Estimate], out_dir: Path, *, dither_hz: float,
                 theta_d: float, k: float, model: str, phase: float) -> Path:
    plt = _pyplot()
    f = dither_hz if math.isfinite(dither_hz) else 400.0
    a = np.linspace(0.5, 60.0, 240) * RAD_PER_ARCMIN
    fig, ax = plt.subplots(figsize=(8, 5))
    eq24_p = [coning_drift(x / math.sqrt(2), x / math.sqrt(2), dither_frequency_hz=f,
                           rocking_per_misalignment=k, rocking_phase_rad=phase,
                           model='proportional').eq24_rad_s for x in a]
    eq24_c = [coning_drift(x / math.sqrt(2), x / math.sqrt(2), dither_frequency_hz=f,
                           rocking_per_misalignment=k, rocking_phase_rad=phase,
                           model='components').eq24_rad_s for x in a]
    am = a / RAD_PER_ARCMIN
    ax.semilogy(am, np.array(eq24_p) * DEG_H_PER_RAD_S, label='eq. (24), proportional rocking')
    ax.semilogy(am, np.array(eq24_c) * DEG_H_PER_RAD_S, ls='--',
                label='eq. (24), components rocking (ψ₀ = 45°, its largest)')
    if math.isfinite(theta_d):
        total = [coning_drift(x / math.sqrt(2), x / math.sqrt(2), dither_frequency_hz=f,
                              dither_amplitude_rad=theta_d, rocking_per_misalignment=k,
                              rocking_phase_rad=phase, model=model).total_rad_s for x in a]
        ax.semilogy(am, np.array(total) * DEG_H_PER_RAD_S, ls=':',
                    label=f'+ dither × rocking, {model} (ψ₀ = 45°)')
    ax.axvline(5.0, color='tab:red', lw=0.8, label='acceptance limit 5′')
    ax.axhline(0.0005, color='0.5', lw=0.6, ls='-.', label='0.0005 °/h')
    if KEY_A in results and KEY_CONING in results and all(
            math.isfinite(results[k].std_uncertainty) for k in (KEY_A, KEY_CONING)):
        ra, rc = results[KEY_A], results[KEY_CONING]
        ax.errorbar([ra.value / RAD_PER_ARCMIN], [rc.value * DEG_H_PER_RAD_S],
                    xerr=[ra.std_uncertainty / RAD_PER_ARCMIN],
                    yerr=[rc.std_uncertainty * DEG_H_PER_RAD_S], fmt='o', color='k',
                    label='this gyro')
    ax.set_xlabel('dither-axis misalignment a (′)')
    ax.set_ylabel('coning drift ε (°/h)')
    ax.set_title(f'Coning drift against a (Ω_d/2π = {f:.0f} Hz, k = {k * 2100:.2g}″ per 35′, '
                 f'{"sin φ = 1" if math.isnan(phase) else f"φ = {phase:.2f} rad"})', fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(True, which='both', lw=0.3)
    fig.tight_layout()
    path = out_dir / 'dither_coning.png'
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
