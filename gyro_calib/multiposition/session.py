"""The multiposition calibration behind the shared front door (registry, CLI, bag calibration).

One session calibrates one IMU from one ``sensor_msgs/Imu`` topic (``--topic``, default
``/imu/data``; a table file with ``gyro_*`` and ``accel_*`` columns reads as that topic):
the samples are held, and at the end of the data (live: every ``analysis_period_s``) the
whole calibration runs on them (§G). Results: every parameter of both sensors by
``imu.accelerometer.<name>`` and ``imu.gyro.<name>``; the hand-off is the ``imu:`` section
(:mod:`gyro_calib.multiposition.section`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.config import field_defaults, read_method_file
from gyro_calib.estimate import Rejection
from gyro_calib.multiposition.accelerometer import MIN_POSES
from gyro_calib.multiposition.calibrator import (
    AXIS_NAMES,
    MultipositionResult,
    calibrate,
    direction_held,
    directions_not_held,
    inverse_scale,
)
from gyro_calib.multiposition.ferraris import OUTPUTS, FerrarisResult, ferraris
from gyro_calib.multiposition.gravity import ANOMALY_STD_M_S2, normal_gravity_m_s2
from gyro_calib.multiposition.gyroscope import MIN_MOTIONS
from gyro_calib.multiposition.keys import METHOD
from gyro_calib.multiposition.recording import Recording
from gyro_calib.multiposition.section import (
    accelerometer_section,
    ferraris_section,
    imu_section,
)
from gyro_calib.multiposition.settings import (
    DEFAULT_TOPIC,
    NODE_NAME,
    STANDARD_GRAVITY,
    UNKNOWN_SITE_GRAVITY_STD,
    MultipositionSettings,
    settings_from_mapping,
)
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate
    from gyro_calib.handoff import Calibration
    from gyro_calib.imu_calibration import ImuCalibration

IMU = 'sensor_msgs/msg/Imu'

__all__ = ['IMU', 'NODE_NAME', 'MultipositionSession', 'MultipositionSettings', 'local_gravity']


def local_gravity(settings: MultipositionSettings, latitude_deg: float) -> tuple[float, float,
                                                                                 str]:
    """(g, u(g), where it came from): given, else eq. (1) at the site, else standard g."""
    if not math.isnan(settings.gravity_m_s2):
        u = settings.gravity_std_m_s2 if not math.isnan(settings.gravity_std_m_s2) else 0.0
        return settings.gravity_m_s2, u, 'given'
    if math.isfinite(latitude_deg):
        u = settings.gravity_std_m_s2 if not math.isnan(settings.gravity_std_m_s2) \
            else ANOMALY_STD_M_S2
        return (normal_gravity_m_s2(latitude_deg, settings.height_m), u,
                f'normal gravity at {latitude_deg:g}°, {settings.height_m:g} m')
    return STANDARD_GRAVITY, UNKNOWN_SITE_GRAVITY_STD, (
        'standard gravity, u over the whole Earth (give --latitude-deg for local g)')


class MultipositionSession(MethodSession):
    """Accelerometer and gyro of an IMU turned by hand between static poses (§G)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Settings: node parameters, then the config file; the site from the options.

        Raises:
            ConfigError: an unknown or out-of-range setting.
        """
        fields = [f.name for f in dataclasses.fields(MultipositionSettings)]
        values = {k: v for k, v in options.settings.items() if k in fields}
        source = 'settings'
        if options.config_file is not None:
            values.update(read_method_file(options.config_file, node_name=NODE_NAME,
                                           fields=field_defaults(MultipositionSettings))[0])
            source = str(options.config_file)
        self.settings = settings_from_mapping(values, source=source)
        self.options = options
        self.topic = options.topic or str(options.bench('topic', '') or '') or DEFAULT_TOPIC
        self.gravity, self.gravity_std, self.gravity_source = local_gravity(
            self.settings, options.latitude)
        self._stamps: list[np.ndarray] = []
        self._gyro: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []
        self._result: MultipositionResult | None = None
        self._problem = ''
        self._dirty = False
        self._analysed_ns: int | None = None
        self._lines: list[str] = []
        self._units: tuple[str, str, float] = ('m/s²', 'rad/s', 1.0)
        self._fed = False
        self._ferraris: FerrarisResult | None = None
        self._ferraris_rec: Recording | None = None
        self._origin_ns: int | None = None  # first stamp: the live analyses' grid origin
        self._cuts_done = 0  # grid stamps analysed (live, finish_when_conditioned)
        self._finished_ns: int | None = None  # the grid stamp the pose set was well-conditioned
        self._finished_line = ''
        self._after_finish = 0  # samples fed after that, not used
        self._poses_told = 0

    # -- input ------------------------------------------------------------------------------
    def topics(self) -> dict[str, str]:
        """The Imu topic read."""
        return {self.topic: IMU}

    def feed(self, batch: SampleBatch) -> None:
        """The Imu samples of one batch."""
        col = batch.columns.get(self.topic)
        if col is None or not len(col) or col.msgtype != IMU:
            return
        if self._finished_ns is not None:
            self._after_finish += len(col)
            return
        first = int(np.min(col.stamp_ns))
        self._origin_ns = first if self._origin_ns is None else min(self._origin_ns, first)
        self._stamps.append(np.asarray(col.stamp_ns, dtype=np.int64))
        self._gyro.append(np.asarray(col.values['angular_velocity_rad_s'], dtype=np.float64))
        self._acc.append(np.asarray(col.values['linear_acceleration_m_s2'], dtype=np.float64))
        self._dirty = self._fed = True

    def feed_recording(self, rec: Recording) -> None:
        """A whole plain recording (readers' formats), its raw units kept."""
        self._stamps = [np.round(rec.t_s * NS_PER_S).astype(np.int64)]
        self._acc, self._gyro = [rec.acc], [rec.gyro]
        self._units = (rec.acc_unit, rec.gyro_unit, rec.nominal_gyro_scale)
        self.topic = rec.source or self.topic
        self._dirty = True

    def feed_ferraris(self, rec: Recording, sections: dict[str, tuple[int, int]], *,
                      rate_hz: float, turn_angle: float) -> None:
        """A Ferraris session (six positions, three turns; §G.6) with its section list.

        ``turn_angle`` in the gyro's raw unit × s, signed as imucal's ``expected_angle``.

        Raises:
            ValueError: a section is missing or empty.
        """
        self._ferraris = ferraris(rec, sections, rate_hz=rate_hz, gravity=self.gravity,
                                  angle_rad=turn_angle)
        self._ferraris_rec = rec
        self.topic = rec.source or self.topic

    def recording(self, upto_ns: int | None = None) -> Recording | None:
        """The samples held, sorted by stamp, repeated stamps dropped (None: none).

        ``upto_ns``: only those stamped at or before it.
        """
        if not self._stamps:
            return None
        t = np.concatenate(self._stamps)
        order = np.argsort(t, kind='stable')
        t = t[order]
        keep = np.concatenate(([True], np.diff(t) > 0))
        if upto_ns is not None:
            keep &= t <= upto_ns
        acc = np.concatenate(self._acc)[order][keep]
        gyro = np.concatenate(self._gyro)[order][keep]
        ok = np.all(np.isfinite(acc), axis=1) & np.all(np.isfinite(gyro), axis=1)
        t = t[keep][ok]
        if len(t) < 2:
            return None
        acc_unit, gyro_unit, nominal = self._units
        return Recording((t - t[0]) / NS_PER_S + t[0] / NS_PER_S, acc[ok], gyro[ok],
                         acc_unit, gyro_unit, self.topic, nominal_gyro_scale=nominal)

    # -- processing -------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Calibrate the samples held.

        At the end; live every ``analysis_period_s`` of data and whenever the input paused
        (nothing fed since the last call), so the numbers at the end of the data are the
        offline ones. A live session with ``finish_when_conditioned`` analyses the data up
        to each stamp first stamp + n·``analysis_period_s`` in turn (stamps, not arrival)
        and stops at the first whose pose set is well-conditioned (§G.5): :meth:`finished`.
        """
        fed, self._fed = self._fed, False
        if not self._dirty or self._finished_ns is not None:
            return []
        newest = int(self._stamps[-1].max()) if self._stamps else 0
        if self.live and self.settings.finish_when_conditioned and not flush:
            return self._process_grid(newest, fed)
        if not flush and fed and self._analysed_ns is not None and newest - self._analysed_ns \
                < self.settings.analysis_period_s * NS_PER_S:
            return []
        self._dirty = False
        return self._analyse(newest, None)

    def _process_grid(self, newest: int, fed: bool) -> list[str]:
        """Live, finishing: the data up to each grid stamp crossed, in turn; all when paused."""
        assert self._origin_ns is not None
        period = int(round(self.settings.analysis_period_s * NS_PER_S))
        lines: list[str] = []
        while self._origin_ns + (self._cuts_done + 1) * period <= newest:
            self._cuts_done += 1
            cut = self._origin_ns + self._cuts_done * period
            lines += self._analyse(cut, cut)
            r = self._result
            if r is not None and r.well_conditioned and r.gyro is not None \
                    and r.accelerometer is not None:
                self._finished_ns = cut
                self._finished_line = (
                    f'pose set well-conditioned (§G.5) with the data up to '
                    f'{format_stamp(cut)} ({(cut - self._origin_ns) / NS_PER_S:.1f} s): '
                    f'{len(r.detection.intervals)} poses, cond(JᵀJ) '
                    f'{r.accelerometer.condition:.3g} (accelerometer) / '
                    f'{r.gyro.condition:.3g} (gyro) ≤ {self.settings.max_condition:g}, gravity '
                    f'near all of {", ".join(AXIS_NAMES)}; finished (finish_when_conditioned).')
                return lines + [self._finished_line]
        if not fed and not lines:  # the input paused: everything so far (shown, no stop)
            self._dirty = False
            lines += self._analyse(newest, None)
        return lines

    def _analyse(self, newest: int, upto_ns: int | None) -> list[str]:
        """Calibrate the samples up to ``upto_ns`` (None: all); new log lines."""
        rec = self.recording(upto_ns)
        self._analysed_ns = newest
        if rec is None:
            self._problem = f'fewer than two Imu samples with finite values on {self.topic}.'
            return []
        old = {r.reason for r in self.rejections()}
        self._result = calibrate(rec, gravity_m_s2=self.gravity,
                                 gravity_std_m_s2=self.gravity_std,
                                 window_s=self.settings.window_s,
                                 min_static_s=self.settings.min_static_s,
                                 max_condition=self.settings.max_condition)
        self._problem = self._result.problem
        self._t0 = rec.t_s[0]
        lines, self._lines = self._lines, []
        going_on = {x.reason for x in self._result.detection.rejected  # a rest the data end in
                    if upto_ns is not None and x.interval.stop >= len(rec.t_s)}
        lines += [f'rejected: {r.reason}' for r in self.rejections()
                  if r.reason not in old and r.reason not in going_on]
        return lines + self._pose_lines(self._result)

    def _pose_lines(self, r: MultipositionResult) -> list[str]:
        """Live: one line when new static poses were found (which, which still needed)."""
        k = len(r.detection.intervals)
        if not self.live or k <= self._poses_told:
            self._poses_told = min(self._poses_told, k)
            return []
        new = [f'#{i + 1} from {r.detection.intervals[i].t_start_s - self._t0:.1f} s '
               f'({direction_held(r.directions[i]) or "between axes"})'
               for i in range(self._poses_told, k)]
        self._poses_told = k
        held = [a for a in AXIS_NAMES if a not in directions_not_held(r.directions)]
        return [f'{k} static poses (new: {", ".join(new)}); gravity near '
                f'{", ".join(held) or "no axis"} so far; '
                + (f'still needed: {"; ".join(r.lacking)}.' if r.lacking
                   else 'the pose set is well-conditioned (§G.5).')]

    def finished(self) -> str:
        """Live: why the run is over (the pose set well-conditioned), else ''."""
        return self._finished_line

    # -- results ----------------------------------------------------------------------------
    @property
    def result(self) -> MultipositionResult | None:
        """The calibration (None before any)."""
        return self._result

    def results(self) -> dict[str, Estimate]:
        """Every parameter of both sensors, by ``imu.<sensor>.<name>``."""
        out: dict[str, Estimate] = {}
        if self._ferraris is not None:
            return self._ferraris_estimates()
        r = self._result
        if r is None:
            return out
        for fit in (r.accelerometer, r.gyro):
            if fit is not None:
                for name in fit.names:
                    out[f'imu.{fit.sensor}.{name}'] = fit.estimate(name)
        return out

    def _ferraris_estimates(self) -> dict[str, Estimate]:
        """Every Ferraris output element, by ``imu.ferraris.<name>_<index>``."""
        from gyro_calib.estimate import Estimate

        f = self._ferraris
        assert f is not None
        out = {}
        for name in OUTPUTS:
            values, stds = np.ravel(f.values[name]), np.ravel(f.std(name))
            for i, (v, u) in enumerate(zip(values, stds, strict=True)):
                out[f'imu.ferraris.{name}_{i}'] = Estimate(float(v), float(u), f.n_used,
                                                           f.n_used - 1, basis=f.basis)
        return out

    def missing(self) -> dict[str, str]:
        """Why the accelerometer or the gyro is not calibrated."""
        if self._ferraris is not None:
            return {}
        r = self._result
        why = self._problem or (f'no sensor_msgs/Imu sample on {self.topic} (the topic this '
                                f'method reads) yet: it needs {MIN_POSES} static poses and '
                                f'{MIN_MOTIONS} turns between them.')
        out = {}
        if r is None or r.accelerometer is None:
            out['imu.accelerometer'] = why
        if r is None or r.gyro is None:
            out['imu.gyro'] = why
        return out

    def needs(self) -> dict[str, str]:
        """The static poses and turns found so far against those the fits need.

        Live, once both are calibrated: what the pose set lacks to be well-conditioned.
        """
        r = self._result
        if r is not None and r.accelerometer is not None and r.gyro is not None:
            if self.live and r.lacking and self._finished_ns is None:
                return {'imu': f'{len(r.detection.intervals)} static poses; for a '
                               f'well-conditioned set still needed: {"; ".join(r.lacking)}.'}
            return {}
        k = len(r.detection.intervals) if r is not None else 0
        if r is not None and r.problem and (r.accelerometer is None and k >= MIN_POSES
                                            or r.gyro is None and k - 1 >= MIN_MOTIONS):
            return {'imu': f'{k} static poses; {r.problem}'}  # enough, but undetermined
        where = ''
        rec = self.recording() if r is not None and k else None
        if r is not None and rec is not None:
            means = np.array([rec.acc[iv.start:iv.stop].mean(axis=0)
                              for iv in r.detection.intervals])
            gone = directions_not_held(means / np.linalg.norm(means, axis=1, keepdims=True))
            where = f'; gravity not yet near {", ".join(gone)}' if gone else ''
        return {'imu': f'{k} static poses so far; the accelerometer needs {MIN_POSES}, the '
                       f'gyro {MIN_MOTIONS + 1} (turn the IMU to a new pose and hold it a few '
                       f'seconds){where}.'}

    def rejections(self) -> list[Rejection]:
        """The static runs left out, each with its reason."""
        r = self._result
        if r is None:
            return []
        t0 = float(getattr(self, '_t0', 0.0))
        return [Rejection(int(round((t0 + x.interval.t_start_s - t0) * NS_PER_S)), x.reason)
                for x in r.detection.rejected]

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first static pose used to the last."""
        if self._ferraris_rec is not None:
            t = self._ferraris_rec.t_s
            return int(round(t[0] * NS_PER_S)), int(round(t[-1] * NS_PER_S))
        r = self._result
        if r is None or not r.detection.intervals:
            return None
        iv = r.detection.intervals
        return int(round(iv[0].t_start_s * NS_PER_S)), int(round(iv[-1].t_stop_s * NS_PER_S))

    def conditions(self) -> dict[str, Any]:
        """The g used and where it came from, the static settings, the input topic."""
        return {'gravity_m_s2': self.gravity, 'gravity_std_m_s2': self.gravity_std,
                'gravity_source': self.gravity_source, 'topic': self.topic,
                'window_s': self.settings.window_s, 'min_static_s': self.settings.min_static_s,
                'latitude_deg': self.options.latitude,
                **({'finished_at_stamp_ns': self._finished_ns}
                   if self._finished_ns is not None else {}),
                'gyro_bias_basis': 'mean of the static intervals; the Earth rate averaged over '
                                   'the poses is not removed (docs/methods.md §G.3)'}

    def handoff_values(self) -> dict[str, Any]:
        """None at the top level: the results are the ``imu:`` section (:meth:`handoff`)."""
        return {}

    def imu_calibration(self) -> ImuCalibration | None:
        """The ``imu:`` section (None before the accelerometer is calibrated)."""
        if self._ferraris is not None and self._ferraris_rec is not None:
            flat = np.concatenate([np.ravel(self._ferraris.values[n]) for n in OUTPUTS])
            return ferraris_section(flat, self._ferraris.covariance,
                                    gyro_si_per_raw=self._ferraris_rec.nominal_gyro_scale,
                                    acc_unit=self._ferraris_rec.acc_unit, gravity=self.gravity)
        r = self._result
        if r is None or r.accelerometer is None:
            return None
        acc = accelerometer_section(r.accelerometer, self.gravity, self.gravity_std)
        missing = {'pulses_to_body_rad': r.problem} if r.gyro is None else {}
        return imu_section(r.gyro, acc, missing)

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's record: no top-level keys, the ``imu:`` section (format 4)."""
        from gyro_calib.handoff import Provenance, method_calibration

        imu = self.imu_calibration()
        span = self.data_span_ns()
        if imu is None or span is None:
            return None
        conditions = {k: v for k, v in self.conditions().items()
                      if isinstance(v, str) and v or isinstance(v, (int, float))
                      and not isinstance(v, bool) and math.isfinite(v)}
        cal = method_calibration(self.name, {}, Provenance(source, span[0], span[1],
                                                           conditions=conditions),
                                 gyro_id=gyro_id)
        return dataclasses.replace(cal, imu=imu)

    # -- presentation -----------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """Scales (and 1/s), misalignments (°), biases, per sensor, with u and n."""
        rows: list[tuple[str, str, str, str]] = []
        if self._ferraris is not None:
            return [(f'Ferraris {k.removeprefix("imu.ferraris.")}', f'{e.value:.8g}',
                     f'{e.std_uncertainty:.2g}', str(e.n_used))
                    for k, e in self._ferraris_estimates().items()]
        r = self._result
        if r is None:
            return rows
        for fit in (r.accelerometer, r.gyro):
            if fit is None:
                continue
            unit = 'm/s²' if fit.sensor == 'accelerometer' else 'rad/s'
            inv, u_inv = inverse_scale(fit)
            for i, name in enumerate(fit.names):
                v, u = float(fit.values[i]), float(fit.std[i])
                if name.startswith('misalignment'):
                    rows.append((f'{fit.sensor} {name[:-4]} (°)', f'{math.degrees(v):.4f}',
                                 f'{math.degrees(u):.2g}', str(fit.n_used)))
                elif name.startswith('scale'):
                    j = 'xyz'.index(name[-1])
                    rows.append((f'{fit.sensor} {name} ({unit} per {fit.raw_unit}) '
                                 f'[1/s]', f'{v:.8g} [{inv[j]:.6g}]',
                                 f'{u:.2g} [{u_inv[j]:.2g}]', str(fit.n_used)))
                else:
                    rows.append((f'{fit.sensor} {name} ({fit.raw_unit})', f'{v:.8g}',
                                 f'{u:.2g}', str(fit.n_used)))
        return rows

    def summary_lines(self) -> list[str]:
        """Intervals used and rejected, g, the conditioning statement, what is missing."""
        r = self._result
        lines = []
        if self._ferraris is not None:
            lines.append('Ferraris variant (docs/methods.md §G.6): raw = K·R·x + b; the hand-off '
                         'holds (K·R)⁻¹ as M and A')
            lines.append(f'uncertainty: {self._ferraris.basis}')
        if r is not None:
            lines.append(f'static intervals: {len(r.detection.intervals)} used, '
                         f'{len(r.detection.rejected)} rejected (threshold '
                         f'{r.detection.threshold_ratio:g} × the recording\'s noise floor, '
                         f'window {r.detection.window} samples)')
            lines.append(f'g = {self.gravity:.6f} ± {self.gravity_std:.2g} m/s² '
                         f'({self.gravity_source})')
            lines += [f'conditioning: {c}' for c in r.conditioning]
            lines.append('pose set: well-conditioned (§G.5)' if r.well_conditioned else
                         f'pose set: not well-conditioned (§G.5): it lacks '
                         f'{"; ".join(r.lacking)}')
            for fit in (r.accelerometer, r.gyro):
                if fit is not None:
                    lines.append(f'{fit.sensor} uncertainty: {fit.basis}')
        if self._finished_line:
            lines.append(f'live: {self._finished_line} {self._after_finish} later samples '
                         'not used.')
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def json_section(self) -> dict[str, Any]:
        """The shared results and rejections, the conditioning, and the ``imu:`` section."""
        out = super().json_section()
        r = self._result
        if r is not None:
            out['conditioning'] = list(r.conditioning)
            for fit in (r.accelerometer, r.gyro):
                if fit is not None:
                    out[f'{fit.sensor}_covariance'] = {'names': list(fit.names),
                                                        'matrix': fit.covariance.tolist(),
                                                        'dof': [float(min(v, 1e12))
                                                                for v in fit.dof]}
        imu = self.imu_calibration()
        if imu is not None:
            out['imu'] = imu.to_section()
        return out
