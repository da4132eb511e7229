"""The FOG method behind the shared front door (registry, CLI, bag calibration, hand-off, node).

Feeds :class:`~gyro_calib.fog.calibrator.FogCalibrator` from the topic contract (issue 10
Part 1 item 2) exactly as ``fog_calibration_node`` does from DDS, so a bag gives the same
numbers offline as replayed into the node. The summary speaks a FOG laboratory's units:
K in counts/rad and in (counts/s)/(°/s), nonlinearity and asymmetry in ppm, bias in °/h,
angle random walk in °/√h, the linear range in °/s.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib import topics
from gyro_calib.fog.calibrator import (
    KEY_ARW,
    KEY_ASYMMETRY,
    KEY_BIAS,
    KEY_BIAS_PLUS_EARTH,
    KEY_CUBIC,
    KEY_MAPPING,
    KEY_NONLINEARITY,
    KEY_QUADRATIC,
    KEY_SCALE_FACTOR,
    KEY_SELF_CAL,
    KEY_SELF_CAL_DIFFERENCE,
    KEY_SELF_CAL_NONLINEARITY,
    KEY_SELF_CAL_RANGE,
    KEY_SELF_CAL_SMALL_SIGNAL,
    SELF_CAL_KEYS,
    FogCalibrator,
)
from gyro_calib.fog.keys import METHOD
from gyro_calib.fog.self_cal import SETTLING_NOTE, SelfCalFit
from gyro_calib.fog.settings import FogSettings, fog_settings_from_mapping
from gyro_calib.fog.turntable import MappingFit, TurntableFit, pooled_noise
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from collections.abc import Sequence
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection

TOPICS = {topics.FOG_OUTPUT: 'sensor_msgs/msg/JointState',
          topics.FOG_INJECTION: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_JOINT_STATES: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_ZERO_INDEX: 'std_msgs/msg/Header'}

DEG = math.pi / 180.0
"""rad per degree."""
DEG_H = DEG / 3600.0
"""rad/s per °/h."""
DEG_SQRT_H = DEG / 60.0
"""rad/√s per °/√h."""
PAPER_ROWS = (6, 10, 15, 25, 35, 45, 55)
"""Plateau counts of seed 001 Table 1 (shown in the summary's self-calibration table)."""


def fog_settings(options: CalibrationOptions) -> FogSettings:
    """The FOG settings from parameters, config file and flags.

    The FOG settings: the node's parameters, then the config file's values, then the
    latitude from the flags or the bag.
    """
    values, source = options.method_settings(FogSettings, 'fog_calibration_node')
    settings = fog_settings_from_mapping(values, source=source) if values else FogSettings()
    latitude = options.latitude
    if math.isfinite(latitude):
        settings = dataclasses.replace(settings, latitude_deg=latitude)
    return settings


class FogSession(MethodSession):
    """Turntable K (IEEE Std 952), equivalence mapping and ladder-wave self-calibration."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Build the calibrator from the options."""
        self.calibrator = FogCalibrator(fog_settings(options))
        self._ended = False

    def topics(self) -> dict[str, str]:
        """Output, injection and (for the turntable phases) the rate table."""
        return dict(TOPICS)

    def feed(self, batch: SampleBatch) -> None:
        """Output counts, injection levels, table joint_states and zero-index events."""
        cal = self.calibrator
        out = batch.joint_state(topics.FOG_OUTPUT)
        if out is not None:
            cal.extend_output(out[0], out[1])
        inj = batch.joint_state(topics.FOG_INJECTION)
        if inj is not None:
            cal.extend_injection(inj[0], inj[1])
        table = batch.joint_state(topics.RATE_TABLE_JOINT_STATES)
        if table is not None:
            cal.extend_table_states(*table)
        index = batch.stamps(topics.RATE_TABLE_ZERO_INDEX)
        if index is not None:
            cal.extend_zero_index(index)

    def late_input(self, late: Sequence[tuple[str, int]]) -> list[str]:
        """Reject every segment and plateau a late sample falls in (now or when it closes)."""
        return self.calibrator.reject_late(late)

    def end_of_recording(self) -> None:
        """The recording ended: the next process() flushes.

        The recording ended (a live node stops): the next :meth:`process` flushes, so the
        last open segment and plateau are measured as offline at the end of a bag.
        """
        self._ended = True

    def process(self, *, flush: bool = False) -> list[str]:
        """Measure finished segments and plateaus."""
        return self.calibrator.process(flush=flush or self._ended)

    def results(self) -> dict[str, Estimate]:
        """The FOG results by hand-off key.

        By hand-off key (SI units in the names); no full-scale nonlinearity from a table
        that turned only at the mapping rates (:meth:`mapping_rates_only`).
        """
        out = self.calibrator.results()
        if self.mapping_rates_only() and KEY_NONLINEARITY in out:
            del out[KEY_NONLINEARITY]
        return out

    def mapping_rates_only(self) -> str:
        """Why the turntable fit has no full-scale nonlinearity.

        Why the turntable fit has no full-scale nonlinearity ('' if it has): every segment
        was at an equivalence-mapping rate (a mapping bench, seed 001 §3: 20–21 °/s).
        """
        segments = self.calibrator.active_segments
        settings = self.calibrator.settings
        if not segments:
            return ''
        rates = [abs(math.degrees(s.rate_rad_s)) for s in segments]
        if all(any(abs(r - m) <= settings.mapping_rate_tolerance_deg_s
                   for m in settings.mapping_rates_deg_s) for r in rates):
            return (f'the table turned only at the equivalence-mapping rates ({min(rates):.4g}–'
                    f'{max(rates):.4g} °/s): a full-scale (IEEE Std 952) nonlinearity needs '
                    'rates over the gyro\'s range, so none is given (the self-calibration '
                    'states its own, fog_self_cal_nonlinearity_ppm).')
        return ''

    def missing(self) -> dict[str, str]:
        """Why each FOG key is not measured."""
        out = self.calibrator.missing()
        why = self.mapping_rates_only()
        if why:
            out[KEY_NONLINEARITY] = why
        return out

    def not_measurable(self) -> dict[str, str]:
        """Keys a bench of this kind cannot measure, with why.

        Self-calibration (and mapping) keys of a bench without injection; turntable keys of
        a bench without a rate table; the full-scale nonlinearity of a mapping-only table.
        """
        seen = self.calibrator.seen_topics
        out: dict[str, str] = {}
        missing = self.missing()
        if topics.FOG_INJECTION not in seen:
            for key in (*SELF_CAL_KEYS, KEY_MAPPING):
                out[key] = f'no {topics.FOG_INJECTION} on this bench: no self-calibration.'
        if topics.RATE_TABLE_JOINT_STATES not in seen:
            for key in (KEY_SCALE_FACTOR, KEY_BIAS, KEY_BIAS_PLUS_EARTH, KEY_NONLINEARITY,
                        KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC, KEY_ARW, KEY_MAPPING):
                out[key] = f'no {topics.RATE_TABLE_JOINT_STATES} on this bench: no turntable.'
        if self.mapping_rates_only():
            out[KEY_NONLINEARITY] = missing[KEY_NONLINEARITY]
            for key in (KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC):
                if key in missing:
                    out[key] = missing[key]
        return {k: v for k, v in out.items() if k in missing}

    def conditions(self) -> dict[str, Any]:
        """The latitude the bias rests on (NaN: the bias keeps the Earth rate)."""
        return {'latitude_deg': self.calibrator.settings.latitude_deg}

    def rejections(self) -> list[Rejection]:
        """Segments, plateaus and events rejected, in stamp order.

        Segments, plateaus and events rejected, with reasons, in stamp order (the same
        however the streams were chunked, so a node's last rejection is the offline one).
        """
        return self.calibrator.all_rejections()

    def notices(self) -> list[str]:
        """Source restarts, dropped samples and settling plateaus.

        Source restarts, samples dropped or re-sorted (NaN/inf, bad stamps), and plateaus
        measured over their second halves only (the loop still settling).
        """
        fit = self.calibrator.fits().self_cal
        settling = ([n for n in fit.notes if n.startswith(SETTLING_NOTE)]
                    if isinstance(fit, SelfCalFit) else [])
        return list(self.calibrator.restarts) + self.calibrator.stream_notes() + settling

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first to the last segment or plateau measured."""
        cal = self.calibrator
        stamps = [s.start_ns for s in cal.segments] + [s.end_ns for s in cal.segments]
        stamps += [p.start_ns for p in cal.plateaus] + [p.end_ns for p in cal.plateaus]
        return (min(stamps), max(stamps)) if stamps else None

    # -- summary ----------------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """Each figure in the units a FOG laboratory quotes (value, std uncertainty, n)."""
        res = self.results()
        rows: list[tuple[str, str, str, str]] = []

        def add(label: str, key: str, scale: float = 1.0, fmt: str = '.6f', *,
                always: bool = False) -> None:
            est = res.get(key)
            if est is None:
                if always:
                    rows.append((label, '—', '', ''))
                return
            rows.append((label, f'{est.value * scale:{fmt}}',
                         f'{est.std_uncertainty * abs(scale):.3g}', str(est.n_used)))

        add('K turntable (counts/rad)', KEY_SCALE_FACTOR, always=True)
        add('K turntable ((counts/s)/(°/s))', KEY_SCALE_FACTOR, DEG, '.7f')
        if self.calibrator.bias_key == KEY_BIAS:
            add('bias (°/h)', KEY_BIAS, 1.0 / DEG_H, '.4f', always=KEY_SCALE_FACTOR in res)
        else:
            add('bias + Earth rate (°/h)', KEY_BIAS_PLUS_EARTH, 1.0 / DEG_H, '.4f',
                always=KEY_SCALE_FACTOR in res)
        add('nonlinearity (ppm)', KEY_NONLINEARITY, fmt='.3f')
        add('asymmetry (ppm)', KEY_ASYMMETRY, fmt='.3f')
        add('quadratic (ppm/(°/s))', KEY_QUADRATIC, DEG * 1e6, '.5f')
        add('cubic (ppm/(°/s)²)', KEY_CUBIC, DEG * DEG * 1e6, '.3g')
        add('ARW (°/√h)', KEY_ARW, 1.0 / DEG_SQRT_H, '.5f')
        add('K mapping (counts/rad)', KEY_MAPPING)
        injected = (topics.FOG_INJECTION in self.calibrator.seen_topics
                    or bool(self.calibrator.plateaus))
        add('K self-cal (counts/rad)', KEY_SELF_CAL, always=bool(injected))
        add('K self-cal ((counts/s)/(°/s))', KEY_SELF_CAL, DEG, '.7f')
        add('linear range (°/s)', KEY_SELF_CAL_RANGE, 1.0 / DEG, '.4f')
        add('self-cal nonlinearity (ppm)', KEY_SELF_CAL_NONLINEARITY, fmt='.2f')
        add('K zero amplitude (counts/rad)', KEY_SELF_CAL_SMALL_SIGNAL)
        add('K self-cal − K turntable (counts/rad)', KEY_SELF_CAL_DIFFERENCE, fmt='+.4f')
        return rows

    def summary_lines(self) -> list[str]:
        """The summary lines of a FOG run.

        Counts, the uncertainty bases, the self-calibration table (K against the plateaus
        used, as the paper's Table 1, the linear range marked), and what is missing.
        """
        cal = self.calibrator
        fits = cal.fits()
        rejected = self.rejections()
        n_seg_rej = sum(1 for r in rejected if r.reason.startswith('segment'))
        n_plat_rej = sum(1 for r in rejected if r.reason.startswith('plateau'))
        used = len(fits.turntable.segments) if isinstance(fits.turntable, TurntableFit) else 0
        lines = [f'segments measured: {len(cal.segments)} (in the turntable fit: {used}, '
                 f'rejected: {n_seg_rej}); plateaus accepted: {len(cal.plateaus)} '
                 f'(rejected: {n_plat_rej})']
        res = self.results()
        for label, key in (('K turntable', KEY_SCALE_FACTOR), ('K self-cal', KEY_SELF_CAL),
                           ('K zero amplitude', KEY_SELF_CAL_SMALL_SIGNAL)):
            est = res.get(key)
            if est is not None and est.basis:
                lines.append(f'{label} uncertainty: {est.basis}')
        if KEY_BIAS_PLUS_EARTH in res:
            lines.append('the bias includes the Earth rate along the table axis: give '
                         '--latitude-deg (node: latitude_deg) to separate them.')
        if isinstance(fits.mapping, MappingFit) and fits.mapping.rates_missing_deg_s:
            missing = ', '.join(f'{r:g}' for r in fits.mapping.rates_missing_deg_s)
            lines.append(f'mapping rates not measured: {missing} °/s (the mapping rests on the '
                         f'others).')
        if isinstance(fits.self_cal, SelfCalFit):
            lines += self._self_cal_table(fits.self_cal)
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def _self_cal_table(self, fit: SelfCalFit) -> list[str]:
        diff = fit.difference
        lines = []
        if diff is not None:
            k = self.results().get(KEY_SCALE_FACTOR)
            ppm = f' ({diff.value / k.value * 1e6:+.0f} ppm)' if k is not None else ''
            lines.append(f'self-calibrated K − turntable K = {diff.value:+.4f} ± '
                         f'{diff.std_uncertainty:.3g} counts/rad{ppm}: '
                         f'{fit.significance_sigma:.1f} σ.')
        rows = list(fit.table)
        if not rows:
            return lines
        linear_at = rows.index(fit.linear) if fit.linear is not None else -1
        shown = {i for i in range(min(len(rows), max(linear_at + 3, 4)))}
        shown |= {i for i, r in enumerate(rows) if r.plateaus in PAPER_ROWS}
        shown.add(len(rows) - 1)
        lines.append('self-calibration: K against the plateaus used (from zero up):')
        for i, row in enumerate(rows):
            if i not in shown:
                continue
            k_text = (f'K = {row.scale_factor.value:.6f} ± {row.scale_factor.std_uncertainty:.2g} '
                      f'counts/rad, up to {math.degrees(row.range_rad_s):.4f} °/s'
                      if row.scale_factor is not None else
                      f'dN/dJ = {row.slope.value:.8f} ± {row.slope.std_uncertainty:.2g}')
            mark = '   ← linear range' if i == linear_at else ''
            lines.append(f'  {row.plateaus:3d} plateaus: {k_text}; {row.nonlinearity_text()}'
                         f'{mark}')
        return lines

    def info_lines(self) -> list[str]:
        """The segments, the mapping and the plateaus the calibration would use."""
        cal = self.calibrator
        fits = cal.fits()
        unsteady = {r.stamp_ns for r in fits.rejections}
        active = {id(s) for s in cal.active_segments if s.start_ns not in unsteady}
        lines = [f'constant-rate segments measured: {len(cal.segments)}']
        for s in cal.segments:
            how = (f'{s.revolutions} rev between zero-index events' if s.revolutions
                   else 'no whole revolution: Earth-rate residual bounded')
            used = '' if id(s) in active else (
                '  (not used: output not steady)' if s.start_ns in unsteady
                else '  (not used: injection)')
            lines.append(f'  {format_stamp(s.start_ns)} → {format_stamp(s.end_ns)}  '
                         f'{math.degrees(s.rate_rad_s):+10.4f} °/s  {s.duration_s:7.2f} s  '
                         f'{how}; output {s.output_rate_counts_s:.4f} counts/s{used}')
        if isinstance(fits.mapping, MappingFit):
            m = fits.mapping
            lines.append(f'equivalence mapping: {len(m.segments)} segment(s) at '
                         f'{", ".join(f"{r:g}" for r in m.rates_found_deg_s)} °/s; K_map = '
                         f'{m.scale_factor.value:.6f} ± {m.scale_factor.std_uncertainty:.3g} '
                         f'counts/rad (0.01 °/s ≙ {m.output_step_counts_s(0.01):.4f} counts/s)')
        else:
            lines.append(f'equivalence mapping: {fits.mapping}')
        lines.append(f'injection plateaus accepted: {len(cal.plateaus)}')
        for p in cal.plateaus:
            lines.append(f'  {format_stamp(p.start_ns)}  J = {p.injection_counts_s:12.4f} '
                         f'counts/s  settled after {(p.settled_ns - p.start_ns) / 1e9:.3g} s  '
                         f'N = {p.output_rate_counts_s:.4f} ± {p.std_counts_s:.2g} counts/s '
                         f'over {p.settled_s:.2f} s')
        return lines

    def limiting(self) -> str:
        """One line: what limits the result most, as an action."""
        cal = self.calibrator
        fits = cal.fits()
        res = self.results()
        if topics.FOG_OUTPUT not in cal.seen_topics:
            return f'no {topics.FOG_OUTPUT} samples: record the FOG output.'
        self_cal = fits.self_cal
        injected = topics.FOG_INJECTION in cal.seen_topics
        if injected and isinstance(fits.mapping, str):
            rates = ', '.join(f'{r:g}' for r in cal.settings.mapping_rates_deg_s)
            return ('no equivalence mapping, so no self-calibrated K: run the table at the '
                    f'mapping rates ({rates} °/s) before the ladder.')
        if injected and isinstance(self_cal, str):
            return f'self-calibration: {self_cal} Run more plateaus on a static base.'
        if isinstance(self_cal, SelfCalFit) and self_cal.linear is None:
            return (f'no range of {cal.settings.min_plateaus} or more plateaus from zero up '
                    f'stays within {cal.settings.self_cal_nonlinearity_spec_ppm:g} ppm: inject '
                    f'smaller steps (or hold each plateau longer if the nonlinearity is noise: '
                    f'see the self-calibration table).')
        if isinstance(self_cal, SelfCalFit) and KEY_SELF_CAL in res:
            return self._self_cal_limit(self_cal, fits.mapping, res)
        if isinstance(fits.turntable, str):
            return f'turntable: {self.missing().get(KEY_SCALE_FACTOR, fits.turntable)}'
        return self._turntable_limit(fits.turntable)

    def _self_cal_limit(self, fit: SelfCalFit, mapping: MappingFit | str,
                        res: dict[str, Estimate]) -> str:
        if fit.difference is not None and fit.significance_sigma > 3.0:
            k = res[KEY_SELF_CAL]
            k_tt = k.value - fit.difference.value
            ppm = fit.difference.value / k_tt * 1e6
            head = (f'the self-calibrated K differs from the turntable K by {ppm:+.0f} ppm '
                    f'({fit.significance_sigma:.0f} σ)')
            small = fit.small_signal
            tt = res.get(KEY_SCALE_FACTOR)
            if small is not None and tt is not None:
                z0 = abs(small.value - k_tt) / math.hypot(small.std_uncertainty,
                                                          tt.std_uncertainty)
                if z0 <= 3.0:
                    return (f'{head} while the zero-amplitude K agrees with it '
                            f'({z0:.1f} σ): the front end bends inside the linear range — '
                            f'lower self_cal_nonlinearity_spec_ppm or use the zero-amplitude K.')
            return (f'{head}: a systematic error of the equivalence mapping (injection gain), '
                    'not noise — recalibrate the injection gain or use the turntable K.')
        assert fit.linear is not None and isinstance(mapping, MappingFit)
        k_map = mapping.scale_factor
        slope = fit.linear.slope
        from_map = (slope.value * k_map.std_uncertainty) ** 2
        from_plateaus = (k_map.value * slope.std_uncertainty) ** 2
        total = from_map + from_plateaus
        if total > 0 and from_map >= from_plateaus:
            return (f'the equivalence mapping gives {from_map / total:.0%} of the '
                    f'self-calibrated K\'s variance: hold the mapping rates longer.')
        return (f'the {fit.linear.plateaus} plateaus in the linear range give '
                f'{from_plateaus / total if total else 1.0:.0%} of the self-calibrated K\'s '
                f'variance: hold each plateau longer or inject smaller steps (more plateaus '
                f'in range).')

    def _turntable_limit(self, fit: TurntableFit) -> str:
        if fit.asymmetry_ppm is None or fit.quadratic_s_per_rad is None:
            return ('the turntable fit has too few rates for the asymmetry or the quadratic '
                    'and cubic terms: add rates of both signs, at least 5 distinct.')
        # K's variance split into its sources through the least-squares operator
        noise = pooled_noise(list(fit.segments))
        k_row = fit.line.operator[0] ** 2
        t = np.array([s.duration_s for s in fit.segments])
        arw = float(np.sum(k_row * noise.arw_counts2_s / t))
        quant = float(np.sum(k_row * np.array([s.end_variance_counts2 for s in fit.segments])
                             / t**2))
        earth = float(np.sum(k_row * (np.array([s.earth_bound_rad_s for s in fit.segments])
                                      * abs(fit.scale_factor.value)) ** 2 / 3.0))
        total = arw + quant + earth
        if total <= 0:
            return 'every quantity measured; the segments show no noise.'
        shares = {'arw': arw / total, 'quant': quant / total, 'earth': earth / total}
        top = max(shares, key=shares.__getitem__)
        if top == 'earth':
            return (f'the Earth-rate residual of segments without whole revolutions gives '
                    f'{shares[top]:.0%} of K\'s variance: hold the slow rates for whole table '
                    f'revolutions between zero-index events.')
        if top == 'quant':
            return (f'the output quantisation at the segment ends gives {shares[top]:.0%} of '
                    f'K\'s variance: raise the output rate or hold each rate longer.')
        return (f'the angle random walk gives {shares[top]:.0%} of K\'s variance (σ_K ∝ '
                f'1/√T): hold each rate longer or repeat the rates.')

    def json_section(self) -> dict[str, Any]:
        """Results, missing, rejections, and the self-calibration table (K per range)."""
        out = super().json_section()
        fit = self.calibrator.fits().self_cal
        if isinstance(fit, SelfCalFit):
            out['self_cal_table'] = [
                {'plateaus': r.plateaus,
                 'max_injection_counts_s': _finite(r.max_injection_counts_s),
                 'range_rad_s': _finite(r.range_rad_s),
                 'scale_factor_counts_per_rad': _finite(r.scale_factor.value
                                                        if r.scale_factor else None),
                 'scale_factor_std': _finite(r.scale_factor.std_uncertainty
                                             if r.scale_factor else None),
                 'nonlinearity_ppm': _finite(r.nonlinearity_ppm.value),
                 'linear_range': r is fit.linear} for r in fit.table]
        out['notices'] = self.notices()
        return out

    def plot(self, out_dir: Path) -> list[Path]:
        """The turntable nonlinearity curve and self-cal K against the range used."""
        from gyro_calib.fog.plots import plot_fog

        return plot_fog(self.calibrator, out_dir)


def _finite(value: float | None) -> float | None:
    """JSON has no NaN: a value that is not a finite number becomes null."""
    return value if value is not None and math.isfinite(value) else None
