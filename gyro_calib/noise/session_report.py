"""What a noise run says: conditions, summary, limits, figure, Kalibr file (METHODS §E).

Also the refusal when nothing can be measured (:class:`NoNoiseDataError`).

:class:`NoiseReport` is mixed into :class:`~gyro_calib.noise.session.NoiseSession` and reads
the session's state (input kind, scale factors, settings, the calibrator results come from).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.noise.inputs import (
    FOG_OUTPUT,
    GYRO_PULSES,
    GYRO_TOPICS,
    IMU,
    IMU_PULSES,
    JOINT_STATE,
)
from gyro_calib.noise.outliers import OutlierReport
from gyro_calib.noise.scale_factors import ScaleFactor, TriadScales, _positive
from gyro_calib.noise.terms import SYMBOLS

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.noise.calibrator import AxisResult, NoiseCalibrator
    from gyro_calib.noise.fit import NoiseFit
    from gyro_calib.noise.settings import NoiseSettings

FIGURE_NAME = 'noise_adev.png'
"""File name of the Allan-deviation figure when a directory is given."""


class NoNoiseDataError(InsufficientDataError):
    """No axis of the input yields an Allan deviation.

    No axis of the input yields an Allan deviation (constant, non-finite, too short,
    no scale factor): no noise term can be measured.
    """


class NoiseReport:
    """The reporting half of :class:`~gyro_calib.noise.session.NoiseSession`.

    Reads the session's input kind and topic, scale factors, settings and :attr:`view`.
    """

    kind: str
    topic: str | None
    settings: NoiseSettings
    calibrator: NoiseCalibrator
    pulse_scale: ScaleFactor
    fog_scale: ScaleFactor
    triad_scale: TriadScales

    if TYPE_CHECKING:
        @property
        def view(self) -> NoiseCalibrator | None:
            """The calibrator results come from (:attr:`NoiseSession.view`)."""

        def axis_results(self) -> dict[str, AxisResult]:
            """Curve, fit and reason of every axis (:meth:`NoiseSession.axis_results`)."""

        def missing(self) -> dict[str, str]:
            """Every term not resolved (:meth:`NoiseSession.missing`)."""

    def conditions(self) -> dict[str, Any]:
        """The scale factor the terms in rad rest on, and where it came from.

        ``scale_factor_rad_per_pulse`` (/gyro/pulses) or ``fog_scale_factor_counts_per_rad``
        (/fog/output) with ``scale_factor_from``; nothing for an Imu (no scale factor).
        """
        inputs = self.calibrator.inputs()
        out: dict[str, Any] = {}
        if 'triad' in inputs and self.triad_scale.known:
            out = {'triad_scale_factors_rad_per_pulse': ', '.join(
                f'{c} {k:.10g}' for c, k in zip(self.triad_scale.channels,
                                                 self.triad_scale.values)),
                   'scale_factor_from': self.triad_scale.source}
        for stream, name, scale in (('pulses', 'scale_factor_rad_per_pulse', self.pulse_scale),
                                    ('fog', 'fog_scale_factor_counts_per_rad', self.fog_scale)):
            if stream in inputs and scale.known:
                out = {name: scale.value, 'scale_factor_from': scale.source}
                break
        return {**out, **self.outlier_conditions()}

    def outlier_conditions(self) -> dict[str, Any]:
        """The spike treatment the terms rest on, for the run's conditions (§E.6).

        ``outliers`` (keep or remove), ``outlier_sigma``, ``outliers_found`` (all axes)
        and ``outliers_report`` (each axis with spikes: how many, the largest, what the other
        treatment changes; 'none' without spikes).
        """
        s = self.settings
        view = self.view
        reports = ([r.outliers for r in view.axis_results().values() if r.outliers is not None]
                   if view is not None else [])
        found = sum(r.tally.spikes for r in reports)
        words = []
        for r in reports:
            if not r.tally.spikes:
                continue
            change = (r.changes_words() if s.outliers == 'keep' else r.reverse_words())
            verb = 'removing' if s.outliers == 'keep' else 'keeping'
            words.append(f'{r.axis}: {r.tally.spikes} of {r.tally.screened} (largest '
                         f'{r.tally.largest_sigma:.4g} σ); {verb} them changes {change}')
        return {'outliers': s.outliers, 'outlier_sigma': float(s.outlier_sigma),
                'outliers_found': int(found), 'outliers_report': '; '.join(words) or 'none'}

    def check_measurable(self) -> None:
        """Raise unless at least one axis gives an Allan deviation in SI units.

        Raises:
            NoNoiseDataError: naming each axis's reason (constant, non-finite, too short,
                no scale factor, no samples).
        """
        results = self.axis_results()
        if any(r.curve is not None for r in results.values()):
            return
        where = self.topic or f'{GYRO_PULSES} / {FOG_OUTPUT}'
        if not results:
            raise NoNoiseDataError(f'no sample of {where} was analysed: nothing to '
                                   'characterise; nothing was written.')
        groups: dict[str, list[str]] = {}  # the same reason on several axes: said once
        for axis, res in results.items():
            groups.setdefault(res.reason.replace(axis, '{axis}', 1), []).append(axis)
        reasons = [why.replace('{axis}', axes[0] if len(axes) == 1 else
                               f'each axis ({", ".join(axes)})', 1)
                   for why, axes in groups.items()]
        raise NoNoiseDataError(f'no noise term can be measured from {where}: '
                               + ' '.join(reasons) + ' Nothing was written.')

    def deviation_tables(self) -> dict[str, dict[str, Any]]:
        """The per-τ ADEV, MDEV, HDEV and TOTDEV of each axis, for the hand-off file.

        The per-τ ADEV, MDEV, HDEV and TOTDEV of each axis with their standard
        uncertainties and EDF (``methods.noise.deviations``; the same numbers as ``--json``'s
        ``axes``), in the axis's rate unit.
        """
        from gyro_calib.handoff import DEVIATION_FIELDS

        view = self.view
        if view is None:
            return {}
        units = {axis: res.units.rate_unit for axis, res in view.axis_results().items()}
        return {axis: {k: (units[axis] if k == 'unit' else record[k]) for k in DEVIATION_FIELDS
                       if k == 'unit' or k in record}
                for axis, record in view.json_section()['axes'].items()}

    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """One row per resolved term: SI and the quoted unit (°/√h, °/h, µg …)."""
        rows = []
        for axis, res in self.axis_results().items():
            if res.fit is None:
                continue
            u = res.units
            for k, key in enumerate(u.keys):
                est = res.fit.estimates.get(key)
                if est is None:
                    continue
                q = u.quoted_factors[k]
                rows.append((f'{axis}: {u.names[k]}',
                             f'{est.value:.4g} {u.si_units[k]} = {est.value * q:.4g} '
                             f'{u.quoted_units[k]}',
                             f'{est.std_uncertainty:.2g} {u.si_units[k]} = '
                             f'{est.std_uncertainty * q:.2g} {u.quoted_units[k]}',
                             str(est.n_used)))
        return rows

    def _input_line(self) -> str:
        view = self.view
        rate = ''
        if view is not None and view.axes():
            hz = view.sample_rate_hz(view.axes()[0])
            if math.isfinite(hz):
                rate = f', {hz:.6g} Hz'
        if self.kind == 'imu':
            return f'input: {self.topic} ({IMU}), 6 axes{rate}.'
        if self.kind == 'triad':
            ks = self.triad_scale
            known = '; '.join(f'K_{c} = {k:.10g}' for c, k in zip(ks.channels, ks.values)
                              if _positive(k))
            return (f'input: {IMU_PULSES} ({JOINT_STATE}), {len(ks.channels)} channels'
                    f'{rate}' + (f'; {known} rad/pulse from {ks.source}' if known else '')
                    + '.')
        parts = []
        if self.kind in ('pulses', 'gyro') and self.pulse_scale.known:
            parts.append(f'K = {self.pulse_scale.value:.10g} rad/pulse from '
                         f'{self.pulse_scale.source}')
        if self.kind in ('fog', 'gyro') and self.fog_scale.known:
            parts.append(f'scale factor {self.fog_scale.value:.10g} counts/rad from '
                         f'{self.fog_scale.source}')
        topic = self.topic or ' or '.join(GYRO_TOPICS)
        return f'input: {topic} ({JOINT_STATE}){rate}' + (f'; {"; ".join(parts)}'
                                                           if parts else '') + '.'

    @staticmethod
    def _bounds(res: AxisResult) -> str:
        fit: NoiseFit | None = res.fit
        if fit is None:
            return ''
        u, parts = res.units, []
        for k, key in enumerate(u.keys):
            upper = fit.upper_bounds.get(key)
            if key in fit.estimates or upper is None:
                continue
            q = u.quoted_factors[k]
            parts.append(f'{SYMBOLS[k]} < {upper:.3g} {u.si_units[k]} ({upper * q:.3g} '
                         f'{u.quoted_units[k]})')
        return ', '.join(parts)

    def summary_lines(self) -> list[str]:
        """The summary lines of a noise run.

        Input and scale factor, the stream counts (re-sorted, duplicates, late, gaps …),
        the terms not resolved with their 2σ bounds, and axes without any term.
        """
        lines = [self._input_line()]
        view = self.view
        if view is None:
            lines.append(f'no samples analysed yet on {self.topic or " or ".join(GYRO_TOPICS)}.')
            return lines
        lines += [c.line() for c in view.stream_counts()]
        motion = view.table_line()
        if motion:
            lines.append(motion)
        scaled = []
        for axis, res in view.axis_results().items():
            if res.fit is None:
                lines.append(f'{axis}: no term — {res.reason}')
                continue
            if res.taus_left_out:
                lines.append(f'{axis}: {res.taus_left_out}')
            bounds = self._bounds(res)
            if bounds:
                lines.append(f'{axis}: not resolved (2σ upper bounds): {bounds}.')
            if res.fit.covariance_scale > 1.0:
                scaled.append(f'{axis} (χ² ratio {res.fit.chi2_ratio:.3g})')
            curve = res.curve
            if curve is not None and 'Q' in res.fit.symbols_resolved and self.kind != 'imu':
                lines.append(f'{axis}: quantisation Q shows because the sub-pulse phase moves '
                             '(dither or rotation); a static, locked-in RLG shows none.')
        lines += OutlierReport.lines([res.outliers for res in view.axis_results().values()
                                      if res.outliers is not None])
        if scaled:
            lines.append('the model fits the Allan variance worse than its scatter allows on '
                         f'{", ".join(scaled)}: those uncertainties were scaled up by √ratio.')
        if any(r.fit is not None for r in view.axis_results().values()):
            where = ('imu.noise.<channel> keeps its 2σ bound' if self.kind == 'triad'
                     else 'hand-off missing: with the reason')
            lines.append(f'terms not resolved are absent ({where}); '
                         'gyro-calib info BAG --method noise prints every reason.')
        return lines

    def info_lines(self) -> list[str]:
        """The summary lines and every missing term's full reason."""
        return self.summary_lines() + [f'  {k}: {why}' for k, why in self.missing().items()]

    def limiting(self) -> str:
        """What limits the result most.

        What limits the result most: the reason nothing is measured, else the least
        certain term and the record length behind it.
        """
        results = self.axis_results()
        if not any(r.fit is not None and r.fit.estimates for r in results.values()):
            reasons = [r.reason for r in results.values() if r.reason]
            if reasons:
                return reasons[0]
            return next(iter(self.missing().values()), 'no input for noise characterisation.')
        worst: tuple[float, str, AxisResult] | None = None
        unresolved = 0
        for axis, res in results.items():
            if res.fit is None:
                unresolved += 5
                continue
            unresolved += 5 - len(res.fit.estimates)
            for k, key in enumerate(res.units.keys):
                est = res.fit.estimates.get(key)
                if est is not None and (worst is None or est.relative_uncertainty > worst[0]):
                    worst = (est.relative_uncertainty, f'{axis} {res.units.names[k]}', res)
        assert worst is not None
        rel, label, res = worst
        curve = res.curve
        span = ''
        if curve is not None:
            span = (f'; the longest averaging time is {curve.tau_s[-1]:.3g} s of '
                    f'{curve.n_rate_samples * curve.tau0_s:.4g} s analysed, and a record k× '
                    f'longer narrows it about √k×')
        tail = (f'; {unresolved} term(s) not resolved (a longer record, or the slope is '
                f'not there)' if unresolved else '')
        return f'{label} is known to ±{rel:.1%} (k = 1){span}{tail}.'

    def plot(self, out_dir: Path) -> list[Path]:
        """One PNG with a log-log ADEV panel per axis (``noise_adev.png``)."""
        from gyro_calib.noise.plots import plot_noise_figure

        view = self.view
        if view is None or not view.axes():
            return []
        return [plot_noise_figure(view, out_dir / FIGURE_NAME)]

    def kalibr_left_out(self) -> list[str]:
        """Axes left out of the Kalibr file, one line each with the reason."""
        from gyro_calib.noise.kalibr import kalibr_left_out

        view = self.view
        return kalibr_left_out(view) if view is not None else []

    def kalibr_text(self) -> str:
        """Kalibr ``imu.yaml`` text of an IMU run (largest of the three axes per key).

        Raises:
            ConfigError: the input is a single-axis gyro (Kalibr needs an IMU).
            KalibrExportError: an axis has neither the term nor an upper bound.
        """
        from gyro_calib.noise.kalibr import kalibr_imu_yaml

        if self.kind != 'imu':
            raise ConfigError(f'Kalibr\'s imu.yaml describes an IMU (gyro and accelerometer '
                              f'triads); {self.topic or "the gyro stream"} is a single-axis '
                              'gyro: use --out (hand-off file) or --json instead.')
        view = self.view
        if view is None or not view.axes():
            raise NoNoiseDataError(f'no sample of {self.topic} was analysed: no Kalibr file.')
        assert self.topic is not None
        return kalibr_imu_yaml(view, rostopic=self.topic)
