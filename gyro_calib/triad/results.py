"""The triad's result in the shared shape: estimates, what is missing, rows, the imu: section.

From a :class:`~gyro_calib.triad.estimator.TriadResult` (METHODS §F eqs. (10)–(14)):
:func:`estimates` (K and bias by ``imu.<channel>.<key>``), :func:`missing_of` and
:func:`not_measurable_of` (why a key is not measured), :func:`summary_rows` (the summary
table) and :func:`imu_section` (the hand-off's ``imu:`` section).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.imu_calibration import ImuCalibration
from gyro_calib.units import ARCSEC_PER_RAD

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.estimate import Estimate
    from gyro_calib.triad.count_noise import CountWalk
    from gyro_calib.triad.records import TriadResult

    Array = npt.NDArray[np.float64]

DEG_H = math.radians(1.0) / 3600.0
"""rad/s per °/h."""


def estimates(r: TriadResult | None) -> dict[str, Estimate]:
    """K and the bias of each channel, by ``imu.<channel>.<key>``."""
    out: dict[str, Estimate] = {}
    if r is None:
        return out
    for ch in r.channels:
        if ch.scale_factor_rad_per_pulse is not None:
            out[f'imu.{ch.name}.scale_factor_rad_per_pulse'] = ch.scale_factor_rad_per_pulse
    if r.bias_body_rad_s is not None:
        for name, est in zip(('x', 'y', 'z'), r.bias_body_rad_s, strict=True):
            out[f'imu.bias_rad_s.{name}'] = est
    return out


def missing_of(r: TriadResult | None, problem: str) -> dict[str, str]:
    """Why K, s, M or b are not measured (``problem``: why there is no result, if known)."""
    if r is None:
        why = problem or ('no window pair yet: the triad needs forward/reverse '
                                'pairs about at least 3 independent directions.')
        return {'imu.scale_factor_rad_per_pulse': why, 'imu.pulses_to_body_rad': why}
    out: dict[str, str] = {}
    for ch in r.channels:
        if ch.not_measurable:
            out[f'imu.{ch.name}.scale_factor_rad_per_pulse'] = ch.not_measurable
    if r.not_measurable:
        out['imu.pulses_to_body_rad'] = r.not_measurable
    if r.bias_body_rad_s is None:
        out['imu.bias_rad_s'] = r.bias_missing or 'b needs all three rows and biases.'
    return out


def not_measurable_of(r: TriadResult | None) -> dict[str, str]:
    """The rows whose directions do not span 3-D (no more data of this bench helps)."""
    if r is None:
        return {}
    out = {f'imu.{c.name}.scale_factor_rad_per_pulse': c.not_measurable
           for c in r.channels if c.not_measurable}
    if r.not_measurable:
        out['imu.pulses_to_body_rad'] = r.not_measurable
    return out


def summary_rows(r: TriadResult | None) -> list[tuple[str, str, str, str]]:
    """K_i (″/pulse, u in ppm), misalignments (″), M (rad/pulse), biases (°/h)."""
    rows: list[tuple[str, str, str, str]] = []
    if r is None:
        return rows
    for i, ch in enumerate(r.channels):
        k = ch.scale_factor_rad_per_pulse
        if k is None or ch.sense_axis is None:
            rows.append((f'K_{ch.name} (″/pulse)', '—', '', 'not measurable'))
            continue
        rows.append((f'K_{ch.name} (″/pulse) [u ppm]', f'{k.value * ARCSEC_PER_RAD:.10f}',
                     f'{k.std_uncertainty / k.value * 1e6:.3g} ppm', str(k.n_used)))
        for j, axis in enumerate('xyz'):
            if j == i:
                continue
            e = ch.sense_axis[j]
            rows.append((f's_{ch.name}·e_{axis} (″)', f'{e.value * ARCSEC_PER_RAD:.3f}',
                         f'{e.std_uncertainty * ARCSEC_PER_RAD:.3g}', str(e.n_used)))
        if ch.bias_rad_s is not None:
            rows.append((f'bias_{ch.name} along s (°/h)', f'{ch.bias_rad_s.value / DEG_H:.5f}',
                         f'{ch.bias_rad_s.std_uncertainty / DEG_H:.3g}',
                         str(ch.bias_rad_s.n_used)))
    if r.pulses_to_body_rad is not None:
        for i, row in enumerate(r.pulses_to_body_rad):
            rows.append((f'M row {i} (rad/pulse)', ' '.join(f'{e.value:.9e}' for e in row),
                         ' '.join(f'{e.std_uncertainty:.2e}' for e in row),
                         str(row[0].n_used)))
    if r.bias_body_rad_s is not None:
        for name, e in zip('xyz', r.bias_body_rad_s, strict=True):
            rows.append((f'b_{name} body (°/h)', f'{e.value / DEG_H:.5f}',
                         f'{e.std_uncertainty / DEG_H:.3g}', str(e.n_used)))
    for name, e in r.parameters.items():
        rows.append((f'{name} correction (″)', f'{e.value * ARCSEC_PER_RAD:.4f}',
                     f'{e.std_uncertainty * ARCSEC_PER_RAD:.3g}', str(e.n_used)))
    return rows


def imu_section(r: TriadResult, channels: tuple[str, str, str],
                fixture: Array) -> ImuCalibration:
    """The ``imu:`` section of a :class:`TriadResult` (METHODS §F eqs. (10)–(14))."""
    missing: dict[str, str] = {}
    not_measurable: dict[str, str] = {}
    k = k_std = k_dof = axes = axes_std = None
    if any(c.scale_factor_rad_per_pulse is not None and c.sense_axis is not None
           for c in r.channels):  # the solved channels; a channel not measured is NaN (null)
        nan3 = (math.nan, math.nan, math.nan)
        k, k_std, k_dof, axes_std = (np.full(3, math.nan) for _ in range(4))
        axes = np.full((3, 3), math.nan)
        for i, c in enumerate(r.channels):
            e = c.scale_factor_rad_per_pulse
            if e is None or c.sense_axis is None:
                continue
            k[i], k_std[i], k_dof[i] = e.value, e.std_uncertainty, float(e.supported_dof)
            row = np.array([a.value for a in c.sense_axis] if c.sense_axis else nan3)
            axes[i] = row / np.linalg.norm(row)
            axes_std[i] = (math.sqrt(max(float(np.trace(c.sense_axis_covariance)), 0.0))
                           if c.sense_axis_covariance is not None else 0.0)
    why = '; '.join(c.not_measurable for c in r.channels if c.not_measurable)
    if why:
        for key in ('scale_factor_rad_per_pulse', 'sense_axes'):
            not_measurable[key] = why
    m = m_cov = None
    if r.pulses_to_body_rad is not None and r.pulses_to_body_covariance is not None:
        m = np.array([[e.value for e in row] for row in r.pulses_to_body_rad])
        m_cov = 0.5 * (r.pulses_to_body_covariance + r.pulses_to_body_covariance.T)
    else:
        not_measurable['pulses_to_body_rad'] = r.not_measurable or 'M needs all three rows.'
    b = b_std = None
    if r.bias_body_rad_s is not None:
        b = np.array([e.value for e in r.bias_body_rad_s])
        b_std = np.array([e.std_uncertainty for e in r.bias_body_rad_s])
    else:
        missing['bias_rad_s'] = r.bias_missing or 'b needs all three rows and biases.'
    return ImuCalibration(channels, np.asarray(fixture, dtype=np.float64), k, k_std, k_dof,
                          axes, axes_std, m, m_cov, b, b_std, missing=missing,
                          not_measurable=not_measurable)


def count_walk_line(walk: CountWalk, channels: tuple[str, str, str]) -> str:
    """The ARW each window's count carries (eq. (6b)), per gyro, and where it comes from."""
    from gyro_calib.triad.count_noise import MEASURED

    parts = []
    for i, name in enumerate(channels):
        n = float(walk.arw_rad_sqrt_s[i])
        text = f'{math.degrees(n) * 60.0:.3g}' if math.isfinite(n) else '—'
        if walk.origin == MEASURED and math.isfinite(n):
            text += f' ({walk.dof[i]} dof)'
        parts.append(f'{name} {text}')
    return f'count noise: ARW over each window (°/√h, {walk.origin}): ' + ', '.join(parts)


def dof_line(r: TriadResult) -> str:
    """The degrees of freedom of each K_i and s_i, as the hand-off stores them."""
    parts = [f'K_{c.name}, s_{c.name} {c.scale_factor_rad_per_pulse.supported_dof}'
             for c in r.channels if c.scale_factor_rad_per_pulse is not None]
    if not parts:
        return ''
    return ('degrees of freedom (hand-off scale_factor_rad_per_pulse_dof): '
            + ', '.join(parts))
