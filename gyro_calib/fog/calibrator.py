"""Streaming FOG calibration: output, injection, table and zero-index streams in, K out.

:class:`FogCalibrator` is the accumulator a node feeds message by message (``add_*``) or
a bag reader feeds array by array (``extend_*``); :func:`calibrate_fog` runs it over
whole recordings. Both run the same code, and the results do not depend on how the
streams were chunked or how far they lag one another (within ``stream_lag_s``):

1. the output counts are reduced to least-squares sums per ``cell_s`` once the stream
   has run ``reorder_margin_s`` past a cell (memory stays bounded);
2. joint_states go through the :class:`~gyro_calib.fog.segments.SegmentDetector`;
   each finished constant-rate segment is measured (:func:`measure_segment`) once the
   output cells cover it and the zero-index stream has passed its end (or the output
   has run ``stream_lag_s`` past it);
3. each injection plateau is measured (:func:`measure_plateau`) once the next message
   has closed it and the output (and the table, if present) cover it;
4. the fits (:func:`fit_turntable`, :func:`fit_mapping`, :func:`fit_self_cal`) are
   recomputed from the measured segments and plateaus when results are asked for.

Turntable segments that overlap a non-zero injection are left out of the turntable and
mapping fits (the injection is not a rotation), also when the injection message arrives
after the segment was measured.

The streams' state and inputs are :class:`~gyro_calib.fog.intake.FogIntake`'s, steps 1–3
:class:`~gyro_calib.fog.measuring.FogMeasuring`'s; :class:`FogCalibrator` adds step 4 and
the results.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.fog import topics
from gyro_calib.fog.intake import _Fits
from gyro_calib.fog.measuring import FogMeasuring
from gyro_calib.fog.segments import rate_deg_s, stamp_text
from gyro_calib.fog.self_cal import SETTLING_NOTE, SelfCalFit, fit_self_cal
from gyro_calib.fog.settings import FogSettings
from gyro_calib.fog.turntable import (
    MappingFit,
    SegmentMeasurement,
    TurntableFit,
    fit_mapping,
    fit_turntable,
    mapping_turntable_covariance,
    pooled_noise,
)
from gyro_calib.streams import feed_by_timeline

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt
    from numpy.typing import ArrayLike

KEY_SCALE_FACTOR = 'fog_scale_factor_counts_per_rad'
KEY_BIAS = 'fog_bias_rad_s'
KEY_BIAS_PLUS_EARTH = 'fog_bias_plus_earth_rate_rad_s'
KEY_NONLINEARITY = 'fog_nonlinearity_ppm'
KEY_ASYMMETRY = 'fog_asymmetry_ppm'
KEY_QUADRATIC = 'fog_scale_factor_quadratic_s_per_rad'
KEY_CUBIC = 'fog_scale_factor_cubic_s2_per_rad2'
KEY_ARW = 'fog_angle_random_walk_rad_per_sqrt_s'
KEY_MAPPING = 'fog_mapping_scale_factor_counts_per_rad'
KEY_SELF_CAL = 'fog_self_cal_scale_factor_counts_per_rad'
KEY_SELF_CAL_RANGE = 'fog_self_cal_linear_range_rad_s'
KEY_SELF_CAL_NONLINEARITY = 'fog_self_cal_nonlinearity_ppm'
KEY_SELF_CAL_SMALL_SIGNAL = 'fog_self_cal_small_signal_scale_factor_counts_per_rad'
KEY_SELF_CAL_DIFFERENCE = 'fog_self_cal_minus_turntable_scale_factor_counts_per_rad'

TURNTABLE_KEYS = (KEY_SCALE_FACTOR, KEY_NONLINEARITY, KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC,
                  KEY_ARW)
SELF_CAL_KEYS = (KEY_SELF_CAL, KEY_SELF_CAL_RANGE, KEY_SELF_CAL_NONLINEARITY,
                 KEY_SELF_CAL_SMALL_SIGNAL, KEY_SELF_CAL_DIFFERENCE)


@dataclass(slots=True)
class FogCalibrator(FogMeasuring):
    """Accumulates the FOG streams into the turntable and self-calibration results."""

    # -- results -------------------------------------------------------------------------------
    @property
    def seen_topics(self) -> frozenset[str]:
        """The input topics that delivered at least one sample."""
        return frozenset(self._seen)

    @property
    def active_segments(self) -> list[SegmentMeasurement]:
        """Segments used by the turntable and mapping fits (no injection overlap)."""
        return [s for i, s in enumerate(self.segments) if i not in self._excluded]

    def fits(self) -> _Fits:
        """Turntable, mapping and self-calibration fits (each a fit or the reason why not)."""
        if self._fits is None:
            segs, unsteady = self._steady(self.active_segments)
            noise = pooled_noise(segs)
            turntable = fit_turntable(segs, noise, self.settings)
            mapping = fit_mapping(segs, noise, self.settings)
            cov = 0.0
            if isinstance(turntable, TurntableFit) and isinstance(mapping, MappingFit):
                cov = mapping_turntable_covariance(mapping, turntable, segs)
            self_cal: SelfCalFit | str
            if not self.plateaus and topics.FOG_INJECTION not in self._seen:
                self_cal = ('no /fog/injection messages: self-calibration needs the injected '
                            'plateaus (the turntable results stand on their own).')
            else:
                self_cal = fit_self_cal(
                    self.plateaus, mapping if isinstance(mapping, MappingFit) else None,
                    turntable if isinstance(turntable, TurntableFit) else None, cov,
                    self.settings)
            self._fits = _Fits(turntable, mapping, self_cal, unsteady)
        return self._fits

    def _steady(self, segments: list[SegmentMeasurement]) -> tuple[
            list[SegmentMeasurement], tuple[Rejection, ...]]:
        """Leave out segments whose output was not steady.

        Leave out segments whose output was not steady: block scatter far beyond the
        other segments' (the ARW does not depend on the rate; an unrecorded injection or a
        loop disturbance makes the output rate jump within the segment).

        The integer output's quantisation can beat slowly against the sample rate and leave
        up to ½ count in each local-fit count, so up to 1 count² in a block increment: that
        much (1/T_b counts²/s) is allowed beyond the ratio before a segment is called
        unsteady.
        """
        if len(segments) < 3:
            return segments, ()
        n2 = [s.arw_estimate()[0] if s.block_count >= 2 else math.nan for s in segments]
        ratio = self.settings.unsteady_noise_ratio
        keep, rejected = [], []
        for i, seg in enumerate(segments):
            others = [v for j, v in enumerate(n2) if j != i and math.isfinite(v)]
            median = float(np.median(others)) if len(others) >= 2 else math.nan
            excess = n2[i] - 1.0 / seg.block_s if seg.block_s > 0 else math.nan
            if math.isfinite(excess) and median > 0 and excess > ratio * median:
                reason = (f'segment at {rate_deg_s(seg.rate_rad_s)} {stamp_text(seg.start_ns)}: '
                          f'the output rate was not steady — its block scatter is '
                          f'{n2[i] / median:.3g} times the median of the other segments '
                          f'(limit unsteady_noise_ratio = {ratio:g}, beyond the count '
                          f'quantisation): the output changed during '
                          f'the segment (an injection not recorded on /fog/injection? a loop '
                          f'disturbance); not used.')
                rejected.append(Rejection(seg.start_ns, reason))
            else:
                keep.append(seg)
        return keep, tuple(rejected)

    def all_rejections(self) -> list[Rejection]:
        """Everything rejected, in stamp order.

        Everything rejected, in stamp order: while streaming (segments, plateaus) and by
        the fits (unsteady segments).
        """
        return sorted([*self.rejections, *self.fits().rejections],
                      key=lambda r: (r.stamp_ns, r.reason))

    @property
    def bias_key(self) -> str:
        """The hand-off key of the bias: with or without the Earth rate in it."""
        return KEY_BIAS if self.settings.latitude_known else KEY_BIAS_PLUS_EARTH

    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (SI units in the names), only those measured."""
        f = self.fits()
        out: dict[str, Estimate] = {}
        if isinstance(f.turntable, TurntableFit):
            t = f.turntable
            out[KEY_SCALE_FACTOR] = t.scale_factor
            out[self.bias_key] = t.bias
            out[KEY_ARW] = t.angle_random_walk_rad_sqrt_s
            for key, est in ((KEY_NONLINEARITY, t.nonlinearity_ppm),
                             (KEY_ASYMMETRY, t.asymmetry_ppm),
                             (KEY_QUADRATIC, t.quadratic_s_per_rad),
                             (KEY_CUBIC, t.cubic_s2_per_rad2)):
                if est is not None:
                    out[key] = est
        if isinstance(f.mapping, MappingFit):
            out[KEY_MAPPING] = f.mapping.scale_factor
        if isinstance(f.self_cal, SelfCalFit):
            s = f.self_cal
            if s.scale_factor is not None and s.linear is not None:
                out[KEY_SELF_CAL] = s.scale_factor
                assert s.linear_range_rad_s is not None
                out[KEY_SELF_CAL_RANGE] = s.linear_range_rad_s
                out[KEY_SELF_CAL_NONLINEARITY] = s.linear.nonlinearity_ppm
            if s.small_signal is not None:
                out[KEY_SELF_CAL_SMALL_SIGNAL] = s.small_signal
            if s.difference is not None:
                out[KEY_SELF_CAL_DIFFERENCE] = s.difference
        rejected = tuple(self.all_rejections())
        # a figure whose value or uncertainty is not a finite number is not measured
        return {k: dataclasses.replace(e, rejected=rejected) for k, e in out.items()
                if math.isfinite(e.value) and math.isfinite(e.std_uncertainty)}

    def summary(self) -> list[str]:
        """Whole-sentence summary lines of the FOG run.

        Whole-sentence lines: each measured figure with its uncertainty and count, and the
        self-calibration table (K against the plateaus used) with the linear range marked.
        """
        res = self.results()
        lines = [f'{key} = {e.value:.10g} ± {e.std_uncertainty:.3g} (k = 1, from {e.n_used})'
                 for key, e in res.items()]
        if self.bias_key == KEY_BIAS_PLUS_EARTH and KEY_BIAS_PLUS_EARTH in res:
            lines.append('the bias includes the Earth rate along the table axis (no latitude '
                         'given).')
        fit = self.fits().self_cal
        if isinstance(fit, SelfCalFit):
            lines += [n for n in fit.notes if n.startswith(SETTLING_NOTE)]
            if fit.difference is not None:
                lines.append(f'self-calibrated K differs from the turntable K by '
                             f'{fit.difference.value:+.6g} ± {fit.difference.std_uncertainty:.3g} '
                             f'counts/rad ({fit.significance_sigma:.1f} σ).')
            for row in fit.table:
                k = (f'K = {row.scale_factor.value:.8g} ± {row.scale_factor.std_uncertainty:.2g}'
                     if row.scale_factor is not None else f'slope {row.slope.value:.8g}')
                mark = '  ← linear range' if row is fit.linear else ''
                lines.append(f'  {row.plateaus:3d} plateaus: {k}, {row.nonlinearity_text()}'
                             f'{mark}')
        lines += [f'{key}: {why}' for key, why in self.missing().items()]
        return lines

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet), a whole sentence."""
        f = self.fits()
        have = self.results()
        keys = (KEY_SCALE_FACTOR, self.bias_key, KEY_NONLINEARITY, KEY_ASYMMETRY,
                KEY_QUADRATIC, KEY_CUBIC, KEY_ARW, KEY_MAPPING) + SELF_CAL_KEYS
        out: dict[str, str] = {}
        for key in keys:
            if key in have:
                continue
            out[key] = self._why_missing(key, f)
        return out

    def _why_missing(self, key: str, f: _Fits) -> str:
        if key == KEY_ARW and isinstance(f.turntable, TurntableFit):
            return (f'no segment was long enough for two noise blocks of min_block_s = '
                    f'{self.settings.min_block_s:g} s: no angle random walk estimate.')
        if key == KEY_NONLINEARITY and isinstance(f.turntable, TurntableFit):
            return next((n for n in f.turntable.notes if n.startswith('nonlinearity')),
                        'not measured.')
        if key in (KEY_SCALE_FACTOR, self.bias_key, KEY_NONLINEARITY, KEY_ARW):
            return self._turntable_reason(f.turntable)
        if key in (KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC):
            if isinstance(f.turntable, str):
                return self._turntable_reason(f.turntable)
            word = 'asymmetry' if key == KEY_ASYMMETRY else 'quadratic'
            return next((n for n in f.turntable.notes if n.startswith(word)),
                        'not measured.')
        if key == KEY_MAPPING:
            return f.mapping if isinstance(f.mapping, str) else 'not measured.'
        if isinstance(f.self_cal, str):
            return f.self_cal
        if key == KEY_SELF_CAL_SMALL_SIGNAL and f.self_cal.scale_factor is not None:
            return ('no range of 7 or more injection levels over which a cubic and a quintic '
                    'agree on the slope at zero (too few plateaus, or too much noise).')
        notes = ' '.join(n for n in f.self_cal.notes if not n.startswith(SETTLING_NOTE))
        return notes or 'not measured.'

    def _turntable_reason(self, fit: TurntableFit | str) -> str:
        if isinstance(fit, TurntableFit):
            return 'not measured.'
        if topics.RATE_TABLE_JOINT_STATES not in self._seen:
            return (f'no {topics.RATE_TABLE_JOINT_STATES} messages: the turntable scale factor '
                    f'needs the table rates.')
        return fit


def calibrate_fog(
    output_t_ns: ArrayLike,
    output_counts: ArrayLike,
    *,
    injection_t_ns: ArrayLike = (),
    injection_counts_s: ArrayLike = (),
    table_t_ns: ArrayLike = (),
    table_angle_rad: ArrayLike = (),
    table_rate_rad_s: ArrayLike = (),
    zero_index_ns: ArrayLike = (),
    settings: FogSettings | None = None,
) -> FogCalibrator:
    """Batch FOG calibration over whole recordings; returns the flushed calibrator.

    Read ``results()``, ``missing()``, ``fits()``, ``segments``, ``plateaus`` and
    ``rejections`` from it. If a source restarted (stamps jump back by
    ``restart_backstep_s``), each timeline is calibrated in turn, as a live node would.
    """
    cal = FogCalibrator(settings or FogSettings())
    back = int(cal.settings.restart_backstep_s * 1e9)
    streams: list[tuple[Callable[..., object], npt.NDArray[np.int64],
                        tuple[ArrayLike, ...]]] = [
        (cal.extend_output, np.asarray(output_t_ns, np.int64), (output_counts,)),
        (cal.extend_injection, np.asarray(injection_t_ns, np.int64), (injection_counts_s,)),
        (cal.extend_table_states, np.asarray(table_t_ns, np.int64),
         (table_angle_rad, table_rate_rad_s)),
        (cal.extend_zero_index, np.asarray(zero_index_ns, np.int64), ()),
    ]
    feed_by_timeline(streams, back, lambda: cal.process(flush=True))
    return cal
