"""Streaming thermal calibration: pulses and temperatures in, a bias model out (METHODS §D).

:class:`ThermalCalibrator` is the accumulator a node feeds message by message, or a bag
reader array by array; :func:`calibrate_thermal` runs the same code over whole arrays.
Each stream is reduced on the fly to one row per averaging interval
(:mod:`gyro_calib.thermal.intervals`), so memory stays small for hours of 1 kHz pulses;
the model is fitted from those rows (:func:`gyro_calib.thermal.fit.fit_thermal`) at the
end of the recording (``process(flush=True)``), or every ``refit_every_s`` of new data
for running results. Results depend only on stamps and values: however the data are
chunked, and however far one stream lags another, the rows — and so the model — are the
same.

Input streams:

- ``/gyro/pulses`` (sensor_msgs/JointState, name ['gyro']): header stamp, position[0] =
  cumulative pulse count → :meth:`ThermalCalibrator.extend_pulses` / ``add_pulses``;
- ``/gyro/temperature`` (sensor_msgs/Temperature): header stamp, temperature (°C),
  variance (°C², not used by the fit), header.frame_id = sensor (cavity_a, cavity_b,
  shell) → :meth:`ThermalCalibrator.extend_temperatures` / ``add_temperature``.
  Readings of other frame_ids are counted and ignored.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import GyroCalibError, InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.thermal.errors import SensorSamplingError
from gyro_calib.thermal.fit import ThermalFitReport, fit_thermal
from gyro_calib.thermal.intervals import (
    IntervalTable,
    PulseIntervals,
    TemperatureIntervals,
    join_intervals,
    split_frame_ids,
)
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.settings import ThermalSettings
from gyro_calib.thermal.terms import parse_term
from gyro_calib.thermal.topics import GYRO_TEMPERATURE, SENSORS

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ['ThermalCalibrator', 'ThermalSettings', 'calibrate_thermal', 'COEFFICIENT_PREFIX']

COEFFICIENT_PREFIX = 'thermal_coefficient_'
"""results() key of a coefficient: prefix + term key (``const``, ``h``, ``h2``, ``hdot`` …)
+ ``_rad_s`` (rad/s per scaled unit of the term)."""

RESULT_KEYS_FIXED = (
    'thermal_residual_std_rad_s',
    'thermal_holdout_bias_stability_raw_rad_s',
    'thermal_holdout_bias_stability_compensated_rad_s',
    'thermal_calibration_bias_stability_raw_rad_s',
    'thermal_calibration_bias_stability_compensated_rad_s',
)
"""results() keys besides the coefficients."""


class ThermalCalibrator:
    """Accumulates /gyro/pulses and /gyro/temperature into a thermal bias model."""

    def __init__(self, settings: ThermalSettings) -> None:
        """Create the per-stream reducers (no data kept beyond about one interval).

        Raises:
            ConfigError: the scale factor or the latitude is not given (NaN).
        """
        settings.require_site()
        self.settings = settings
        iset = settings.interval_settings()
        self._pulses = PulseIntervals(iset, settings.scale_factor_rad_per_pulse)
        self._temps = {s: TemperatureIntervals(s, iset) for s in SENSORS}
        self._other_ids: Counter[str] = Counter()
        self._report: ThermalFitReport | None = None
        self._error: GyroCalibError | None = None
        self._reduced_s_at_fit = 0.0
        self._n_pulse_rej = 0

    # -- input ------------------------------------------------------------------------------
    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many /gyro/pulses samples: stamps (int ns), cumulative counts (pulses)."""
        self._pulses.extend(t_ns, counts)

    def add_pulses(self, t_ns: int, count: float) -> None:
        """One /gyro/pulses sample."""
        self._pulses.append(int(t_ns), float(count))

    def extend_temperatures(self, t_ns: ArrayLike, celsius: ArrayLike,
                            frame_id: ArrayLike | str,
                            variance_c2: ArrayLike | None = None) -> None:
        """Many /gyro/temperature messages.

        Many /gyro/temperature messages: stamps (int ns), °C, frame_id per message (or
        one for all), variance (°C², accepted and not used).
        """
        t = np.asarray(t_ns, np.int64)
        v = np.asarray(celsius, np.float64)
        ids = split_frame_ids(frame_id, len(t))
        for name in np.unique(ids):
            sel = ids == name
            if name in self._temps:
                self._temps[name].extend(t[sel], v[sel])
            else:
                self._other_ids[str(name)] += int(np.count_nonzero(sel))

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str,
                        variance_c2: float = 0.0) -> None:
        """One /gyro/temperature message."""
        if frame_id in self._temps:
            self._temps[frame_id].append(int(t_ns), float(celsius))
        else:
            self._other_ids[frame_id] += 1

    # -- processing --------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Reduce what the streams allow; fit at the end (``flush``) or every refit_every_s.

        Returns:
            New log lines: notices, rejections, and the fit's outcome.

        Raises:
            SensorSamplingError: at the end (``flush``), a temperature sensor read too sparsely
                to be interpolated (``max_temperature_gap_s``): the run is refused.
        """
        lines: list[str] = []
        self._pulses.reduce(flush=flush)
        for red in self._temps.values():
            red.reduce(flush=flush)
        sources: list[PulseIntervals | TemperatureIntervals] = [self._pulses,
                                                                *self._temps.values()]
        for src in sources:
            lines += src.notices
            src.notices.clear()
        new_rej = self._pulses.rejections[self._n_pulse_rej:]
        self._n_pulse_rej = len(self._pulses.rejections)
        lines += [r.reason for r in new_rej]
        span = self._reduced_span_s()
        due = flush or (self.settings.refit_every_s > 0
                        and span - self._reduced_s_at_fit >= self.settings.refit_every_s)
        if due:
            lines += self._fit()
            self._reduced_s_at_fit = span
            if flush and isinstance(self._error, SensorSamplingError):
                raise self._error  # bad input, not a fit that failed on the data: refuse
        return lines

    def _reduced_span_s(self) -> float:
        k = self._pulses.arrays()[0]
        return len(k) * self.settings.averaging_interval_s

    def table(self) -> IntervalTable:
        """The streams reduced so far, joined on the interval grid."""
        return join_intervals(self._pulses.arrays(),
                              {s: r.stamped_arrays() for s, r in self._temps.items()
                               if r.n_messages or len(r.arrays()[0])},
                              self.settings.averaging_interval_s)

    def _fit(self) -> list[str]:
        lines: list[str] = []
        if self._other_ids:
            lines.append('ignored /gyro/temperature messages of unknown sensors: ' + ', '.join(
                f'{n} from frame_id {i!r}' for i, n in sorted(self._other_ids.items()))
                + f' (the method reads {", ".join(SENSORS)}).')
        seen = tuple(s for s, r in self._temps.items() if r.n_messages) + tuple(self._other_ids)
        try:
            report = fit_thermal(self.table(), self.settings, frame_ids_seen=seen)
        except GyroCalibError as exc:
            self._error = exc
            self._report = None
            return [*lines, f'thermal model not fitted: {exc}']
        self._report, self._error = report, None
        m = report.model
        lines += list(report.notes)
        lines += [r.reason for r in report.rejections]
        steps = ', '.join(f'{st.action} {st.term} (p = {st.p_value:.3g})'
                          for st in report.selection.steps if st.action != 'skip') or 'none'
        lines.append(f'stepwise ({self.settings.stepwise_start} start) over '
                     f'{", ".join(report.candidates)}: {steps}.')
        lines.append(
            f'thermal model fitted on {report.fit.n} {self._row_kind()} '
            f'({m.calibration_style}): bias = b0'
            + (''.join(f' + t{j}·{t}' for j, t in enumerate(m.terms, start=1))
               or ' (constant only)')
            + f'; residual std {m.residual_std_rad_s / _RAD_S_PER_DEG_H:.4f} °/h; calibrated '
            f'H {m.h_range_c[0]:.2f}…{m.h_range_c[1]:.2f} °C.')
        if m.model_error_n:
            lines.append(f'model error (held-out scatter beyond noise and covariance, added in '
                         f'quadrature to every prediction): '
                         f'{m.model_error_rad_s / _RAD_S_PER_DEG_H:.4f} °/h from '
                         f'{m.model_error_n} held-out blocks of '
                         f'{self.settings.stability_block_s:g} s.')
        if report.holdout_stability_raw is not None and report.holdout_stability_compensated:
            r, c = report.holdout_stability_raw, report.holdout_stability_compensated
            lines.append(f'held-out data: bias stability {r.value / _RAD_S_PER_DEG_H:.4f} → '
                         f'{c.value / _RAD_S_PER_DEG_H:.4f} °/h ({c.n_used} blocks of '
                         f'{self.settings.stability_block_s:g} s).')
        for p in report.snr:
            lines.append(f'SNR at H = {p.h_c:.1f} °C: {p.snr_raw_db:.1f} dB raw → '
                         f'{p.snr_denoised_db:.1f} dB denoised ({p.n} intervals).')
        return lines

    def _row_kind(self) -> str:
        if self.settings.calibration_style == 'soak':
            return 'soak points'
        return f'{self.settings.fit_block_s:g} s blocks'

    # -- results -----------------------------------------------------------------------------
    @property
    def report(self) -> ThermalFitReport:
        """The last fit's full report.

        Raises:
            InsufficientDataError (or the fit's own error): if there is no model yet.
        """
        if self._report is None:
            if self._error is not None:
                raise self._error
            raise InsufficientDataError('no thermal model yet: call process(flush=True) at the '
                                        'end of the recording.')
        return self._report

    def model(self) -> ThermalBiasModel:
        """The fitted model (see :attr:`report` for the errors)."""
        return self.report.model

    def handoff_extra(self) -> dict[str, Any]:
        """The model as the hand-off dict (``thermal_*`` keys)."""
        return self.model().to_dict()

    @property
    def rejections(self) -> list[Rejection]:
        """Every rejection: pulse gaps and glitches, stuck or silent sensors, short plateaus."""
        out = list(self._pulses.rejections)
        if self._report is not None:
            out += list(self._report.rejections)
        return sorted(out, key=lambda r: r.stamp_ns)

    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (rad/s); only those measured so far."""
        if self._report is None:
            return {}
        rep = self._report
        fit = rep.fit
        out: dict[str, Estimate] = {}
        stds = fit.std_uncertainties
        keys = ['const'] + [parse_term(t).key for t in fit.terms]
        rej = tuple(self.rejections)
        for key, value, std in zip(keys, fit.coefficients, stds):
            out[f'{COEFFICIENT_PREFIX}{key}_rad_s'] = Estimate(float(value), float(std), fit.n,
                                                               fit.dof, rej)
        r = fit.residual_std
        out['thermal_residual_std_rad_s'] = Estimate(r, r / math.sqrt(2.0 * max(fit.dof, 1)),
                                                     fit.n, fit.dof)
        if rep.holdout_stability_raw is not None:
            out['thermal_holdout_bias_stability_raw_rad_s'] = rep.holdout_stability_raw
        if rep.holdout_stability_compensated is not None:
            out['thermal_holdout_bias_stability_compensated_rad_s'] = \
                rep.holdout_stability_compensated
        out['thermal_calibration_bias_stability_raw_rad_s'] = rep.calibration_stability_raw
        out['thermal_calibration_bias_stability_compensated_rad_s'] = \
            rep.calibration_stability_compensated
        return {k: v for k, v in out.items() if math.isfinite(v.value)}

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet)."""
        have = self.results()
        if self._report is None:
            why = (f'the thermal model could not be fitted: {self._error}' if self._error
                   else 'not fitted yet: the model is fitted at the end of the recording '
                   '(process(flush=True)).')
            return {k: why for k in (f'{COEFFICIENT_PREFIX}const_rad_s', *RESULT_KEYS_FIXED)}
        out = {}
        for key in RESULT_KEYS_FIXED:
            if key in have:
                continue
            if 'holdout' in key:
                out[key] = ('no held-out check: validation_fraction is 0, the recording is too '
                            'short for a held-out segment, or calibration_style is soak (check '
                            'the model on another run with compensate).')
            else:
                out[key] = 'fewer than two complete stability blocks of valid data.'
        return out

    @property
    def stream_summary(self) -> str:
        """Samples dropped per stream (non-finite, duplicate, late), one line."""
        parts = []
        for name, buf in [('/gyro/pulses', self._pulses.buffer)] + [
                (f'{GYRO_TEMPERATURE} [{s}]', r.buffer) for s, r in self._temps.items()]:
            text = buf.stats.summary()
            if text:
                parts.append(f'{name}: {text}')
        return '; '.join(parts)


_RAD_S_PER_DEG_H = math.pi / 180.0 / 3600.0


def calibrate_thermal(pulse_t_ns: ArrayLike, pulse_counts: ArrayLike,
                      temperature_t_ns: ArrayLike, temperature_c: ArrayLike,
                      temperature_frame_id: ArrayLike | str, settings: ThermalSettings, *,
                      temperature_variance_c2: ArrayLike | None = None,
                      raise_on_failure: bool = True) -> ThermalCalibrator:
    """Batch thermal calibration over whole recordings; returns the finished calibrator.

    Raises:
        GyroCalibError: the reason the model could not be fitted (unless
            ``raise_on_failure`` is False; then read ``missing()``).
    """
    cal = ThermalCalibrator(settings)
    cal.extend_pulses(np.asarray(pulse_t_ns, np.int64), pulse_counts)
    t = np.asarray(temperature_t_ns, np.int64)
    if len(t):
        cal.extend_temperatures(t, temperature_c, temperature_frame_id, temperature_variance_c2)
    cal.process(flush=True)
    if raise_on_failure and cal._error is not None:
        raise cal._error
    return cal
