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
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import GyroCalibError, StreamError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import Calibration, HandoffError
from gyro_calib.imu_body_rate import (
    Array,
    TriadRateModel,
    bias_with_channel_biases,
    body_rate,
    equal_variances,
)
from gyro_calib.imu_calibration import ImuCalibration, ImuSectionError

if TYPE_CHECKING:
    from gyro_calib.thermal.compensate import CompensatedPair
    from gyro_calib.thermal.live import OrderedThermalCompensator
    from gyro_calib.thermal.model import ThermalBiasModel

UNKNOWN_AXIS_VARIANCE_RAD2_S2 = 1.0e6
"""Variance of the unmeasured x and y rates, (rad/s)²: σ = 1000 rad/s, beyond any real
rotation, so any fusion filter gives those zeros no weight."""


@dataclass(frozen=True, slots=True)
class PulseCalibration:
    """What the conversion needs from the hand-off file, in SI.

    Attributes:
        scale_factor_rad_per_pulse: K (or K̃ when told to take θ = 0), rad/pulse.
        scale_factor_std: its standard uncertainty, rad/pulse.
        scale_factor_key: the hand-off key it came from.
        bias_rad_s: b, rad/s (0 when the file has none: ``bias_known`` False).
        bias_std: its standard uncertainty, rad/s.
        bias_known: the file holds ``bias_rad_s``.
        angle_random_walk_rad_per_sqrt_s: N, rad/√s (0 when the file has none).
        thermal_model: the temperature bias model (the file's ``thermal_model``), or None;
            when set, the bias comes from it live and ``bias_rad_s`` is not used.
        asymmetry: a FOG's scale-factor asymmetry a = 2(K₊ − K₋)/(K₊ + K₋) (ppm/10⁶), 0 if
            not measured; the rate is divided by 1 ± a/2 by its sign (module docstring (3)).
        asymmetry_std: its standard uncertainty (relative).
        nonlinearity: a FOG's IEEE nonlinearity NL (ppm/10⁶): a rectangular ±NL·|ω| term in
            the variance (module docstring (4)); 0 if not measured.
        scale_factor_note: which scale factor applies and why (a FOG: turntable or self-cal,
            and the run it came from), for the log; '' for a pulse gyro.
    """

    scale_factor_rad_per_pulse: float
    scale_factor_std: float
    scale_factor_key: str = 'scale_factor_rad_per_pulse'
    bias_rad_s: float = 0.0
    bias_std: float = 0.0
    bias_known: bool = False
    angle_random_walk_rad_per_sqrt_s: float = 0.0
    thermal_model: ThermalBiasModel | None = None
    asymmetry: float = 0.0
    asymmetry_std: float = 0.0
    nonlinearity: float = 0.0
    scale_factor_note: str = ''

    @property
    def is_fog(self) -> bool:
        """The scale factor is a FOG's (counts/rad, taken as K = 1/SF rad/count)."""
        return self.scale_factor_key.startswith('fog_')


def scale_factor_line(c: PulseCalibration) -> str:
    """'K = value ± std rad/pulse (from KEY)' for logs.

    'K = value ± std rad/pulse (from KEY)' for logs: the quantity is always K, with the
    hand-off key it came from (a model-borne K: the scale factor the thermal_model was
    fitted with, never 'thermal_model = … rad/pulse').
    """
    where = ('the scale factor the thermal_model was fitted with'
             if c.scale_factor_key == 'thermal_model' else c.scale_factor_key)
    if c.is_fog:
        sf = 1.0 / c.scale_factor_rad_per_pulse
        sf_std = c.scale_factor_std * sf * sf
        return (f'SF = {sf!r} ± {sf_std!r} counts/rad (from {where}; K = 1/SF = '
                f'{c.scale_factor_rad_per_pulse!r} rad/count)')
    name = 'K̃' if c.scale_factor_key == 'k_tilde_rad_per_pulse' else 'K'
    return (f'{name} = {c.scale_factor_rad_per_pulse!r} ± {c.scale_factor_std!r} rad/pulse '
            f'(from {where})')


def pulse_calibration(calibration: Calibration, *, use_k_tilde: bool = False,
                      gyro_id: str = '') -> PulseCalibration:
    """The scale factor, bias (or thermal bias model) and ARW the conversion uses.

    Args:
        calibration: the hand-off file's content.
        use_k_tilde: take K̃ as the scale factor (θ = 0: a gyro whose fix-error angle was not
            measured); otherwise K = K̃·cos θ is required (or, with a thermal model, the K
            the model was fitted with). A FOG's file (no such key, but a FOG scale factor)
            goes to :func:`fog_pulse_calibration` instead.
        gyro_id: the gyro this conversion is for ('' = not checked): a thermal model fitted
            on another gyro is refused.

    Raises:
        HandoffError: naming the missing key (``scale_factor_rad_per_pulse``, or
            ``k_tilde_rad_per_pulse`` with ``use_k_tilde``), or a K that disagrees with the
            thermal model's.
        GyroCalibError (ModelFileError, ModelMismatchError): an invalid thermal model, or
            one of another gyro.
    """
    if use_k_tilde:
        key, why = 'k_tilde_rad_per_pulse', 'imu_corrector was told to use K̃ with θ = 0'
    else:
        key, why = 'scale_factor_rad_per_pulse', (
            'K = K̃·cos θ needs the fix-error angle θ; set use_k_tilde to take K̃ with θ = 0')
    arw = calibration.measured('angle_random_walk_rad_per_sqrt_s')
    arw_value = arw[0] if arw else 0.0
    model = thermal_model(calibration, gyro_id=gyro_id)
    if model is not None:
        got = calibration.measured(key)
        k_model = model.scale_factor_rad_per_pulse
        if got is None:
            for other in ('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'):
                beside = calibration.measured(other)
                if beside is not None and abs(beside[0] / k_model - 1.0) > 1e-4:
                    raise HandoffError(
                        f'the calibration\'s {other} = {beside[0]!r} rad/pulse differs from the '
                        f'{k_model!r} rad/pulse its thermal_model was fitted with by '
                        f'{abs(beside[0] / k_model - 1.0) * 1e6:.0f} ppm: the file mixes two '
                        'scale factors (another gyro, or a model fitted with a spec-sheet K); '
                        'refit the thermal model with this K (--calibration FILE).')
            return PulseCalibration(k_model, 0.0, 'thermal_model', 0.0, 0.0, True, arw_value,
                                    model)
        if abs(got[0] / k_model - 1.0) > 1e-4:
            raise HandoffError(
                f'the calibration\'s {key} = {got[0]!r} rad/pulse differs from the '
                f'{k_model!r} rad/pulse its thermal_model was fitted with by more than 100 ppm: '
                'the model\'s bias belongs to that K. Refit the thermal model with this K.')
        return PulseCalibration(got[0], got[1], key, 0.0, 0.0, True, arw_value, model)
    if calibration.measured(key) is None and any(
            calibration.measured(k) is not None for k in (FOG_TURNTABLE_KEY, FOG_SELF_CAL_KEY)):
        return fog_pulse_calibration(calibration)
    k, k_std = calibration.require(key, why=why)
    bias = calibration.measured('bias_rad_s')
    return PulseCalibration(k, k_std, key, bias[0] if bias else 0.0, bias[1] if bias else 0.0,
                            bias is not None, arw_value)


FOG_TURNTABLE_KEY = 'fog_scale_factor_counts_per_rad'
"""A FOG's turntable scale factor (IEEE 952 line fit against the table rates; METHODS §B.2)."""
FOG_SELF_CAL_KEY = 'fog_self_cal_scale_factor_counts_per_rad'
"""A FOG's ladder-wave self-calibrated scale factor (METHODS §B.4)."""
PPM = 1e-6


def fog_pulse_calibration(calibration: Calibration) -> PulseCalibration:
    """A FOG's hand-off as a pulse conversion: K = 1/SF rad/count (module docstring (3)).

    Which SF applies: the turntable's (``fog_scale_factor_counts_per_rad``) whenever the
    file has it — it is measured against the table's rates, and the self-calibrated one is
    anchored to the equivalence mapping and is its check (§B.4, ΔK); otherwise the
    self-calibrated one (``fog_self_cal_scale_factor_counts_per_rad``), valid within its
    linear range. With the turntable SF, its asymmetry (``fog_asymmetry_ppm``) is applied and
    its nonlinearity (``fog_nonlinearity_ppm``) enters the variance; with the self-cal SF,
    ``fog_self_cal_nonlinearity_ppm``. The polynomial coefficients
    (``fog_scale_factor_quadratic_s_per_rad``, ``…_cubic_…``) are not applied: they come from
    a separate fit (§B.2 eq. (8)) whose K₁ and intercept differ from the line's, so mixing them
    with SF and the bias would be inconsistent; NL bounds what they describe. The bias is
    ``fog_bias_rad_s`` (the Earth rate removed); ARW the noise method's
    ``angle_random_walk_rad_per_sqrt_s``, else ``fog_angle_random_walk_rad_per_sqrt_s``.
    """
    turntable = calibration.measured(FOG_TURNTABLE_KEY)
    self_cal = calibration.measured(FOG_SELF_CAL_KEY)
    run = _run_phrase(calibration, FOG_TURNTABLE_KEY if turntable else FOG_SELF_CAL_KEY)
    if turntable is not None:
        key, (sf, sf_std) = FOG_TURNTABLE_KEY, turntable
        asym = calibration.measured('fog_asymmetry_ppm') or (0.0, 0.0)
        nl = calibration.measured('fog_nonlinearity_ppm') or (0.0, 0.0)
        note = (f'the turntable scale factor applies ({run}): it is measured against the '
                'table\'s rates (IEEE 952, METHODS §B.2)')
        diff = calibration.measured('fog_self_cal_minus_turntable_scale_factor_counts_per_rad')
        if self_cal is not None:
            note += ('; the self-calibrated one is anchored to the equivalence mapping and is '
                     'its check' + (f' (it differs by {diff[0]:+.6g} ± {diff[1]:.2g} counts/rad)'
                                    if diff else ''))
        if asym[0]:
            note += f'; asymmetry {asym[0]:g} ppm applied by the sign of the rate'
    else:
        assert self_cal is not None
        key, (sf, sf_std) = FOG_SELF_CAL_KEY, self_cal
        asym = (0.0, 0.0)
        nl = calibration.measured('fog_self_cal_nonlinearity_ppm') or (0.0, 0.0)
        span = calibration.measured('fog_self_cal_linear_range_rad_s')
        note = (f'the self-calibrated scale factor applies ({run}): the file has no turntable '
                'scale factor; it holds within its linear range'
                + (f' |ω| ≤ {span[0]:.4g} rad/s' if span else '')
                + ' (beyond it the loop\'s front end leaves its small-signal region, '
                'METHODS §B.4)')
    if nl[0]:
        note += f'; nonlinearity {nl[0]:g} ppm in the variance'
    if sf <= 0.0:
        raise HandoffError(f'the calibration\'s {key} = {sf!r} counts/rad is not > 0.')
    bias = calibration.measured('fog_bias_rad_s')
    arw = (calibration.measured('angle_random_walk_rad_per_sqrt_s')
           or calibration.measured('fog_angle_random_walk_rad_per_sqrt_s'))
    return PulseCalibration(
        1.0 / sf, sf_std / (sf * sf), key, bias[0] if bias else 0.0, bias[1] if bias else 0.0,
        bias is not None, arw[0] if arw else 0.0, None, asym[0] * PPM, asym[1] * PPM,
        nl[0] * PPM, note)


def _run_phrase(calibration: Calibration, key: str) -> str:
    """'run SOURCE of CREATED' of the run that gave ``key`` (or 'run unknown')."""
    from gyro_calib.registry import handoff_schema

    try:
        run = calibration.source_of(key, handoff_schema())
    except (KeyError, GyroCalibError):
        run = None
    return 'run unknown' if run is None else f'from run {run.label()}'


def thermal_model(calibration: Calibration, *, gyro_id: str = '') -> ThermalBiasModel | None:
    """The file's ``thermal_model`` (None without one), checked to belong to the gyro.

    Raises:
        ModelFileError: the mapping is not a valid model.
        ModelMismatchError: the model names another gyro than the file or ``gyro_id``.
    """
    data = calibration.get('thermal_model')
    if data is None:
        return None
    from gyro_calib.thermal.errors import ModelMismatchError
    from gyro_calib.thermal.model import ThermalBiasModel

    model = ThermalBiasModel.from_dict(data, source='the thermal_model of the calibration')
    if calibration.gyro_id and model.gyro_id and calibration.gyro_id != model.gyro_id:
        raise ModelMismatchError(
            f'the calibration file is for gyro {calibration.gyro_id!r} but its thermal_model was '
            f'fitted on gyro {model.gyro_id!r}: the file is inconsistent; recalibrate.')
    for known in (gyro_id, calibration.gyro_id):
        model.check_gyro(known)
    return model


@dataclass(frozen=True, slots=True)
class ImuAngularVelocity:
    """The angular_velocity part of one sensor_msgs/Imu.

    Attributes:
        stamp_ns: header stamp, the later sample's stamp, int ns.
        angular_velocity_rad_s: (x, y, z) in the Imu frame, rad/s; z is the sense axis.
        covariance_rad2_s2: 3×3 covariance, row-major (9 values), (rad/s)².
    """

    stamp_ns: int
    angular_velocity_rad_s: tuple[float, float, float]
    covariance_rad2_s2: tuple[float, ...]


def angular_velocity_from_pulses(t0_ns: int, count0: float, t1_ns: int, count1: float,
                                 calibration: PulseCalibration) -> ImuAngularVelocity:
    """Calibrated sense-axis rate and covariance from two count samples, eqs. (1) and (2).

    Args:
        t0_ns: stamp of the earlier sample, int ns.
        count0: cumulative pulse count at ``t0_ns``, pulses.
        t1_ns: stamp of the later sample, int ns (> ``t0_ns``).
        count1: cumulative pulse count at ``t1_ns``, pulses.
        calibration: K, bias and ARW (:func:`pulse_calibration`).

    Returns:
        The rate about x, y, z (z = sense axis) at ``t1_ns`` and its covariance.

    Raises:
        StreamError: if ``t1_ns <= t0_ns``.
    """
    c = calibration
    k, k_std = c.scale_factor_rad_per_pulse, c.scale_factor_std
    if t1_ns <= t0_ns:
        raise StreamError(f'stamps must increase: t1_ns = {t1_ns} <= t0_ns = {t0_ns}.')
    dt_s = (t1_ns - t0_ns) / 1e9
    measured_rad_s = k * (count1 - count0) / dt_s
    arw = c.angle_random_walk_rad_per_sqrt_s
    variance = (arw * arw / dt_s
                + k * k / (6.0 * dt_s * dt_s)
                + (measured_rad_s * k_std / k) ** 2
                + c.bias_std ** 2)
    rate = measured_rad_s - c.bias_rad_s
    if c.asymmetry or c.nonlinearity:  # a FOG's scale-factor model, eqs. (3) and (4)
        half = math.copysign(0.5, rate) * c.asymmetry
        rate /= 1.0 + half
        variance = (variance / (1.0 + half) ** 2 + (0.5 * rate * c.asymmetry_std) ** 2
                    + (c.nonlinearity * rate) ** 2 / 3.0)
    u = UNKNOWN_AXIS_VARIANCE_RAD2_S2
    return ImuAngularVelocity(
        stamp_ns=t1_ns,
        angular_velocity_rad_s=(0.0, 0.0, rate),
        covariance_rad2_s2=(u, 0.0, 0.0, 0.0, u, 0.0, 0.0, 0.0, variance))


class PulseRateConverter:
    """Streaming form of :func:`angular_velocity_from_pulses` for a node.

    Feed messages in arrival order (:meth:`add_pulse`, :meth:`add_temperature`); each call
    returns the rates (or :class:`Rejection` s) it releases, in pulse stamp order. Each
    sample after the first gives the rate since the one before. Skipped (a Rejection, no
    rate):

    * a non-finite count — the previous sample stays the reference;
    * a stamp not after the previous one — it becomes the new reference, so a source that
      restarted (stamps jumped back) is followed again from its next sample;
    * with a thermal model: a sample for which the model gives no bias (module docstring;
      the sample is still the next one's reference).

    Without a thermal model a sample's rate is released at once and temperatures are
    ignored. With one, samples are held by stamp until the temperatures that decide their
    bias have arrived, then released with the bias the offline compensation gives them,
    whatever the interleaving of the two topics
    (:class:`~gyro_calib.thermal.live.OrderedThermalCompensator`; at most
    ``thermal_max_age_s`` of stamps and a few intervals later). The calibration may be
    replaced between samples (the reference sample stays; held samples and the
    temperature history are kept when the new model reduces temperatures the same way).
    """

    def __init__(self, calibration: PulseCalibration, *, thermal_max_age_s: float = 30.0) -> None:
        """Start with no reference sample.

        Args:
            calibration: K, bias or thermal model, ARW.
            thermal_max_age_s: with a thermal model, how far (in stamp time) beyond a
                sample's averaging interval the temperatures deciding its bias may lie, s
                (:class:`~gyro_calib.thermal.live.OrderedThermalCompensator`).
        """
        self._live: OrderedThermalCompensator | None = None
        self._calibration = calibration
        self.thermal_max_age_s = thermal_max_age_s
        self._last: tuple[int, float] | None = None
        self.last_bias: tuple[float, float] | None = None
        """The thermal bias (rad/s) and its uncertainty of the latest rate released."""
        self.calibration = calibration

    @property
    def calibration(self) -> PulseCalibration:
        """The calibration in use."""
        return self._calibration

    @calibration.setter
    def calibration(self, calibration: PulseCalibration) -> None:
        model = calibration.thermal_model
        if model is None:
            self._live = None
        elif self._live is None or (
                self._live.model.averaging_interval_s, self._live.model.hdot_window_s,
                self._live.model.max_temperature_gap_s) != (
                model.averaging_interval_s, model.hdot_window_s, model.max_temperature_gap_s):
            from gyro_calib.thermal.live import OrderedThermalCompensator

            self._live = OrderedThermalCompensator(model, max_wait_s=self.thermal_max_age_s)
        else:
            self._live.model = model
        self._calibration = calibration

    @property
    def held(self) -> int:
        """Pulse samples waiting for their thermal bias."""
        return 0 if self._live is None else self._live.held

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str
                        ) -> list[ImuAngularVelocity | Rejection]:
        """One /gyro/temperature reading; the rates it releases (none without a model)."""
        if self._live is None:
            return []
        return self._convert(self._live.add_temperature(t_ns, celsius, frame_id))

    def add_pulse(self, t_ns: int, count: float) -> list[ImuAngularVelocity | Rejection]:
        """One /gyro/pulses sample; the rates (or Rejections) it releases, in stamp order."""
        if self._live is not None:
            return self._convert(self._live.add_pulse(t_ns, count))
        out = self._add_plain(t_ns, count)
        return [] if out is None else [out]

    def add(self, t_ns: int, count: float) -> ImuAngularVelocity | Rejection | None:
        """The rate since the previous sample, a Rejection saying why not, or None.

        The single-result form of :meth:`add_pulse` (None: nothing released — the first
        sample, or, with a thermal model, a sample still held).
        """
        outs = self.add_pulse(t_ns, count)
        return outs[-1] if outs else None

    def _add_plain(self, t_ns: int, count: float) -> ImuAngularVelocity | Rejection | None:
        if not math.isfinite(count):
            return Rejection(t_ns, f'pulse count {count!r} at stamp {t_ns} ns is not finite.')
        last, self._last = self._last, (t_ns, count)
        if last is None:
            return None
        if t_ns <= last[0]:
            return Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, {last[0]} '
                                   'ns; it becomes the new reference.')
        return angular_velocity_from_pulses(last[0], last[1], t_ns, count, self._calibration)

    def _convert(self, outcomes: list[CompensatedPair | Rejection]
                 ) -> list[ImuAngularVelocity | Rejection]:
        out: list[ImuAngularVelocity | Rejection] = []
        for o in outcomes:
            if isinstance(o, Rejection):
                out.append(o)
                continue
            self.last_bias = (o.bias_rad_s, o.bias_std)
            cal = dataclasses.replace(self._calibration, bias_rad_s=o.bias_rad_s,
                                      bias_std=o.bias_std)
            out.append(angular_velocity_from_pulses(o.t0_ns, o.count0, o.t1_ns, o.count1, cal))
        return out


# ------------------------------------------------------------ a gyro triad (METHODS §F.6)


def channel_thermal_models(cal: ImuCalibration, model: TriadRateModel
                           ) -> dict[str, ThermalBiasModel]:
    """The ``imu.thermal.<channel>.thermal_model`` of each channel that has one.

    Raises:
        ImuSectionError: a channel's model is invalid, or was fitted with a scale factor
            other than that channel's K_i = 1/|r_i| by more than 100 ppm.
    """
    from gyro_calib.thermal.model import ThermalBiasModel

    out: dict[str, ThermalBiasModel] = {}
    for i, channel in enumerate(model.channels):
        data = cal.thermal.get(channel, {}).get('thermal_model')
        if data is None:
            continue
        try:
            m = ThermalBiasModel.from_dict(
                data, source=f'the imu.thermal.{channel}.thermal_model of the calibration')
        except GyroCalibError as exc:
            raise ImuSectionError(str(exc)) from None
        k = float(model.scale_factor_rad_per_pulse[i])
        if abs(m.scale_factor_rad_per_pulse / k - 1.0) > 1e-4:
            raise ImuSectionError(
                f'the thermal_model of channel {channel!r} was fitted with K = '
                f'{m.scale_factor_rad_per_pulse!r} rad/pulse, but the channel\'s K (1/|row| of '
                f'M⁻¹) is {k!r}: more than 100 ppm apart; refit the model with this K.')
        out[channel] = m
    return out


class TriadRateConverter:
    """Streaming triad body rates for imu_corrector's triad mode (METHODS §F.6).

    Feed ``/imu/pulses`` samples (:meth:`add_pulses`, names and positions as in the message)
    and, where channels have thermal models, their temperatures (:meth:`add_temperature`) in
    arrival order; each call returns the body rates (or :class:`Rejection` s) it releases,
    in stamp order. A sample whose names are not the calibration's three channels (in any
    order) is refused and not used. As :class:`PulseRateConverter`: a sample with a non-finite
    count is skipped (the previous one stays the reference); a stamp not after the previous
    one is refused and becomes the new reference. With thermal models, each such channel's
    pulses go to its own :class:`~gyro_calib.thermal.live.OrderedThermalCompensator` and a
    sample is released when every one of them has decided its bias (by stamps only), with
    b and C_b of §F.6 eq. (19); if any has none the sample gets a Rejection.
    """

    def __init__(self, model: TriadRateModel,
                 thermal: dict[str, ThermalBiasModel] | None = None, *,
                 thermal_max_age_s: float = 30.0, equal: bool = False) -> None:
        """Start with no reference sample.

        Args:
            model: M, its covariance, b, noise.
            thermal: channel → its thermal model (channels without one use the section's b).
            thermal_max_age_s: as :class:`PulseRateConverter`.
            equal: publish :func:`~gyro_calib.imu_body_rate.equal_variances` (§F.6 eq. (18)).
        """
        from gyro_calib.thermal.live import OrderedThermalCompensator

        self.model = model
        self.equal = equal
        self.thermal = dict(thermal or {})
        self._live = {c: OrderedThermalCompensator(m, max_wait_s=thermal_max_age_s)
                      for c, m in self.thermal.items()}
        self._queues: dict[str, deque[CompensatedPair | Rejection]] = {
            c: deque() for c in self._live}
        self._counts: dict[int, Array] = {}
        self._last: tuple[int, Array] | None = None

    @property
    def held(self) -> int:
        """Samples waiting for their thermal biases."""
        return max((c.held for c in self._live.values()), default=0)

    def _ordered(self, t_ns: int, names: Sequence[str], positions: Sequence[float]
                 ) -> Array | Rejection:
        channels = self.model.channels
        if sorted(names) != sorted(channels) or len(positions) != len(names):
            return Rejection(t_ns, f'channel names {list(names)} (with {len(positions)} '
                                   f'positions) do not match the calibration\'s channels '
                                   f'{list(channels)}: sample not used.')
        return np.array([float(positions[list(names).index(c)]) for c in channels])

    def add_pulses(self, t_ns: int, names: Sequence[str], positions: Sequence[float]
                   ) -> list[ImuAngularVelocity | Rejection]:
        """One /imu/pulses sample; the rates (or Rejections) it releases, in stamp order."""
        counts = self._ordered(t_ns, names, positions)
        if isinstance(counts, Rejection):
            return [counts]
        if self._live:
            if not np.all(np.isfinite(counts)):
                counts = np.full(3, math.nan)
            else:
                self._counts[t_ns] = counts
            for i, c in enumerate(self.model.channels):
                if c in self._live:
                    self._queues[c].extend(self._live[c].add_pulse(t_ns, float(counts[i])))
            return self._release()
        if not np.all(np.isfinite(counts)):
            return [Rejection(t_ns, f'pulse counts {list(counts)} at stamp {t_ns} ns are not '
                                    'all finite.')]
        last, self._last = self._last, (t_ns, counts)
        if last is None:
            return []
        if t_ns <= last[0]:
            return [Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, {last[0]} '
                                    'ns; it becomes the new reference.')]
        return [self._rate(last[0], last[1], t_ns, counts)]

    def add_temperature(self, channel: str, t_ns: int, celsius: float, frame_id: str
                        ) -> list[ImuAngularVelocity | Rejection]:
        """One temperature reading of a channel's sensor; the rates it releases."""
        live = self._live.get(channel)
        if live is None:
            return []
        self._queues[channel].extend(live.add_temperature(t_ns, celsius, frame_id))
        return self._release()

    def _rate(self, t0_ns: int, c0: Array, t1_ns: int, c1: Array,
              channel_bias: dict[int, tuple[float, float]] | None = None
              ) -> ImuAngularVelocity:
        bias, c_b = (None, None) if not channel_bias else bias_with_channel_biases(
            self.model, channel_bias)
        omega, cov = body_rate(c0, c1, (t1_ns - t0_ns) / 1e9, self.model, bias_rad_s=bias,
                               bias_covariance=c_b)
        if self.equal:
            cov = equal_variances(cov)
        return ImuAngularVelocity(t1_ns, (float(omega[0]), float(omega[1]), float(omega[2])),
                                  tuple(float(v) for v in cov.reshape(9)))

    def _release(self) -> list[ImuAngularVelocity | Rejection]:
        out: list[ImuAngularVelocity | Rejection] = []
        queues = list(self._queues.values())
        while all(queues):
            heads = [q.popleft() for q in queues]
            stamp = heads[0].stamp_ns if isinstance(heads[0], Rejection) else heads[0].t1_ns
            rejected = [h for h in heads if isinstance(h, Rejection)]
            if rejected:
                out.append(Rejection(stamp, rejected[0].reason))
                # the next pair starts at the latest finite sample up to here: older go
                ref = max((t for t in self._counts if t <= stamp), default=None)
                for t in [t for t in self._counts if ref is not None and t < ref]:
                    del self._counts[t]
                continue
            done = [h for h in heads if not isinstance(h, Rejection)]
            pairs = dict(zip(self._queues, done, strict=True))
            t0 = done[0].t0_ns
            c0, c1 = self._counts.get(t0), self._counts.get(stamp)
            for t in [t for t in self._counts if t < t0]:
                del self._counts[t]
            if c0 is None or c1 is None or any((h.t0_ns, h.t1_ns) != (t0, stamp) for h in done):
                out.append(Rejection(stamp, f'the channels\' thermal compensators disagree on '
                                            f'the sample pair ending at {stamp} ns.'))
                continue
            bias: dict[int, tuple[float, float]] = {}
            for i, c in enumerate(self.model.channels):
                p = pairs.get(c)
                if p is not None:
                    k = self.thermal[c].scale_factor_rad_per_pulse
                    bias[i] = (p.bias_rad_s / k, p.bias_std / k)
            out.append(self._rate(t0, c0, stamp, c1, bias))
        return out
