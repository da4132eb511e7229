"""The dither method behind the shared front door (registry, CLI, bag calibration, hand-off).

Feeds :class:`~gyro_calib.dither.calibrator.DitherCalibrator` from ``/gyro/pulses`` and
``/vibration_table/joint_states`` (the orientation is each sample's header.frame_id, ``'z'``
or ``'y'``) exactly as ``dither_calibration_node`` does from DDS, so two bags give the same
numbers offline as when they are replayed into the node. The bags of the two orientations
are separate runs (:attr:`gyro_calib.registry.Method.separate_bags`): between them the
calibrator's recording is ended (:meth:`DitherSession.start_bag`); live, the change of
frame_id does the same (:meth:`DitherCalibrator.process`).

The scale factor K (rad/pulse) gives θ_d in rad: from ``--scale-factor-rad-per-pulse`` (the
node's ``scale_factor_rad_per_pulse``), else the settings file, else a hand-off file
(``--calibration``: its ``scale_factor_rad_per_pulse``, or ``k_tilde_rad_per_pulse``); without
it θ_d is reported in pulses and every figure that needs it says so. The misalignment itself
needs no K (it is a ratio of the sideband to the dither line).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

from gyro_calib.dither import topics
from gyro_calib.dither.calibrator import (
    AXES,
    COMPONENT_KEYS,
    DitherCalibrator,
    DitherSummary,
    describe_component,
)
from gyro_calib.dither.floor import (
    required_record_s,
    required_sample_rate_hz,
    required_table_rate_amplitude_rad_s,
)
from gyro_calib.dither.keys import (
    KEY_A,
    KEY_AMPLITUDE,
    KEY_AMPLITUDE_PULSES,
    KEY_CONING,
    KEY_CONING_TOTAL,
    KEY_FREQUENCY,
    KEY_LIMIT,
    KEY_LOWER,
    KEY_UPPER,
    KEY_VERDICT,
    KEY_Y,
    KEY_Z,
    METHOD,
)
from gyro_calib.dither.misalignment import RAD_PER_ARCMIN, Component
from gyro_calib.dither.settings import DitherSettings, dither_settings_from_mapping
from gyro_calib.dither.wording import arcmin, duration
from gyro_calib.errors import ConfigError
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.units import NS_PER_S, RAD_PER_ARCSEC

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection

JOINT_STATE = 'sensor_msgs/msg/JointState'
TOPICS = {topics.GYRO_PULSES: JOINT_STATE, topics.VIBRATION_TABLE_JOINT_STATES: JOINT_STATE}
NODE_NAME = 'dither_calibration_node'
DEG_H_PER_RAD_S = 180.0 / math.pi * 3600.0
"""°/h per rad/s."""


def _finite_or_none(value: Any) -> Any:
    """JSON-safe: non-finite floats become None (``--json`` refuses NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _scale_factor_from_file(path: Path) -> tuple[float, str, str]:
    """K from a hand-off file: its K, else its K̃ (they differ by cos θ, a few 1e-5).

    Returns:
        K (rad/pulse), the phrase for the summary, and where it came from (key and file).
    """
    from gyro_calib.handoff import load_calibration

    cal = load_calibration(path)
    for key, what in (('scale_factor_rad_per_pulse', 'K'),
                      ('k_tilde_rad_per_pulse', 'K̃ (taken for K; K = K̃·cos θ differs by '
                                                 'a few 1e-5, far below what θ_d needs)')):
        got = cal.measured(key)
        if got is not None:
            return got[0], f'{what} from {path}', f'{key} in {path}'
    raise ConfigError(f'calibration file {path} holds neither scale_factor_rad_per_pulse nor '
                      'k_tilde_rad_per_pulse: give --scale-factor-rad-per-pulse, or calibrate '
                      'the gyro\'s scale factor first (gyro-calib calibrate ... --method rbrlg '
                      '--out FILE).')


def dither_settings(options: CalibrationOptions) -> tuple[DitherSettings, str, str]:
    """The dither settings with K resolved, where K came from, and its origin.

    The settings (node parameters, then the config file's values) with K resolved, a
    sentence saying where K came from (or that it is unknown), and that origin in a few words
    for the run's hand-off conditions (``scale_factor_from``; '' without K).
    """
    values, source = options.method_settings(DitherSettings, NODE_NAME)
    settings = dither_settings_from_mapping(values, source=source)
    if options.scale_factor_rad_per_pulse is not None:
        k, where = float(options.scale_factor_rad_per_pulse), 'K given'
        origin = options.origin_of_given('scale_factor_rad_per_pulse')
    elif settings.has_scale_factor:
        k, where = settings.scale_factor_rad_per_pulse, f'K from {source}'
        origin = (f'config file {source}' if options.config_file is not None
                  else 'the node parameters')
    elif options.calibration_file is not None:
        k, where, origin = _scale_factor_from_file(options.calibration_file)
    else:
        return settings, ('no scale factor K given: θ_d is reported in pulses '
                          '(dither_amplitude_pulses) and the dither × rocking coning is not '
                          'computed; give --scale-factor-rad-per-pulse or --calibration FILE.'), ''
    if not (0 < k < 1e-2):
        raise ConfigError(f'scale factor K = {k!r} rad/pulse ({where}) is invalid: it must be '
                          'between 0 and 0.01 rad/pulse.')
    settings = dataclasses.replace(settings, scale_factor_rad_per_pulse=k)
    return settings, f'{where}: K = {k / RAD_PER_ARCSEC:.6g}″/pulse ({k:.6g} rad/pulse).', origin


class DitherSession(MethodSession):
    """Dither-axis misalignment a, its components, θ_d and the coning drift (METHODS §C)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Build the calibrator from the options."""
        settings, self.scale_factor_note, self.scale_factor_from = dither_settings(options)
        self.calibrator = DitherCalibrator(settings)
        self._pending: list[str] = []
        self._bags: list[str] = []

    # -- input ------------------------------------------------------------------------------
    def topics(self) -> dict[str, str]:
        """Pulses and the vibration table's joint_states."""
        return dict(TOPICS)

    def feed(self, batch: SampleBatch) -> None:
        """Pulses (position = cumulative count) and table states (angle, rate, frame_id)."""
        cal = self.calibrator
        pulses = batch.joint_state(topics.GYRO_PULSES)
        if pulses is not None:
            cal.extend_pulses(pulses[0], pulses[1])
        table = batch.columns.get(topics.VIBRATION_TABLE_JOINT_STATES)
        if table is not None and len(table):
            codes, names = table.frame_id.codes, table.frame_id.names
            first = int(codes[0])
            if bool((codes == first).all()):
                frame: str | list[str] = names[first]
            else:
                frame = [names[c] for c in codes.tolist()]
            cal.extend_table_states(table.stamp_ns, table.values['position'],
                                    table.values['velocity'], frame)

    def start_bag(self, index: int, path: Path) -> None:
        """Bag ``index`` begins: end the previous bag's recording (its last block judged)."""
        self._bags.append(str(path))
        if index > 0:
            self._pending.extend(self.calibrator.end_recording())

    def process(self, *, flush: bool = False) -> list[str]:
        """Reduce the blocks the data allow; new log lines."""
        lines, self._pending = self._pending, []
        return lines + self.calibrator.process(flush=flush)

    # -- results ----------------------------------------------------------------------------
    def _all_results(self) -> dict[str, Estimate]:
        return self.calibrator.results()

    def results(self) -> dict[str, Estimate]:
        """By hand-off key (SI), those with a finite value and uncertainty."""
        return {k: e for k, e in self._all_results().items()
                if math.isfinite(e.value) and math.isfinite(e.std_uncertainty)}

    def missing(self) -> dict[str, str]:
        """Why each dither key is not measured (yet)."""
        out = self.calibrator.missing()
        for key, est in self._all_results().items():
            if key not in out and not (math.isfinite(est.value)
                                       and math.isfinite(est.std_uncertainty)):
                out[key] = (f'only {est.n_used} accepted block: its uncertainty needs the '
                            'scatter of at least two.')
        return out

    def needs(self) -> dict[str, str]:
        """What each orientation still needs.

        Per orientation without a component: how many more accepted blocks (and seconds
        of table motion along it); then the other reasons, once each.
        """
        cal, s = self.calibrator, self.calibrator.settings
        components = cal.summary().components
        out: dict[str, str] = {}
        for axis, rec in cal.orientations.items():
            if axis in components:
                continue
            more = s.min_blocks - len(rec.blocks)
            if more > 0:  # else withheld for another reason, said by missing()
                out[COMPONENT_KEYS[axis]] = (
                    f'the {axis.upper()} orientation needs {more} more accepted block(s) of '
                    f'{s.block_s:g} s (about {more * s.block_s:g} s with the table along '
                    f'{axis.upper()}); {len(rec.blocks)} of {s.min_blocks} so far')
        for key, why in super().needs().items():
            out.setdefault(key, why)
        return out

    def rejections(self) -> list[Rejection]:
        """Blocks rejected, each with its reason."""
        return list(self.calibrator.rejections)

    def notices(self) -> list[str]:
        """Samples the streams dropped (duplicates, non-finite, late) and restarts."""
        out = []
        for name, buf in ((topics.GYRO_PULSES, self.calibrator.pulses),
                          (topics.VIBRATION_TABLE_JOINT_STATES, self.calibrator.table)):
            summary = buf.stats.summary()
            if summary:
                out.append(f'{name}: {summary}')
        return out

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first to the last accepted block's samples."""
        blocks = [b for r in self.calibrator.orientations.values() for b in r.blocks]
        if not blocks:
            return None
        return (min(b.start_ns for b in blocks),
                max(b.start_ns + int(round(b.span_s * NS_PER_S)) for b in blocks))

    def conditions(self) -> dict[str, Any]:
        """The scale factor K θ_d and the angles rest on, and where it came from (none: {})."""
        s = self.calibrator.settings
        if not s.has_scale_factor:
            return {}
        return {'scale_factor_rad_per_pulse': s.scale_factor_rad_per_pulse,
                'scale_factor_from': self.scale_factor_from}

    # -- reports ----------------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """a, the two components, θ_d, f_d and the coning drift in the paper's units."""
        res = {k: e for k, e in self._all_results().items() if math.isfinite(e.value)}
        rows: list[tuple[str, str, str, str]] = []

        def add(name: str, key: str, scale: float, fmt: str) -> None:
            est = res.get(key)
            if est is None:
                rows.append((name, '—', '', ''))
            else:
                std = (f'{est.std_uncertainty * scale:.3g}'
                       if math.isfinite(est.std_uncertainty) else 'unbounded')
                rows.append((name, f'{est.value * scale:{fmt}}', std, str(est.n_used)))

        per_arcmin = 1.0 / RAD_PER_ARCMIN
        add('a (′)', KEY_A, per_arcmin, '.3f')
        add('a·|sin ψ₀|, table along Z (′)', KEY_Z, per_arcmin, '.3f')
        add('a·|cos ψ₀|, table along Y (′)', KEY_Y, per_arcmin, '.3f')
        if self.calibrator.settings.has_scale_factor:
            add('θ_d (′)', KEY_AMPLITUDE, per_arcmin, '.4f')
        else:
            add('θ_d (pulses; no K given)', KEY_AMPLITUDE_PULSES, 1.0, '.3f')
        add('f_d (Hz)', KEY_FREQUENCY, 1.0, '.4f')
        add('ε eq. (24) (°/h)', KEY_CONING, DEG_H_PER_RAD_S, '.3g')
        add('ε with dither × rocking (°/h)', KEY_CONING_TOTAL, DEG_H_PER_RAD_S, '.3g')
        return rows

    def summary_lines(self) -> list[str]:
        """The summary lines of a dither run.

        Each component and a with the floor beside it, the verdict (only when the record
        decides it; else what record would), the coning, K's source and what is missing.
        """
        cal = self.calibrator
        n = {axis: rec.equations.n_blocks for axis, rec in cal.orientations.items()}
        lines = [f'blocks accepted: {n["z"]} with the table along Z, {n["y"]} along Y; '
                 f'rejected: {len(cal.rejections)}']
        lines += cal.summary().lines()
        lines.append(self.scale_factor_note)
        lines.append('rocking: ' + self._rocking_note())
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def _rocking_note(self) -> str:
        s = self.calibrator.settings
        if s.rocking_treatment == 'bound' and not s.has_scale_factor:
            return ('in-phase transverse rocking NOT bounded without K: the allowance k·a/θ_d '
                    'needs θ_d in rad, so a and its components are given with their '
                    'statistical part and an unbounded uncertainty (give K, or set '
                    'rocking_treatment: none if the bench has no transverse rocking).')
        if s.rocking_treatment == 'bound':
            rocking = self.calibrator.summary().rocking
            what = rocking.description() if rocking is not None else ''
            return (f'allowance for in-phase transverse rocking (rocking_treatment = bound): '
                    f'{what}. It is an interval on a, not a random error: the verdict uses '
                    'the interval; std combines it as a rectangular bound/√3.')
        if s.rocking_treatment == 'model':
            return ('measured in-phase rocking subtracted (rocking_treatment = model: '
                    f'{s.rocking_in_phase_xz_arcsec:g}″ about Y, '
                    f'{s.rocking_in_phase_xy_arcsec:g}″ '
                    'about Z).')
        return 'ignored (rocking_treatment = none): a may be biased by the in-phase rocking.'

    def info_lines(self) -> list[str]:
        """The info lines of a dither record.

        Per orientation: the record, its detection floor, and the record length, sample
        rate or table amplitude a target σ per component needs; then a and the verdict.
        """
        cal = self.calibrator
        s = cal.settings
        comps, why_not = cal.components()
        summary = cal.summary()
        target = s.target_std_rad
        target_what = (f'half the {s.max_misalignment_arcmin:g}′ limit at k = '
                       f'{s.verdict_coverage_factor:g}' if math.isnan(s.target_std_arcmin)
                       else 'target_std_arcmin')
        lines = [f'target σ per component: {arcmin(target)} ({target_what})']
        for axis in AXES:
            c = comps.get(axis)
            if c is None:
                lines.append(f'table along {axis.upper()}: {why_not.get(axis, "not measured.")}')
                continue
            lines += self._orientation_info(axis, c, summary, target)
        line = summary.misalignment_line()
        if line is not None:
            lines.append(line)
        elif comps:
            lines.append('a = √(z² + y²) needs both orientations measured: ' + (
                'record the other orientation (the table along '
                + ' and '.join(a.upper() for a in AXES if a not in summary.components) + ').'))
        if summary.verdict is not None:
            lines.append(summary.verdict.sentence)
        lines.append(self.scale_factor_note)
        return lines

    def _orientation_info(self, axis: str, c: Component, summary: DitherSummary,
                          target: float) -> list[str]:
        cal = self.calibrator
        rec = cal.orientations[axis]
        amp = rec.mean('table_rate_amplitude_rad_s')
        fz, fd = rec.mean('table_frequency_hz'), rec.mean('dither_frequency_hz')
        theta_pulses = rec.mean('dither_amplitude_pulses')
        s = cal.settings
        theta = (f'θ_d = {theta_pulses:.1f} pulses'
                 + (f' = {arcmin(theta_pulses * s.scale_factor_rad_per_pulse)}'
                    if s.has_scale_factor else ''))
        arw_pulses = (math.radians(s.angle_random_walk_deg_sqrt_h) / 60.0
                      / s.scale_factor_rad_per_pulse if s.has_scale_factor else 0.0)
        common = dict(dither_amplitude_rad=theta_pulses, scale_factor_rad_per_pulse=1.0,
                      angle_random_walk_rad_sqrt_s=arw_pulses, dither_frequency_hz=fd,
                      table_frequency_hz=fz)
        t_need = required_record_s(target, table_rate_amplitude_rad_s=amp,
                                   sample_rate_hz=c.sample_rate_hz, **common)
        f_need = required_sample_rate_hz(target, record_s=c.record_s,
                                         table_rate_amplitude_rad_s=amp, **common)
        a_need = required_table_rate_amplitude_rad_s(target, record_s=c.record_s,
                                                     sample_rate_hz=c.sample_rate_hz, **common)
        rate = (f'{f_need / 1000:.3g} kHz' if math.isfinite(f_need)
                else 'no sample rate (angle random walk alone is above it)')
        floor = c.floor
        out = [
            f'table along {axis.upper()}: {c.n_blocks} blocks, {c.record_s:.0f} s of pulses at '
            f'{c.sample_rate_hz:.0f} Hz; table {fz:.3f} Hz, A = {amp:.3g} rad/s; dither '
            f'{fd:.3f} Hz, {theta}',
            f'  detection floor of this record: σ_c = {arcmin(floor.component_std_rad)} per '
            f'component (quantisation {arcmin(floor.quantisation_std_rad)}, angle random walk '
            + (f'{arcmin(floor.arw_std_rad)})' if arw_pulses else
               'not given: angle_random_walk_deg_sqrt_h, ~1e-5 of the variance on an RLG)'),
            f'  for σ_c = {arcmin(target)}: record {duration(t_need)} in this orientation '
            f'(at A = {amp:.3g} rad/s, {c.sample_rate_hz:.0f} Hz), or sample at {rate} '
            f'(this {c.record_s:.0f} s record), or A ≥ {a_need:.3g} rad/s (this record and '
            'rate)',
        ]
        out.append('  ' + describe_component(c).split(': ', 1)[1])
        if axis in summary.unresolved:
            out.append('  ' + summary.unresolved[axis])
        return out

    def limiting(self) -> str:
        """What limits the result most, as an action."""
        cal = self.calibrator
        summary = cal.summary()
        measured = summary.components
        if not measured:
            last = cal.rejections[-1].reason if cal.rejections else (
                'no block of pulses and table joint_states yet.')
            return f'no accepted block: {last}'
        verdict = summary.verdict
        for axis in AXES:
            if axis in summary.unresolved:
                return summary.unresolved[axis]
        missing = [a for a in AXES if a not in measured]
        if missing:
            lead = (f'a needs the table along {" and ".join(m.upper() for m in missing)} too: '
                    'one orientation sees only a·|sin ψ₀| or a·|cos ψ₀|')
            if verdict is not None and verdict.decided:
                return f'{lead} ({verdict.sentence})'
            return lead + '.'
        m = summary.misalignment
        if verdict is not None and not verdict.decided:
            return verdict.sentence
        if m is not None:
            if math.isinf(m.rocking_bound_rad):
                return ('the rocking allowance is unbounded: '
                        + next(c.rocking_note for c in measured.values() if c.rocking_note) + '.')
            if m.rocking_bound_rad > m.random_std_rad:
                return (f'the rocking allowance (±{arcmin(m.rocking_bound_rad)} on a, an '
                        f'interval) dominates the record\'s statistical '
                        f'{arcmin(m.random_std_rad)}: measure the in-phase rocking '
                        '(rocking_treatment = model).')
            return (f'the detection floor: u(a) = {arcmin(m.std_rad)} falls as 1/√(f_s·T) '
                    '(longer records, faster sampling) or 1/A (larger table amplitude).')
        return 'every quantity measured.'

    def handoff_values(self) -> dict[str, Any]:
        """The hand-off values of a dither run.

        The measured keys with their ``_std`` (finite ones), then the verdict, a's interval
        ends and the limit they were judged against.
        """
        out = super().handoff_values()
        summary = self.calibrator.summary()
        if summary.verdict is not None and summary.interval is not None:
            out[KEY_VERDICT] = summary.verdict.state
            out[KEY_LOWER] = summary.interval.lower_rad
            if math.isfinite(summary.interval.upper_rad):
                out[KEY_UPPER] = summary.interval.upper_rad
            out[KEY_LIMIT] = self.calibrator.settings.max_misalignment_arcmin * RAD_PER_ARCMIN
        return out

    def json_section(self) -> dict[str, Any]:
        """Results (with their parts), missing, rejections, components, a, verdict, K.

        Each result keeps ``value``, ``std`` (null when unbounded) and ``n``; the
        misalignment keys add ``std_statistical``, ``systematic_bound`` (half-width, null when
        unbounded), ``systematic_model``, ``interval`` and ``coverage_factor``.
        """
        out = super().json_section()
        cal = self.calibrator
        summary = cal.summary()
        results: dict[str, Any] = {}
        parts = cal.result_parts()
        for key, est in self._all_results().items():
            if not math.isfinite(est.value):
                continue
            entry: dict[str, Any] = {'value': est.value,
                                     'std': _finite_or_none(float(est.std_uncertainty)),
                                     'n': est.n_used}
            for name, value in parts.get(key, {}).items():
                entry[name] = ([_finite_or_none(float(v)) for v in value]
                               if isinstance(value, list) else _finite_or_none(value))
            results[key] = entry
        out['results'] = results
        comps = summary.components
        section: dict[str, Any] = {}
        for axis, c in comps.items():
            section[axis] = {k: _finite_or_none(v) for k, v in {
                'reported': True,
                'unresolved': summary.unresolved.get(axis),
                'value_rad': c.magnitude_rad, 'signed_rad': c.signed_rad,
                'std_rad': c.std_rad, 'statistical_std_rad': c.statistical_std_rad,
                'random_std_rad': c.random_std_rad,
                'rocking_bound_rad': c.rocking_bound_rad,
                'floor_rad': c.floor.component_std_rad, 'n_blocks': c.n_blocks,
                'record_s': c.record_s, 'sample_rate_hz': c.sample_rate_hz,
                'table_rate_amplitude_rad_s': cal.orientations[axis].mean(
                    'table_rate_amplitude_rad_s'),
                'table_frequency_hz': cal.orientations[axis].mean('table_frequency_hz'),
            }.items()}
        out['components'] = section
        m = summary.misalignment
        out['misalignment'] = None if m is None else {k: _finite_or_none(v) for k, v in {
            'value_rad': m.value_rad, 'std_rad': m.std_rad,
            'statistical_std_rad': m.statistical_std_rad, 'random_std_rad': m.random_std_rad,
            'rocking_bound_rad': m.rocking_bound_rad, 'rho': m.rho,
            'floor_rad': max(c.floor.component_std_rad for c in comps.values()),
            'azimuth_rad': m.azimuth_rad, 'resolved': m.resolved}.items()}
        v, iv = summary.verdict, summary.interval
        out['verdict'] = None if v is None or iv is None else {
            'state': v.state, 'decided': v.decided, 'accepted': v.accepted,
            'sentence': v.sentence,
            'limit_rad': cal.settings.max_misalignment_arcmin * RAD_PER_ARCMIN,
            'lower_rad': iv.lower_rad, 'upper_rad': _finite_or_none(iv.upper_rad),
            'lower_from': iv.lower_from, 'coverage_factor': iv.coverage_factor,
            'more_record_s': _finite_or_none(v.more_record_s),
            'sample_rate_needed_hz': _finite_or_none(v.sample_rate_needed_hz),
            'table_rate_amplitude_needed_rad_s':
                _finite_or_none(v.table_rate_amplitude_needed_rad_s)}
        rocking = summary.rocking
        out['rocking_allowance'] = None if rocking is None else {
            'treatment': rocking.treatment, 'model': rocking.model,
            'kappa': _finite_or_none(rocking.kappa), 'rho': _finite_or_none(rocking.rho),
            'description': rocking.description()}
        out['scale_factor'] = {
            'rad_per_pulse': _finite_or_none(cal.settings.scale_factor_rad_per_pulse),
            'note': self.scale_factor_note}
        out['notes'] = list(summary.notes.values())
        return out

    def plot(self, out_dir: Path) -> list[Path]:
        """Spectra with lines and sidebands, regression residuals, ε against a."""
        from gyro_calib.dither.plots import plot_dither

        return plot_dither(self.calibrator, out_dir)
