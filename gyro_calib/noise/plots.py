"""Log-log Allan-deviation plots of the noise characterisation (matplotlib, Agg backend).

Each axis: the measured ADEV with its EDF error bars, the total deviation at long τ
(hollow markers), the jointly fitted model, each reported term's own line (slopes −1,
−½, 0, +½, +1) and a marker where IEEE Std 952 reads the term off (Q at τ = √3 s, N at
1 s, B on the plateau 0.664·B, K at 3 s, R at √2 s), labelled with its value in the units
people quote.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.noise.terms import (
    AVAR_EXPONENT,
    AVAR_FACTOR,
    BIAS_INSTABILITY_ADEV_FACTOR,
    READ_OFF_TAU_S,
    SYMBOLS,
)

if TYPE_CHECKING:
    from gyro_calib.noise.calibrator import AxisResult, NoiseCalibrator

_COLOURS = ('tab:purple', 'tab:blue', 'tab:green', 'tab:orange', 'tab:red')


def _draw_axis(ax: Any, res: AxisResult) -> None:
    curve, fit = res.curve, res.fit
    units = res.units
    if curve is None:
        ax.text(0.5, 0.5, res.reason, ha='center', va='center', wrap=True,
                transform=ax.transAxes, fontsize=8)
        ax.set_title(res.axis)
        return
    tau, adev = curve.tau_s, curve.adev
    ok = adev > 0
    err = res.adev_std if res.adev_std is not None else np.zeros_like(adev)
    ax.errorbar(tau[ok], adev[ok], yerr=err[ok], fmt='o', ms=3, color='black', ecolor='0.5',
                elinewidth=0.8, capsize=0, label=f'ADEV ({curve.overlap} overlap)')
    if res.total_deviation is not None:
        t_tau, t_dev, t_err = res.total_deviation
        keep = t_tau > tau[-1] / 8
        if np.any(keep):
            ax.errorbar(t_tau[keep], t_dev[keep], yerr=t_err[keep], fmt='s', ms=3, mfc='none',
                        color='0.35', elinewidth=0.6, capsize=0, label='TOTDEV')
    grid = np.logspace(math.log10(tau[0]), math.log10(tau[-1]), 200)
    if fit is not None and np.any(fit.theta > 0):
        ax.loglog(grid, np.sqrt(fit.model_avar(grid)), '-', color='black', lw=1.0,
                  label='joint fit')
        for k, symbol in enumerate(SYMBOLS):
            key = units.keys[k]
            est = fit.estimates.get(key)
            line = np.sqrt(AVAR_FACTOR[k] * max(float(fit.theta[k]), 0.0)
                           * grid ** AVAR_EXPONENT[k])  # θ < 0 is never drawn
            if est is None:
                if fit.theta[k] > 0:
                    ax.loglog(grid, line, ':', color=_COLOURS[k], lw=0.8, alpha=0.6,
                              label=f'{symbol} in the fit, not resolved')
                continue
            q = units.quoted_factors[k]
            label = (f'{symbol} = {est.value * q:.3g} ± {est.std_uncertainty * q:.2g} '
                     f'{units.quoted_units[k]}')
            ax.loglog(grid, line, '--', color=_COLOURS[k], lw=0.9, label=label)
            if symbol == 'B':
                level = BIAS_INSTABILITY_ADEV_FACTOR * est.value
                model = np.sqrt(fit.model_avar(grid))
                t_mark = grid[int(np.argmin(model))]
                ax.plot([t_mark], [level], 'v', color=_COLOURS[k], ms=6)
            elif tau[0] <= READ_OFF_TAU_S[k] <= tau[-1]:
                ax.plot([READ_OFF_TAU_S[k]], [est.value], 'D', color=_COLOURS[k], ms=5)
    ax.set_xscale('log')
    ax.set_yscale('log')
    ax.set_xlabel('averaging time τ (s)')
    ax.set_ylabel(f'Allan deviation ({units.rate_unit})')
    ax.set_title(f'{res.axis}: {curve.n_rate_samples} samples, {curve.n_segments} segment(s), '
                 f'τ0 = {curve.tau0_s * 1e3:.4g} ms', fontsize=9)
    ax.grid(True, which='major', lw=0.4, alpha=0.5)
    # minor ticks at 2 and 5 only: log axes over many decades otherwise spend most of the
    # drawing time creating minor tick objects
    from matplotlib.ticker import LogLocator, NullFormatter
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_minor_locator(LogLocator(base=10.0, subs=(2.0, 5.0)))
        axis.set_minor_formatter(NullFormatter())
    ax.legend(fontsize=7, loc='best')


def _results(source: NoiseCalibrator | dict[str, AxisResult]) -> dict[str, AxisResult]:
    if isinstance(source, dict):
        return source
    return source.axis_results()


def plot_noise(source: NoiseCalibrator | dict[str, AxisResult], out_dir: str | Path) -> list[Path]:
    """One PNG per axis, ``noise_adev_<axis>.png`` in ``out_dir``; returns their paths."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for axis, res in _results(source).items():
        fig, ax = plt.subplots(figsize=(7.0, 5.0))
        _draw_axis(ax, res)
        path = (out / f'noise_adev_{axis}.png').absolute()
        fig.subplots_adjust(left=0.12, right=0.97, bottom=0.11, top=0.93)
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_noise_figure(source: NoiseCalibrator | dict[str, AxisResult], path: str | Path) -> Path:
    """All axes in one PNG (a panel per axis: 1 for a gyro, 2 × 3 for an Imu)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    results = _results(source)
    n = max(len(results), 1)
    cols = 3 if n > 2 else n
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(6.0 * cols, 4.5 * rows), squeeze=False)
    for ax, res in zip(axes.ravel(), results.values()):
        _draw_axis(ax, res)
    for ax in axes.ravel()[len(results):]:
        ax.set_visible(False)
    target = Path(path).absolute()
    target.parent.mkdir(parents=True, exist_ok=True)
    # margins in inches (tick labels and axis labels), whatever the number of panels
    fig.subplots_adjust(left=0.9 / (6.0 * cols), right=1.0 - 0.12 / (6.0 * cols),
                        bottom=0.55 / (4.5 * rows), top=1.0 - 0.3 / (4.5 * rows),
                        wspace=0.25, hspace=0.3)
    fig.savefig(target, dpi=100)
    plt.close(fig)
    return target
