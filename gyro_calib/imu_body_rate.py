"""A gyro triad's calibrated body rate and its covariance (METHODS §F.6 eqs. (16)–(18)).

Between two samples of the three cumulative counts n(t₀), n(t₁) (``/imu/pulses``, channels
in the order of the hand-off's ``imu.channels``) the body rate is

    ω_B = M·ṅ − b,   ṅ = (n(t₁) − n(t₀))/Δt                                  (§F.6 eq. (16))

with M (``pulses_to_body_rad``) and b (``bias_rad_s``) of the ``imu:`` section
(:mod:`gyro_calib.imu_calibration`). Its 3×3 covariance, first order (GUM), sums three
independent sources (§F.6 eq. (17)):

    C_ω = M·C_ṅ·Mᵀ + J·C_M·Jᵀ + C_b,   J = I₃ ⊗ ṅᵀ  (3×9; vec(M) row-major)
    C_ṅ = diag( N_i²/(K_i²·Δt) + 1/(6·Δt²) )       count-rate noise, pulses²/s²

N_i the channel's angle random walk (``imu.noise.<channel>.angle_random_walk_rad_per_sqrt_s``,
else the noise run's ``gyro.imu_gyro_<axis>_…``, else its 2σ upper bound, 0 when absent),
K_i = 1/|r_i| with R = M⁻¹ (the channel's scale factor), 1/6 pulse² the
quantisation of a count difference (±½ pulse uniform at each end), C_M the section's
``pulses_to_body_rad_covariance`` and C_b = diag(u²(b)). :func:`equal_variances` is the form
for consumers that use one variance for all axes (§F.6 eq. (18)).

:func:`load_imu_calibration` reads a format-4 hand-off file's ``imu:`` section.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from gyro_calib.imu_calibration import (
    ImuCalibration,
    ImuSectionError,
    imu_from_section,
    with_channel_noise,
)

Array = npt.NDArray[np.float64]

IMU_FORMAT_VERSION = 4
"""The hand-off format that holds an ``imu:`` section."""

QUANTISATION_VARIANCE_PULSES2 = 1.0 / 6.0
"""Variance of a count difference from ±½-pulse rounding at both ends, pulse²."""


def load_imu_calibration(path: str | Path) -> ImuCalibration:
    """The ``imu:`` section of a format-4 hand-off file, its noise from both places.

    A channel's noise keys not in ``imu.noise`` are taken from the noise run's
    ``gyro.imu_gyro_<axis>_…`` keys (:func:`~gyro_calib.imu_calibration.channel_noise`, the
    rule ``gyro-calib export`` reads them by).

    Raises:
        ImuSectionError: one line naming the file and what is wrong (unreadable, not YAML,
            not format 4, no ``imu:`` section, or a malformed section).
    """
    import yaml

    path = Path(path)
    try:
        data: Any = yaml.safe_load(path.read_text(encoding='utf-8'))
    except OSError as exc:
        raise ImuSectionError(f'cannot read calibration file {path}: '
                              f'{exc.strerror or exc}.') from None
    except UnicodeDecodeError as exc:
        raise ImuSectionError(f'calibration file {path} is not UTF-8 text: {exc.reason}.') \
            from None
    except yaml.YAMLError as exc:
        reason = ' '.join(str(exc).split())
        raise ImuSectionError(f'calibration file {path} is not valid YAML: {reason}.') from None
    if not isinstance(data, dict) or 'imu' not in data:
        raise ImuSectionError(f'calibration file {path} has no imu: section (a triad '
                              'hand-off, format_version 4).')
    version = data.get('format_version')
    if version != IMU_FORMAT_VERSION:
        raise ImuSectionError(f'calibration file {path} has an imu: section but format_version '
                              f'{version!r}; an imu: section is format_version '
                              f'{IMU_FORMAT_VERSION}.')
    gyro = data.get('gyro')
    return with_channel_noise(imu_from_section(data['imu'], source=f'calibration file {path}'),
                              gyro if isinstance(gyro, dict) else {})


def has_imu_section(path: str | Path) -> bool:
    """Whether the file is a YAML mapping with an ``imu:`` key (False if unreadable)."""
    import yaml

    try:
        data = yaml.safe_load(Path(path).read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(data, dict) and 'imu' in data


@dataclass(frozen=True, slots=True)
class TriadRateModel:
    """What the body-rate conversion needs from the ``imu:`` section, SI.

    Attributes:
        channels: the channel names in row order of M.
        m: M, 3×3, rad/pulse.
        m_covariance: 9×9 covariance of vec(M) (row-major), (rad/pulse)².
        bias_rad_s: b (3,), body frame, rad/s (zeros when not measured).
        bias_std: u(b) (3,), rad/s.
        bias_known: the section holds ``bias_rad_s``.
        scale_factor_rad_per_pulse: K_i = 1/|r_i|, R = M⁻¹ (3,).
        arw_rad_per_sqrt_s: N_i per channel (3,), 0 where not measured.
        rounding_variance_pulses2: the variance a count difference gets from rounding, per
            channel (3,), pulse²; None: 1/6 (a pulse triad's integer counts). An IMU's
            section (``imu.accelerometer``: the driver's rates, one "pulse" = one raw unit·s)
            has no count rounding: 2·(Q_i/K_i)², Q_i the channel's angle quantisation noise
            where the noise run gives it (or its 2σ bound), else 0 (METHODS §E.5 eq. (16)).
    """

    channels: tuple[str, str, str]
    m: Array
    m_covariance: Array
    bias_rad_s: Array
    bias_std: Array
    bias_known: bool
    scale_factor_rad_per_pulse: Array
    arw_rad_per_sqrt_s: Array
    rounding_variance_pulses2: Array | None = None


def triad_rate_model(cal: ImuCalibration, *, source: str = 'hand-off') -> TriadRateModel:
    """The conversion's inputs from a read ``imu:`` section.

    Raises:
        ImuSectionError: the section has no M (``pulses_to_body_rad``), with its reason.
    """
    if cal.pulses_to_body_rad is None or cal.pulses_to_body_rad_covariance is None:
        why = cal.not_measurable.get('pulses_to_body_rad') or cal.missing.get(
            'pulses_to_body_rad') or 'not in the file'
        raise ImuSectionError(f'{source}: imu.pulses_to_body_rad (M) is needed for body rates '
                              f'and is absent: {why}')
    m = np.asarray(cal.pulses_to_body_rad, dtype=float)
    k = 1.0 / np.linalg.norm(np.linalg.inv(m), axis=1)
    arw = np.array([channel_arw(cal.noise.get(c, {})) for c in cal.channels])
    known = cal.bias_rad_s is not None and cal.bias_rad_s_std is not None
    return TriadRateModel(
        cal.channels, m, np.asarray(cal.pulses_to_body_rad_covariance, dtype=float),
        np.asarray(cal.bias_rad_s, dtype=float) if known else np.zeros(3),
        np.asarray(cal.bias_rad_s_std, dtype=float) if known else np.zeros(3),
        known, k, arw, rounding_variances(cal, k))


def rounding_variances(cal: ImuCalibration, scale_factor_rad_per_pulse: Array
                       ) -> Array | None:
    """Per channel, the rounding variance of a count difference, pulse² (None: 1/6 each).

    A pulse triad's counts are integers (None). An IMU's section (``imu.accelerometer``, a
    multiposition calibration) reads the driver's rates: 2·(Q_i/K_i)², Q_i the channel's
    angle quantisation noise (measured, else its 2σ bound, else 0; METHODS §E.5 eq. (16)).
    """
    if not cal.accelerometer:
        return None
    q = np.array([channel_quantisation(cal.noise.get(c, {})) for c in cal.channels])
    return np.asarray(2.0 * (q / np.asarray(scale_factor_rad_per_pulse, dtype=float)) ** 2,
                      dtype=float)


def channel_arw(noise: dict[str, float]) -> float:
    """N of one channel: its measured value, else its 2σ upper bound (METHODS §E.3), else 0."""
    key = 'angle_random_walk_rad_per_sqrt_s'
    return float(noise.get(key, noise.get(key + '_upper_bound_2sigma', 0.0)))


def channel_quantisation(noise: dict[str, float]) -> float:
    """Q of one channel, rad: its measured value, else its 2σ upper bound, else 0."""
    key = 'quantization_noise_rad'
    return float(noise.get(key, noise.get(key + '_upper_bound_2sigma', 0.0)))


def count_rate_variances(dt_s: float, scale_factor_rad_per_pulse: Array,
                         arw_rad_per_sqrt_s: Array,
                         rounding_variance_pulses2: Array | None = None) -> Array:
    """The diagonal of C_ṅ, §F.6 eq. (17): N_i²/(K_i²·Δt) + 1/(6·Δt²) per channel, pulses²/s².

    ``rounding_variance_pulses2`` replaces the 1/6 pulse² of integer counts (an IMU's
    section: :class:`TriadRateModel`).
    """
    arw_pulses = np.asarray(arw_rad_per_sqrt_s, dtype=float) / np.asarray(
        scale_factor_rad_per_pulse, dtype=float)
    rounding = (np.full(3, QUANTISATION_VARIANCE_PULSES2) if rounding_variance_pulses2 is None
                else np.asarray(rounding_variance_pulses2, dtype=float))
    return np.asarray(arw_pulses**2 / dt_s + rounding / dt_s**2, dtype=float)


def body_rate_covariance(count_rate: Array, m: Array, m_covariance: Array,
                         count_rate_variances: Array, bias_covariance: Array) -> Array:
    """C_ω = M·C_ṅ·Mᵀ + J·C_M·Jᵀ + C_b, J = I₃ ⊗ ṅᵀ (METHODS §F.6 eq. (17)), (rad/s)².

    Args:
        count_rate: ṅ (3,), pulses/s.
        m: M (3×3), rad/pulse.
        m_covariance: covariance of vec(M), row-major (9×9).
        count_rate_variances: diag C_ṅ (3,), pulses²/s² (channels independent).
        bias_covariance: C_b (3×3), (rad/s)².
    """
    n_dot = np.asarray(count_rate, dtype=float).reshape(3)
    jac = np.kron(np.eye(3), n_dot[None, :])
    c = (m @ np.diag(count_rate_variances) @ m.T + jac @ m_covariance @ jac.T
         + np.asarray(bias_covariance, dtype=float))
    return np.asarray(0.5 * (c + c.T), dtype=float)


def body_rate(counts0: Array, counts1: Array, dt_s: float, model: TriadRateModel, *,
              bias_rad_s: Array | None = None, bias_covariance: Array | None = None
              ) -> tuple[Array, Array]:
    """ω_B = M·Δn/Δt − b (§F.6 eq. (16)) and its covariance (eq. (17)).

    Args:
        counts0: the three counts at the earlier sample, channel order of ``model``.
        counts1: the three counts at the later sample.
        dt_s: t₁ − t₀ > 0, s.
        model: M, its covariance, b, noise (:func:`triad_rate_model`).
        bias_rad_s: a bias to use instead of the model's (thermal), rad/s.
        bias_covariance: its 3×3 covariance, (rad/s)².
    """
    n_dot = (np.asarray(counts1, dtype=float) - np.asarray(counts0, dtype=float)) / dt_s
    b = model.bias_rad_s if bias_rad_s is None else bias_rad_s
    c_b = np.diag(model.bias_std**2) if bias_covariance is None else bias_covariance
    omega = model.m @ n_dot - b
    cov = body_rate_covariance(
        n_dot, model.m, model.m_covariance,
        count_rate_variances(dt_s, model.scale_factor_rad_per_pulse, model.arw_rad_per_sqrt_s,
                             model.rounding_variance_pulses2),
        c_b)
    return np.asarray(omega, dtype=float), cov


def equal_variances(covariance: Array) -> Array:
    """The largest variance on every axis, off-diagonals 0 (§F.6 eq. (18)).

    For consumers that take one variance for all axes (Autoware's imu_corrector): the
    published diagonal is then never below any axis's own variance.
    """
    c = np.asarray(covariance, dtype=float)
    return np.asarray(np.eye(3) * float(np.max(np.diag(c))), dtype=float)


def bias_with_channel_biases(model: TriadRateModel,
                             channel_bias: dict[int, tuple[float, float]]
                             ) -> tuple[Array, Array]:
    """The bias b and C_b with some channels' biases replaced (thermal models; §F.6 eq. (19)).

    The section's body-frame b is taken to count rates β = R·b (R = M⁻¹, pulses/s), with
    C_β = R·C_b·Rᵀ; channel i's β_i and its variance (row and column) are replaced by
    ``channel_bias[i]`` = (β_i, u(β_i)) in pulses/s, and b = M·β, C_b = M·C_β·Mᵀ. Channels
    not replaced keep exactly the section's b and C_b.
    """
    r = np.linalg.inv(model.m)
    beta = r @ model.bias_rad_s
    c_beta = r @ np.diag(model.bias_std**2) @ r.T
    for i, (value, std) in channel_bias.items():
        beta[i] = value
        c_beta[i, :] = 0.0
        c_beta[:, i] = 0.0
        c_beta[i, i] = std * std
    return (np.asarray(model.m @ beta, dtype=float),
            np.asarray(model.m @ c_beta @ model.m.T, dtype=float))
