"""Apply a thermal bias model to a recording (offline) or to live temperatures (METHODS §D, §E).

:func:`compensate` reduces a recording exactly as the calibration did (same averaging
interval and Ḣ window, taken from the model), evaluates the model per interval and
reports, on the *unfiltered* rate:

- ``bias_stability_raw_rad_s``: std of consecutive 100 s means of the raw rate K·ΔN/Δt;
- ``bias_stability_compensated_rad_s``: the same of raw − model;
- ``mean_rate_compensated_rad_s``: mean of raw − model — on a static base the Earth rate
  along the sense axis (reported beside it; a difference of many standard uncertainties
  is noted: another gyro's model, a wrong axis or latitude, or a bias shift);
- ``bias_stability_noise_floor_rad_s``: what angle random walk and pulse quantisation
  alone give for 100 s means (:func:`gyro_calib.thermal.allan.noise_floor`) — the
  compensated figure cannot honestly go below it;
- the overlapping Allan deviation before and after.

These are the honest figures. The paper's 0.0086 °/h after compensation is below the
100 s floor of its own 0.003 °/√h random walk (≈ 0.018 °/h), so it was probably computed
on a filtered signal; we do not report a filtered stability (wavelet denoising here
leaves 100 s means essentially unchanged anyway).

:func:`interval_bias` is the per-interval bias itself, and :func:`pairs_with_bias` /
:func:`offline_pairs` give each pulse pair the bias of the interval holding its midpoint (what
``gyro-calib compensate --out`` writes); ``imu_corrector`` gives the same numbers live
(:class:`gyro_calib.thermal.live.OrderedThermalCompensator`). :class:`ThermalBiasTracker`
gives the model bias of the latest complete interval from temperature messages alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.thermal.allan import (
    NoiseFloor,
    allan_long_run_variance,
    bias_stability,
    block_means,
    noise_floor,
    overlapping_adev,
)
from gyro_calib.thermal.errors import ModelMismatchError, TemperatureDataError
from gyro_calib.thermal.intervals import (
    IntervalSettings,
    IntervalTable,
    PulseIntervals,
    TemperatureIntervals,
    check_sensors,
    join_intervals,
    split_frame_ids,
    thermal_variables,
    true_runs,
)
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.topics import SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL, SENSORS
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

    import numpy.typing as npt
    from numpy.typing import ArrayLike

RAD_S_PER_DEG_H = math.pi / 180.0 / 3600.0
"""1 °/h in rad/s."""


@dataclass(frozen=True, slots=True)
class CompensationReport:
    """Figures of one compensated recording (all rates in rad/s).

    Attributes:
        bias_stability_raw, bias_stability_compensated: std of ``block_s`` means.
        mean_rate_compensated: mean of raw − model, with its standard uncertainty (the
            long-run variance of the compensated rate, read from its Allan variance, and
            the model's coefficient uncertainty at the run's mean temperatures).
        earth_rate_along_axis_rad_s: what that mean should be on a static base.
        noise_floor: ARW and quantisation and the floor they give for ``block_s`` means.
        improvement: 1 − compensated/raw bias stability.
        adev_tau_s, adev_raw_rad_s, adev_compensated_rad_s: Allan deviation before/after
            (on the longest gap-free run).
        t_mid_ns: interval centres. rate_raw_rad_s: raw interval rate (NaN invalid).
        bias_model_rad_s, bias_model_std_rad_s: model bias per interval (NaN where not
            applied).
        h_c: H per interval.
        block_s: block length, s.
        rejections: intervals not compensated and why.
        notes: whole sentences (consistency of the mean rate, identity not checked...).
    """

    bias_stability_raw: Estimate
    bias_stability_compensated: Estimate
    mean_rate_compensated: Estimate
    earth_rate_along_axis_rad_s: float
    noise_floor: NoiseFloor
    improvement: float
    adev_tau_s: npt.NDArray[np.float64]
    adev_raw_rad_s: npt.NDArray[np.float64]
    adev_compensated_rad_s: npt.NDArray[np.float64]
    t_mid_ns: npt.NDArray[np.int64]
    rate_raw_rad_s: npt.NDArray[np.float64]
    bias_model_rad_s: npt.NDArray[np.float64]
    bias_model_std_rad_s: npt.NDArray[np.float64]
    h_c: npt.NDArray[np.float64]
    block_s: float
    rejections: tuple[Rejection, ...]
    notes: tuple[str, ...]

    def results(self) -> dict[str, Estimate]:
        """The figures by hand-off key."""
        return {
            'bias_stability_raw_rad_s': self.bias_stability_raw,
            'bias_stability_compensated_rad_s': self.bias_stability_compensated,
            'mean_rate_compensated_rad_s': self.mean_rate_compensated,
            'bias_stability_noise_floor_rad_s': self.noise_floor.floor,
        }


def model_interval_settings(model: ThermalBiasModel) -> IntervalSettings:
    """The reduction the model was fitted with.

    The reduction the model was fitted with: its interval, Ḣ window and largest
    interpolated gap between a sensor's readings.
    """
    return IntervalSettings(averaging_interval_s=model.averaging_interval_s,
                            hdot_window_s=model.hdot_window_s,
                            max_temperature_gap_s=model.max_temperature_gap_s)


class CompensationReducer:
    """Reduces a recording stream by stream, as the calibrator does.

    Reduces a recording stream by stream, chunk by chunk, exactly as the calibrator does
    (the model's averaging interval and Ḣ window), for :func:`compensate_reduced`.

    Memory: about one interval of samples per stream plus a few numbers per interval, so a
    bag of any length is compensated in bounded memory (``gyro-calib compensate``).
    """

    def __init__(self, model: ThermalBiasModel,
                 interval_settings: IntervalSettings | None = None) -> None:
        """Create the per-stream reducers with the model's interval settings.

        Raises:
            ConfigError: ``interval_settings`` with another interval or Ḣ window than the
                model's (Ḣ would not mean what it meant in the fit).
        """
        iset = interval_settings or model_interval_settings(model)
        if abs(iset.averaging_interval_s - model.averaging_interval_s) > 1e-12 or abs(
                iset.hdot_window_s - model.hdot_window_s) > 1e-12:
            raise ConfigError('interval_settings must use the model\'s averaging interval and '
                              'Ḣ window, or Ḣ would not mean what it meant in the fit.')
        self.model = model
        self.settings = iset
        self.pulses = PulseIntervals(iset, model.scale_factor_rad_per_pulse)
        self.temperatures = {s: TemperatureIntervals(s, iset) for s in SENSORS}
        self.frame_ids: set[str] = set()

    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many /gyro/pulses samples (int ns stamps, cumulative counts)."""
        self.pulses.extend(np.asarray(t_ns, np.int64), counts)

    def extend_temperatures(self, t_ns: ArrayLike, celsius: ArrayLike,
                            frame_id: ArrayLike | str) -> None:
        """Many /gyro/temperature messages (int ns stamps, °C, frame_id per message)."""
        t = np.asarray(t_ns, np.int64)
        v = np.asarray(celsius, np.float64)
        ids = split_frame_ids(frame_id, len(t))
        for name in np.unique(ids).tolist():
            self.frame_ids.add(str(name))
            red = self.temperatures.get(str(name))
            if red is not None:
                sel = ids == name
                red.extend(t[sel], v[sel])

    def process(self, *, flush: bool = False) -> None:
        """Reduce every interval the streams have passed (all at the end: ``flush``)."""
        self.pulses.reduce(flush=flush)
        for red in self.temperatures.values():
            red.reduce(flush=flush)

    def table(self) -> IntervalTable:
        """The streams reduced so far, joined on the interval grid."""
        return join_intervals(self.pulses.arrays(),
                              {s: r.stamped_arrays() for s, r in self.temperatures.items()
                               if r.n_messages}, self.settings.averaging_interval_s)


def compensate(model: ThermalBiasModel, pulse_t_ns: ArrayLike, pulse_counts: ArrayLike,
               temperature_t_ns: ArrayLike, temperature_c: ArrayLike,
               temperature_frame_id: ArrayLike | str, *, gyro_id: str = '',
               scale_factor_rad_per_pulse: float | None = None, block_s: float = 100.0,
               out_of_range: str = 'raise',
               interval_settings: IntervalSettings | None = None) -> CompensationReport:
    """Compensate a recording with ``model`` and report the figures (module docstring).

    Args:
        model: the thermal model (from the hand-off dict).
        pulse_t_ns: /gyro/pulses stamps, ns.
        pulse_counts: /gyro/pulses cumulative counts.
        temperature_t_ns: /gyro/temperature stamps, ns.
        temperature_c: /gyro/temperature readings, °C.
        temperature_frame_id: /gyro/temperature sensor names (one per message, or one).
        gyro_id: the recording's gyro (scenario metadata, bench log); checked against the
            model's when both are known.
        scale_factor_rad_per_pulse: the recording's own K if known; refused if it differs
            from the model's by more than 100 ppm (the model's bias is tied to its K).
        block_s: bias-stability block, s (100 s, METHODS §E).
        out_of_range: ``raise`` (default) an :class:`ExtrapolationError` at the first
            interval outside the calibrated range plus margin, or ``skip`` such intervals
            (each run listed in ``rejections``).
        interval_settings: reduction settings (default: the model's interval and Ḣ window).

    Raises:
        ModelMismatchError: another gyro's model, another K, or a sensor the model needs
            missing.
        TemperatureDataError: no cavity temperatures.
        ExtrapolationError: see ``out_of_range``.
        InsufficientDataError: fewer than two complete blocks to compare.
    """
    if out_of_range not in ('raise', 'skip'):
        raise ConfigError(f"out_of_range = {out_of_range!r} is invalid: use 'raise' or 'skip'.")
    check_identity(model, gyro_id=gyro_id,
                   scale_factor_rad_per_pulse=scale_factor_rad_per_pulse)
    reducer = CompensationReducer(model, interval_settings)
    reducer.extend_pulses(pulse_t_ns, pulse_counts)
    t = np.asarray(temperature_t_ns, np.int64)
    if len(t):
        reducer.extend_temperatures(t, temperature_c, temperature_frame_id)
    reducer.process(flush=True)
    return compensate_reduced(reducer, gyro_id=gyro_id, block_s=block_s,
                              out_of_range=out_of_range)


def check_identity(model: ThermalBiasModel, *, gyro_id: str = '',
                   scale_factor_rad_per_pulse: float | None = None) -> None:
    """Refuse a model fitted on another gyro or with another scale factor.

    Raises:
        ModelMismatchError: both gyro ids known and different, or K differing from the
            model's by more than 100 ppm.
    """
    model.check_gyro(gyro_id)
    k_rad = model.scale_factor_rad_per_pulse
    if scale_factor_rad_per_pulse is not None and abs(
            scale_factor_rad_per_pulse / k_rad - 1.0) > 1e-4:
        raise ModelMismatchError(
            f'the recording\'s scale factor {scale_factor_rad_per_pulse:.10g} rad/pulse differs '
            f'from the {k_rad:.10g} rad/pulse the thermal model was fitted with by more than '
            '100 ppm: the model belongs to another gyro or calibration.')


@dataclass(frozen=True, slots=True)
class IntervalBias:
    """The model's bias per interval of a table (:func:`interval_bias`).

    Attributes:
        valid: the interval has a pulse rate, the temperatures the model needs and lies
            inside the calibrated range (plus margin): its bias is used.
        bias, bias_std: the model's bias and its standard uncertainty, rad/s (NaN where
            not ``valid``).
        variables: H, Ḣ, ΔT_ab, ΔT_cs per interval (:func:`thermal_variables`).
        rejections: stuck or silent sensors, and spans outside the calibrated range.
        any_in_data: some interval had a rate and the temperatures before the range check.
    """

    valid: npt.NDArray[np.bool_]
    bias: npt.NDArray[np.float64]
    bias_std: npt.NDArray[np.float64]
    variables: dict[str, npt.NDArray[np.float64]]
    rejections: tuple[Rejection, ...]
    any_in_data: bool


def interval_bias(table: IntervalTable, model: ThermalBiasModel, settings: IntervalSettings,
                  *, out_of_range: str = 'skip') -> IntervalBias:
    """The model's bias for every interval of ``table``, as compensation subtracts it.

    Interpolates and checks the sensors (:func:`check_sensors`), forms H, causal Ḣ and the
    gradients (METHODS §D.3, §D.5) and evaluates the model where the interval has a pulse
    rate and every variable the model needs. Each interval's value depends only on the
    intervals around it (the neighbouring readings, the Ḣ window, the equal-value run a
    stuck check looks at), never on where the table starts, so the live corrector
    (:class:`gyro_calib.thermal.live.OrderedThermalCompensator`) calls this on a window
    and gets the offline numbers bit for bit.

    Raises:
        ModelMismatchError: a sensor the model needs never read.
        ExtrapolationError: ``out_of_range='raise'`` and an interval outside the calibrated
            range plus margin.
    """
    check = check_sensors(table, settings)
    present = tuple(s for s, c in check.temperatures_c.items() if np.any(np.isfinite(c)))
    model.check_sensors(present)
    temps = dict(check.temperatures_c)
    n = len(table)
    for sensor in (SENSOR_CAVITY_A, SENSOR_CAVITY_B):
        temps.setdefault(sensor, np.full(n, np.nan))
    variables = thermal_variables(temps, settings)
    rate = table.rate_rad_s(model.scale_factor_rad_per_pulse)
    valid = np.isfinite(rate)
    for v in ('H', *model.variables):
        valid &= np.isfinite(variables[v])
    rejections = list(check.rejections)
    any_in_data = bool(np.any(valid))
    idx = np.nonzero(valid)[0]
    tint = int(round(table.interval_s * NS_PER_S))
    t_mid = table.t_mid_ns
    if out_of_range == 'raise':
        if len(idx):
            model.check_range(variables['H'][idx], variables['Hdot'][idx], t_mid[idx])
    else:
        lo, hi = model.h_range_c
        m = model.extrapolation_margin_c
        h = variables['H']
        outside = valid & ((h < lo - m) | (h > hi + m))
        if 'Hdot' in model.variables:
            rlo, rhi = model.hdot_range_c_s
            mr = model.hdot_margin_fraction * (rhi - rlo)
            r = variables['Hdot']
            outside |= valid & ((r < rlo - mr) | (r > rhi + mr))
        for a, b in true_runs(outside):
            rejections.append(Rejection(int(table.k[a]) * tint, (
                f'from {format_stamp(int(table.k[a]) * tint)} to '
                f'{format_stamp(int(table.k[b - 1] + 1) * tint)} the temperature (H '
                f'{np.nanmin(h[a:b]):.2f}…{np.nanmax(h[a:b]):.2f} °C) lies outside the '
                f'calibrated range {lo:.2f}…{hi:.2f} °C ± {m:g} °C: not compensated.')))
        valid &= ~outside
        idx = np.nonzero(valid)[0]
    bias = np.full(n, np.nan)
    bias_std = np.full(n, np.nan)
    if len(idx):
        b_in, bs_in = model.bias_rad_s(variables['H'][idx], variables['Hdot'][idx],
                                       variables['dTab'][idx], variables['dTcs'][idx],
                                       check=False)
        bias[idx], bias_std[idx] = b_in, bs_in
    return IntervalBias(valid, bias, bias_std, variables, tuple(rejections), any_in_data)


@dataclass(frozen=True, slots=True)
class CompensatedPair:
    """Two consecutive pulse samples and the model bias to subtract from their rate.

    Attributes:
        t0_ns, count0: the earlier sample. t1_ns, count1: the later one (the rate's stamp).
        bias_rad_s, bias_std: the model bias of the interval holding the pair's midpoint
            and its standard uncertainty, rad/s.
    """

    t0_ns: int
    count0: float
    t1_ns: int
    count1: float
    bias_rad_s: float
    bias_std: float


def pairs_with_bias(samples: Iterable[tuple[int, float]], k0: int, interval_ns: int,
                    bias: npt.NDArray[np.float64], bias_std: npt.NDArray[np.float64]
                    ) -> Iterator[CompensatedPair | Rejection | None]:
    """Each pulse sample with the one before it and the bias of the pair's midpoint interval.

    One item per sample, in order: None where it makes no pair (the first, a non-finite
    count — the previous sample stays the reference —, a stamp not after the previous one
    — it becomes the reference), a :class:`Rejection` where the interval holding the
    midpoint has no bias (``bias[i]`` NaN or outside the table starting at interval
    ``k0``), else the :class:`CompensatedPair`. ``gyro-calib compensate --out`` writes
    these; the live corrector gives the same pairs.
    """
    last: tuple[int, float] | None = None
    for t_ns, count in samples:
        if not math.isfinite(count):
            yield None
            continue
        prev, last = last, (t_ns, count)
        if prev is None or t_ns <= prev[0]:
            yield None
            continue
        i = (prev[0] + (t_ns - prev[0]) // 2) // interval_ns - k0
        if not (0 <= i < len(bias)) or not math.isfinite(bias[i]):
            yield Rejection(t_ns, 'no thermal compensation: the model gives no bias for the '
                                  'interval holding this pair.')
            continue
        yield CompensatedPair(prev[0], prev[1], t_ns, count, float(bias[i]), float(bias_std[i]))


def offline_pairs(model: ThermalBiasModel, pulse_t_ns: ArrayLike, pulse_counts: ArrayLike,
                  temperature_t_ns: ArrayLike, temperature_c: ArrayLike,
                  temperature_frame_id: ArrayLike | str
                  ) -> list[CompensatedPair | Rejection | None]:
    """:func:`pairs_with_bias` of a whole recording, out-of-range intervals skipped.

    The offline reference of the live corrector: the recording reduced and compensated as
    :func:`compensate` does (:func:`interval_bias` with ``out_of_range='skip'``), without
    the figures (so a recording too short for them still gives its pairs).
    """
    reducer = CompensationReducer(model)
    reducer.extend_pulses(pulse_t_ns, pulse_counts)
    t = np.asarray(temperature_t_ns, np.int64)
    if len(t):
        reducer.extend_temperatures(t, temperature_c, temperature_frame_id)
    reducer.process(flush=True)
    table = reducer.table()
    tint = reducer.settings.interval_ns
    try:
        ib = interval_bias(table, model, reducer.settings, out_of_range='skip')
        bias, bias_std = ib.bias, ib.bias_std
    except ModelMismatchError:
        bias = bias_std = np.full(len(table), np.nan)
    samples = zip(np.asarray(pulse_t_ns, np.int64).tolist(),
                  np.asarray(pulse_counts, np.float64).tolist())
    k0 = int(table.k[0]) if len(table) else 0
    return list(pairs_with_bias(samples, k0, tint, bias, bias_std))


def compensate_reduced(reducer: CompensationReducer, *, gyro_id: str = '',
                       block_s: float = 100.0, out_of_range: str = 'raise'
                       ) -> CompensationReport:
    """The figures of a reduced recording.

    The figures of a reduced recording (see :func:`compensate`, which calls it; call
    :func:`check_identity` before reducing).

    Raises:
        TemperatureDataError, ModelMismatchError, ExtrapolationError, InsufficientDataError:
            as :func:`compensate`.
    """
    if out_of_range not in ('raise', 'skip'):
        raise ConfigError(f"out_of_range = {out_of_range!r} is invalid: use 'raise' or 'skip'.")
    model = reducer.model
    model.check_gyro(gyro_id)
    table = reducer.table()
    ids = tuple(sorted(reducer.frame_ids))
    for sensor in (SENSOR_CAVITY_A, SENSOR_CAVITY_B):
        col = table.temperatures_c.get(sensor)
        if col is None or not np.any(np.isfinite(col)):
            raise TemperatureDataError(
                f'no finite /gyro/temperature reading from {sensor} (frame_ids seen: '
                f'{", ".join(ids) or "none"}): the model needs H, the mean of cavity_a and '
                'cavity_b.')
    ib = interval_bias(table, model, reducer.settings, out_of_range=out_of_range)
    if not np.any(ib.valid):
        raise InsufficientDataError('every interval lies outside the calibrated range.'
                                    if ib.any_in_data else
                                    'no interval has both a valid pulse rate and the '
                                    'temperatures the model needs.')
    k_rad = model.scale_factor_rad_per_pulse
    rate = table.rate_rad_s(k_rad)
    valid, variables, bias, bias_std = ib.valid, ib.variables, ib.bias, ib.bias_std
    rejections = list(reducer.pulses.rejections) + list(ib.rejections)
    idx = np.nonzero(valid)[0]
    t_mid = table.t_mid_ns
    earth = model.earth_rate_along_axis_rad_s
    nb = int(round(block_s / table.interval_s))
    shift = int((-table.k[0]) % nb)
    dt = np.where(valid, table.dt_ns, 0)[shift:]
    angle_raw = np.where(valid, table.dcount * k_rad, np.nan)[shift:]
    angle_comp = angle_raw - np.nan_to_num(bias[shift:]) * dt / NS_PER_S
    raw_means = block_means(angle_raw, dt, intervals_per_block=nb)
    comp_means = block_means(angle_comp, dt, intervals_per_block=nb)
    st_raw = bias_stability(raw_means)
    st_comp = bias_stability(comp_means)
    if st_raw.n_used < 2:
        raise InsufficientDataError(
            f'only {st_raw.n_used} complete {block_s:g} s block(s) of compensated data: the '
            'bias stability needs at least two.')
    # mean compensated rate and its uncertainty
    dt_all = np.where(valid, table.dt_ns, 0) / NS_PER_S
    mean_comp = float(np.nansum(np.where(valid, table.dcount * k_rad - bias * dt_all, 0.0))
                      / dt_all.sum())
    x_mean = model.design_rows({'H': variables['H'][idx], 'Hdot': variables['Hdot'][idx],
                          'dTab': variables['dTab'][idx],
                          'dTcs': variables['dTcs'][idx]}).mean(axis=0)
    model_var = float(x_mean @ np.asarray(model.covariance_rad2_s2) @ x_mean) \
        + model.model_error_rad_s**2  # the model error may not average out (METHODS (17g))
    # noise part of the mean's uncertainty: the long-run variance of the compensated
    # interval rates (Allan estimate, so correlated noise such as bias instability counts)
    comp_series = (rate - bias)[valid]
    lrv, m_star = allan_long_run_variance(comp_series, max(1, len(comp_series) // 8))
    noise_var = lrv / len(comp_series)
    fin = comp_means[np.isfinite(comp_means)]
    mean_est = Estimate(mean_comp, math.sqrt(noise_var + model_var), len(fin),
                        max(1, len(comp_series) // m_star - 1), tuple(rejections))
    notes: list[str] = []
    z = (mean_comp - earth) / mean_est.std_uncertainty if mean_est.std_uncertainty else 0.0
    if abs(z) > 5:
        notes.append(
            f'the compensated mean rate {mean_comp / RAD_S_PER_DEG_H:.4f} °/h differs from the '
            f'Earth rate along the sense axis {earth / RAD_S_PER_DEG_H:.4f} °/h by {z:.1f} '
            'standard uncertainties: the model may belong to another gyro, the latitude or '
            'axis may be wrong, or the bias shifted since calibration.')
    if not (model.gyro_id and gyro_id):
        notes.append('gyro identity not checked (the model or the recording names no gyro).')
    # Allan deviation and noise floor on the longest gap-free run
    comp_rate = rate - bias
    runs = true_runs(valid)
    a, b_end = max(runs, key=lambda r: r[1] - r[0])
    tau0 = table.interval_s
    floor = noise_floor(comp_rate[a:b_end], tau0, block_s,
                        quantisation_rad=k_rad / math.sqrt(12.0), min_tau_s=10.0 * tau0)
    tau, adev_raw, _ = overlapping_adev(rate[a:b_end], tau0)
    _, adev_comp, _ = overlapping_adev(comp_rate[a:b_end], tau0)
    improvement = 1.0 - st_comp.value / st_raw.value if st_raw.value else math.nan
    return CompensationReport(
        bias_stability_raw=Estimate(st_raw.value, st_raw.std_uncertainty, st_raw.n_used,
                                    st_raw.dof, tuple(rejections)),
        bias_stability_compensated=Estimate(st_comp.value, st_comp.std_uncertainty,
                                            st_comp.n_used, st_comp.dof, tuple(rejections)),
        mean_rate_compensated=mean_est, earth_rate_along_axis_rad_s=earth, noise_floor=floor,
        improvement=improvement, adev_tau_s=tau, adev_raw_rad_s=adev_raw,
        adev_compensated_rad_s=adev_comp, t_mid_ns=t_mid, rate_raw_rad_s=rate,
        bias_model_rad_s=bias, bias_model_std_rad_s=bias_std, h_c=variables['H'],
        block_s=block_s, rejections=tuple(sorted(rejections, key=lambda r: r.stamp_ns)),
        notes=tuple(notes))


class ThermalBiasTracker:
    """Live model bias from /gyro/temperature messages (for a corrector node).

    Feed temperatures with :meth:`add_temperature`; :meth:`bias` gives the model bias of
    the latest complete averaging interval, from the same interval means, the same sensor
    checks and the same causal Ḣ as :func:`compensate` — so a live corrector subtracts
    what the offline compensation subtracts, one interval (plus the reorder window) later.
    It keeps only the last max(Ḣ window, stuck-sensor span) + ``max_temperature_gap_s``
    intervals. One difference: a
    stuck sensor is recognised live only once it has been stuck for ``sensor_stuck_s``,
    while the offline pass blanks the whole stuck span.
    """

    def __init__(self, model: ThermalBiasModel, *,
                 interval_settings: IntervalSettings | None = None) -> None:
        """Create per-sensor reducers.

        Create per-sensor reducers using the model's interval, Ḣ window and largest
        interpolated gap.
        """
        self.model = model
        self.settings = interval_settings or model_interval_settings(model)
        self._temps = {s: TemperatureIntervals(s, self.settings) for s in SENSORS}
        stuck_n = int(round(self.settings.sensor_stuck_s / self.settings.averaging_interval_s))
        self._gap_n = int(math.ceil(self.settings.max_temperature_gap_s
                                    / self.settings.averaging_interval_s)) + 1
        self._n_keep = max(self.settings.hdot_window_n, stuck_n + 2) + self._gap_n

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str) -> None:
        """One /gyro/temperature message (unknown frame_ids are ignored)."""
        red = self._temps.get(frame_id)
        if red is not None:
            red.append(int(t_ns), float(celsius))

    def bias(self) -> tuple[int, float, float]:
        """(end stamp of the interval used in ns, bias rad/s, its standard uncertainty).

        The interval used is the latest one every sensor has a reading in or after (a
        sensor read every few seconds is interpolated up to its latest reading, so the bias
        lags by up to one reading interval).

        Raises:
            InsufficientDataError: no complete interval with H and Ḣ yet, a sensor the
                model needs is stuck, or has not been read for ``max_temperature_gap_s``.
            ExtrapolationError: the temperature is outside the calibrated range.
        """
        n_keep = self._n_keep
        for red in self._temps.values():
            red.reduce()
        tables = {s: r.stamped_arrays() for s, r in self._temps.items()
                  if len(r.arrays()[0])}
        if SENSOR_CAVITY_A not in tables or SENSOR_CAVITY_B not in tables:
            raise InsufficientDataError('no complete interval of both cavity_a and cavity_b '
                                        'temperatures yet.')
        newest = max(int(cols[0][-1]) for cols in tables.values())
        last_read = {}
        for s, cols in tables.items():
            fin = np.nonzero(np.isfinite(cols[1]))[0]
            last_read[s] = int(cols[0][fin[-1]]) if len(fin) else None
        needs_shell = 'dTcs' in self.model.variables
        for s in (SENSOR_CAVITY_A, SENSOR_CAVITY_B) + ((SENSOR_SHELL,) if needs_shell else ()):
            k_s = last_read.get(s)
            if k_s is None or newest - k_s > self._gap_n:
                raise InsufficientDataError(
                    f'no reading from temperature sensor {s} in the last '
                    f'{self.settings.max_temperature_gap_s:g} s (max_temperature_gap_s): the '
                    'bias cannot be computed.')
        k_end = min(k for s, k in last_read.items() if k is not None
                    and (s != SENSOR_SHELL or needs_shell))
        k0 = k_end - n_keep + 1
        window, offsets = {}, {}
        for s, (k, m, off) in tables.items():
            col = np.full(n_keep, np.nan)
            ocol = np.full(n_keep, np.nan)
            sel = (k >= k0) & (k <= k_end)
            col[k[sel] - k0] = m[sel]
            ocol[k[sel] - k0] = off[sel]
            # the next reading after k_end bounds the interpolation up to k_end
            after = np.nonzero((k > k_end) & np.isfinite(m))[0]
            if len(after):
                j = int(after[0])
                col = np.append(col, [np.nan] * (int(k[j]) - k_end - 1) + [m[j]])
                ocol = np.append(ocol, [np.nan] * (int(k[j]) - k_end - 1) + [off[j]])
            window[s] = col
            offsets[s] = ocol
        width = max(len(c) for c in window.values())
        window = {s: np.concatenate((c, np.full(width - len(c), np.nan)))
                  for s, c in window.items()}
        offsets = {s: np.concatenate((c, np.full(width - len(c), np.nan)))
                   for s, c in offsets.items()}
        table = IntervalTable(self.settings.averaging_interval_s,
                              np.arange(k0, k0 + width, dtype=np.int64), np.full(width, np.nan),
                              np.zeros(width, np.int64), window, offsets)
        check = check_sensors(table, self.settings)
        n_hd = self.settings.hdot_window_n
        recent = {s: c[n_keep - n_hd:n_keep] for s, c in check.temperatures_c.items()}
        variables = thermal_variables(recent, self.settings)
        last = {v: variables[v][-1:] for v in variables}
        needed = ('H', *self.model.variables)
        if not all(np.isfinite(last[v][0]) for v in needed):
            stuck = [r.reason for r in check.rejections if 'stuck' in r.reason]
            raise InsufficientDataError(stuck[-1] if stuck else (
                'the latest interval lacks a temperature the model needs (or Ḣ has fewer than '
                f'half of its {self.settings.hdot_window_s:g} s window).'))
        tint = self.settings.interval_ns
        end_ns = (k_end + 1) * tint
        self.model.check_range(last['H'], last['Hdot'], np.array([end_ns]))
        value, std = self.model.bias_rad_s(last['H'], last['Hdot'], last['dTab'],
                                           last['dTcs'], check=False)
        for red in self._temps.values():  # memory: forget what the window no longer needs
            red.keep_last(n_keep)
        return end_ns, float(value[0]), float(std[0])
