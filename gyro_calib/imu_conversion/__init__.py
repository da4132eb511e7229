"""Pulse counts → calibrated angular rate with its variance, for sensor_msgs/Imu.

Between two samples of the cumulative count, (t₀, n₀) and (t₁, n₁), the rate about the
gyro's sense axis is

    ω = K·(n₁ − n₀)/(t₁ − t₀) − b                                              (1)

with K the scale factor (rad/pulse) and b the bias (rad/s) of the hand-off file
(:mod:`gyro_calib.handoff`, taken by :func:`pulse_calibration`). Its variance sums
independent terms (GUM, first order):

    u²(ω) = N²/Δt                angle random walk N (rad/√s) over Δt: white rate noise
          + K²/(6·Δt²)           quantisation: each count is the true angle/K rounded to
                                 a whole pulse, uniform in ±½ pulse (variance 1/12 pulse²)
                                 at each end, independent → 1/6 pulse² for the difference
          + (ω + b)²·u²(K)/K²    scale-factor uncertainty, relative, on the measured rate
          + u²(b)                bias uncertainty                                     (2)

An absent angle random walk contributes nothing (the quantisation term then stands for
the noise; for a rate-biased RLG at 1 kHz it is the larger one by orders of magnitude).

A FOG (its hand-off has ``fog_scale_factor_counts_per_rad`` or the self-calibrated
``fog_self_cal_scale_factor_counts_per_rad`` and no pulse-gyro K; METHODS §B) is converted
the same way with K = 1/SF rad/count, u(K) = u(SF)/SF², the count's quantisation as above,
and its scale-factor model (:func:`fog_pulse_calibration` says which SF applies and why):

    ω = (K·Δn/Δt − b) / (1 + sgn·a/2)        asymmetry a = 2(K₊ − K₋)/(K₊ + K₋), the sign
                                             that of K·Δn/Δt − b: K₊ = SF(1 + a/2) for
                                             positive rates, K₋ = SF(1 − a/2) (§B.2 eq. (7))  (3)
    u²(ω) = u²₍₂₎/(1 + sgn·a/2)² + (ω·u(a)/2)² + (NL·ω)²/3                                  (4)

NL the IEEE nonlinearity, taken as a rectangular bound ±NL·|ω| on the rate (IEEE 952
defines it relative to full-scale output, which the file does not hold: at full scale the
two agree; below it this bound is the smaller one).

Thermal compensation (METHODS §D). When the hand-off file holds a ``thermal_model``, b is
not a constant but the model's bias b(H, Ḣ, gradients) at the gyro's temperatures:
:class:`PulseRateConverter` also takes the /gyro/temperature readings, holds each pulse
sample by its stamp until the temperatures that decide its bias have arrived, and subtracts
exactly what the offline compensation subtracts for that sample (the bias of the averaging
interval holding the pair's midpoint, from the same interval means, interpolation, sensor
checks and causal Ḣ; :class:`~gyro_calib.thermal.live.OrderedThermalCompensator`), with u(b)
the model's uncertainty there — so the rates depend only on the messages and their stamps,
not on how the two topics were interleaved. K is then the file's
``scale_factor_rad_per_pulse`` (``k_tilde_rad_per_pulse`` with use_k_tilde), which must agree
with the K the model was fitted with within 100 ppm, or, without one, the model's own K
(its uncertainty unknown: u(K) = 0). A file's constant ``bias_rad_s`` is not used then: the
model holds the whole bias. Where the model cannot give a bias — no temperature, a stuck
or silent sensor, temperatures not decided within ``thermal_max_age_s`` of stamps, or a
temperature outside the calibrated range by more than the model's margin — the converter
returns a :class:`~gyro_calib.estimate.Rejection` saying so and **no rate**: an INS is better
told nothing than given a rate whose bias is an extrapolation (a variance alone would not
stop a consumer that ignores it). A model fitted on another gyro (``gyro_id``) is refused.
Consecutive rates share a count, so their quantisation errors are anticorrelated; the
per-message variance is still (2).

The gyro measures about one axis, taken as the Imu frame's z axis. x and y carry 0 with
the variance :data:`UNKNOWN_AXIS_VARIANCE_RAD2_S2`: sensor_msgs/Imu and REP 145 only
offer ``covariance[0] = -1`` to mark a *whole* field unavailable, which would also hide
z; a large, finite variance tells a filter "no information" per axis without the
infinities or NaNs (∞·0) some consumers choke on.

The modules: :mod:`~gyro_calib.imu_conversion.calibration` (what a conversion needs, its log
line), :mod:`~gyro_calib.imu_conversion.from_handoff` (the hand-off file → that),
:mod:`~gyro_calib.imu_conversion.fog_scale` (a FOG's scale factor, eqs. (3)–(4)),
:mod:`~gyro_calib.imu_conversion.rate` (one rate, eqs. (1)–(4)),
:mod:`~gyro_calib.imu_conversion.single` (the streaming single-gyro converter) and
:mod:`~gyro_calib.imu_conversion.triad` (the streaming triad converter, METHODS §F.6).
"""

from __future__ import annotations

from gyro_calib.imu_conversion.calibration import PulseCalibration, scale_factor_line
from gyro_calib.imu_conversion.fog_scale import (
    FOG_SELF_CAL_KEY,
    FOG_TURNTABLE_KEY,
    PPM,
    fog_pulse_calibration,
)
from gyro_calib.imu_conversion.from_handoff import pulse_calibration, thermal_model
from gyro_calib.imu_conversion.rate import (
    UNKNOWN_AXIS_VARIANCE_RAD2_S2,
    ImuAngularVelocity,
    angular_velocity_from_pulses,
)
from gyro_calib.imu_conversion.single import PulseRateConverter
from gyro_calib.imu_conversion.triad import TriadRateConverter, channel_thermal_models

__all__ = [
    'FOG_SELF_CAL_KEY',
    'FOG_TURNTABLE_KEY',
    'PPM',
    'UNKNOWN_AXIS_VARIANCE_RAD2_S2',
    'ImuAngularVelocity',
    'PulseCalibration',
    'PulseRateConverter',
    'TriadRateConverter',
    'angular_velocity_from_pulses',
    'channel_thermal_models',
    'fog_pulse_calibration',
    'pulse_calibration',
    'scale_factor_line',
    'thermal_model',
]
