"""A whole multiposition calibration of one recording (docs/methods.md §G).

Static intervals (§G.1) → accelerometer from gravity (§G.2) → gravity directions → gyro
bias, scale and misalignment from the motions (§G.3) → the conditioning statement (§G.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gyro_calib.multiposition.accelerometer import MIN_POSES, calibrated, fit_accelerometer
from gyro_calib.multiposition.gyroscope import MIN_MOTIONS, directions, fit_gyro
from gyro_calib.multiposition.recording import Array, Recording
from gyro_calib.multiposition.records import TriadFit, misalignment_matrix
from gyro_calib.multiposition.static import Detection, detect_static


@dataclass(frozen=True, slots=True)
class MultipositionResult:
    """The calibration of one recording.

    Attributes:
        detection: the static intervals used and rejected.
        accelerometer: its fit (None: too few poses, see ``problem``).
        gyro: its fit (None: too few motions or no accelerometer).
        gravity_m_s2: g used.
        gravity_std_m_s2: its standard uncertainty.
        conditioning: the conditioning statement, one line per sensor.
        problem: why a fit is missing, '' when both are there.
        directions: each pose's gravity direction (K×3, unit; from the calibrated
            accelerometer, from the raw means before it is calibrated).
        lacking: what the pose set still lacks to be well-conditioned (§G.5 criterion;
            empty: well-conditioned).
    """

    detection: Detection
    accelerometer: TriadFit | None
    gyro: TriadFit | None
    gravity_m_s2: float
    gravity_std_m_s2: float
    conditioning: tuple[str, ...]
    problem: str = ''
    directions: Array = field(default_factory=lambda: np.zeros((0, 3)))
    lacking: tuple[str, ...] = ()

    @property
    def well_conditioned(self) -> bool:
        """Both sensors calibrated and the pose set meets the §G.5 criterion."""
        return not self.lacking


def _direction_sensitivity(p: Array, means: Array) -> Array:
    """∂vec(u)/∂θ_a (3K × 9) by central differences."""
    out = np.empty((means.size, len(p)))
    for j in range(len(p)):
        h = 1e-6 * max(abs(p[j]), 1e-3 if j < 3 else 1e-9)
        dp = np.zeros(len(p))
        dp[j] = h
        out[:, j] = (directions(calibrated(p + dp, means))
                     - directions(calibrated(p - dp, means))).ravel() / (2 * h)
    return out


def pose_spread(u: Array) -> Array:
    """Eigenvalues of (1/K)Σ u_k u_kᵀ, ascending: ⅓ each for poses spread over the sphere."""
    return np.asarray(np.linalg.eigvalsh(u.T @ u / len(u)))


AXIS_NAMES = ('+x', '−x', '+y', '−y', '+z', '−z')
"""The six directions a pose set should hold gravity near (§G.5)."""


def directions_not_held(u: Array, within_deg: float = 35.0) -> list[str]:
    """The axis directions no pose's gravity direction came near (§G.5).

    ±x, ±y, ±z not within ``within_deg`` of any pose's u: where to turn the IMU next.
    """
    axes = np.vstack((np.eye(3), -np.eye(3)))[[0, 3, 1, 4, 2, 5]]
    cos = np.cos(np.radians(within_deg))
    hit = [bool(np.any(u @ axis >= cos)) if len(u) else False for axis in axes]
    return [name for name, h in zip(AXIS_NAMES, hit, strict=True) if not h]


def direction_held(u: Array, within_deg: float = 35.0) -> str:
    """The axis direction (±x, ±y, ±z) one gravity direction lies within ``within_deg`` of.

    '' when it lies between the axes.
    """
    axes = np.vstack((np.eye(3), -np.eye(3)))[[0, 3, 1, 4, 2, 5]]
    cos = axes @ u
    i = int(np.argmax(cos))
    return AXIS_NAMES[i] if cos[i] >= np.cos(np.radians(within_deg)) else ''


MAX_CONDITION = 20.0
"""Default largest cond(JᵀJ) of a well-conditioned fit (§G.5): the real recordings give
5–17 (docs/multiposition.md); a set of 12–13 random poses gives 50–80."""


HARD_CONDITION = 1e6
"""Largest cond(JᵀJ) (columns normalised) at which a fit's numbers are reported (§G.5).

Beyond it the poses do not determine the fit: u of the weakest direction is ≥ 10³ × that of a
well-posed fit, the first-order uncertainty (§G.4) no longer describes the solution (a Ferraris
session without its sections gives 2e11: misalignments of 9088°), and that sensor (with the
gyro, which rests on the accelerometer) is not measured. 5·10⁴ × the well-conditioned default."""


def undetermined(sensor: str, fit: TriadFit, gone: list[str]) -> str:
    """Why a fit beyond :data:`HARD_CONDITION` is not reported, and what to record (§G.5)."""
    where = ', '.join(gone) if gone else 'each of ±x, ±y, ±z'
    return (f'the poses do not determine the {sensor}: cond(JᵀJ) = {fit.condition:.3g} > '
            f'{HARD_CONDITION:g}, where its solution is numerically meaningless (§G.5)'
            + (f'; gravity never came near {", ".join(gone)}' if gone else '')
            + f'. Record poses with gravity near {where}, turned about every axis.')


def lacking(k: int, u: Array, fits: tuple[TriadFit | None, TriadFit | None],
            max_condition: float = MAX_CONDITION) -> tuple[str, ...]:
    """What the pose set still lacks to be well-conditioned (§G.5 criterion); () when not.

    Well-conditioned: both sensors calibrated (≥ 12 poses, ≥ 9 turns), gravity has lain
    within 35° of each of ±x, ±y, ±z, and cond(JᵀJ) of each fit ≤ ``max_condition``.
    """
    acc, gyro = fits
    out = []
    if acc is None:
        out.append(f'{MIN_POSES - k} more static poses (the accelerometer needs {MIN_POSES})')
    elif gyro is None and k < MIN_MOTIONS + 1:
        out.append(f'{MIN_MOTIONS + 1 - k} more static poses (the gyro needs {MIN_MOTIONS} '
                   'turns between poses)')
    gone = directions_not_held(u)
    if gone:
        out.append(f'a pose with gravity near {", ".join(gone)}')
    for fit in fits:
        if fit is not None and not fit.condition <= max_condition:
            out.append(f'{fit.sensor} cond(JᵀJ) = {fit.condition:.3g} > {max_condition:g} '
                       '(more poses, spread over the sphere, turns about every axis)')
    return tuple(out)


def rotation_per_axis_deg(rec: Recording, fit: TriadFit) -> Array:
    """Σ|ω_j|·dt per calibrated gyro axis over the whole recording, °."""
    w = (rec.gyro - fit.bias_raw) @ fit.matrix.T
    dt = np.diff(rec.t_s, append=rec.t_s[-1])
    return np.asarray(np.degrees(np.abs(w).T @ dt))


def calibrate(rec: Recording, *, gravity_m_s2: float, gravity_std_m_s2: float,
              window_s: float = 1.0, min_static_s: float = 1.0,
              max_condition: float = MAX_CONDITION) -> MultipositionResult:
    """Calibrate accelerometer and gyro of one recording (§G)."""
    det = detect_static(rec.t_s, rec.acc, rec.gyro, window_s=window_s,
                        min_static_s=min_static_s)
    k = len(det.intervals)
    means = np.array([rec.acc[iv.start:iv.stop].mean(axis=0) for iv in det.intervals]
                     ).reshape(-1, 3)
    if k < MIN_POSES:
        raw_u = directions(means) if k else np.zeros((0, 3))
        return MultipositionResult(det, None, None, gravity_m_s2, gravity_std_m_s2, (),
                                   f'{k} static poses found; the accelerometer needs at least '
                                   f'{MIN_POSES} (turn the IMU to more poses, at rest '
                                   'a few seconds each).', raw_u,
                                   lacking(k, raw_u, (None, None), max_condition))
    acc = fit_accelerometer(means, gravity_m_s2, gravity_std_m_s2, raw_unit=rec.acc_unit)
    u = directions(calibrated(acc.values, means))
    spread = pose_spread(u)
    gone = directions_not_held(u)
    acc_line = (f'accelerometer: {k} poses, gravity-direction spread {spread[0]:.2f} / '
                f'{spread[1]:.2f} / {spread[2]:.2f} (⅓ each ideal)'
                + (f', gravity never near {", ".join(gone)}' if gone else '')
                + f'; {acc.weak}')
    if not acc.condition <= HARD_CONDITION:
        return MultipositionResult(det, None, None, gravity_m_s2, gravity_std_m_s2, (acc_line,),
                                   undetermined('accelerometer', acc, gone)
                                   + ' (The gyro fit rests on it.)',
                                   u, lacking(k, u, (acc, None), max_condition))
    if k - 1 < MIN_MOTIONS:
        return MultipositionResult(det, acc, None, gravity_m_s2, gravity_std_m_s2, (acc_line,),
                                   f'{k - 1} motions; the gyro needs at least {MIN_MOTIONS}.',
                                   u, lacking(k, u, (acc, None), max_condition))
    gyro = fit_gyro(rec.t_s, rec.gyro, det.intervals, u,
                    _direction_sensitivity(acc.values, means), acc.covariance,
                    float(acc.n_used - 9), nominal_scale=rec.nominal_gyro_scale,
                    raw_unit=rec.gyro_unit)
    turned = rotation_per_axis_deg(rec, gyro)
    gyro_line = (f'gyro: {gyro.n_used} motions, turned {turned[0]:.0f}° / {turned[1]:.0f}° / '
                 f'{turned[2]:.0f}° about x / y / z; {gyro.weak}')
    if not gyro.condition <= HARD_CONDITION:
        return MultipositionResult(det, acc, None, gravity_m_s2, gravity_std_m_s2,
                                   (acc_line, gyro_line), undetermined('gyro', gyro, gone), u,
                                   lacking(k, u, (acc, gyro), max_condition))
    return MultipositionResult(det, acc, gyro, gravity_m_s2, gravity_std_m_s2,
                               (acc_line, gyro_line), '', u,
                               lacking(k, u, (acc, gyro), max_condition))


def inverse_scale(fit: TriadFit) -> tuple[Array, Array]:
    """1/s per axis (raw unit per SI unit, IMU-TK's 'inverse scale') and its u."""
    s = np.diag(fit.scale)
    idx = [fit.names.index(f'scale_{a}') for a in 'xyz']
    return 1 / s, fit.std[idx] / s ** 2


def misalignment_deg(fit: TriadFit) -> dict[str, tuple[float, float]]:
    """Each misalignment angle and its u, °."""
    return {n: (math.degrees(fit.values[i]), math.degrees(fit.std[i]))
            for i, n in enumerate(fit.names) if n.startswith('misalignment')}


__all__ = ['HARD_CONDITION', 'MAX_CONDITION', 'MultipositionResult', 'calibrate',
           'direction_held', 'inverse_scale', 'lacking', 'misalignment_deg',
           'misalignment_matrix', 'pose_spread', 'undetermined']
