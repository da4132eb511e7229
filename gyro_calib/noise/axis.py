"""One axis from its pooled Allan variance to its noise terms, error bars and spikes.

The joint term fit (METHODS §E.3), the error bars from the EDF blended over the noise types
by their shares at each τ (§E.2), the total deviation at long τ (§E.2 (6a)), the outlier
report (§E.6), and for an axis without terms the sentence saying why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.edf import adev_std, edf_totdev
from gyro_calib.noise.fit import NoiseFit, fit_noise_terms
from gyro_calib.noise.mixture import (
    TERM_ALPHA,
    blended_edf,
    curve_edf,
    curve_shares,
    dominant_alpha,
    model_shares,
    slope_shares,
    uniform_quantisation_factor,
)
from gyro_calib.noise.outliers import OutlierReport, adev_at
from gyro_calib.noise.table_report import TableReport
from gyro_calib.noise.terms import SYMBOLS, TermUnits, units_for_axis
from gyro_calib.noise.topics import GYRO_PULSES, IMU_PULSES, PULSE_TOPICS

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.noise.channel import ChannelAccumulator
    from gyro_calib.noise.curve import AllanCurve
    from gyro_calib.noise.intake import InputStream

    FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class AxisResult:
    """Everything measured on one axis.

    Attributes:
        axis: axis name.
        units: its keys and units.
        curve: pooled Allan variance (None when there is none in SI units).
        fit: the joint term fit (None when no fit ran).
        adev_std: standard deviation of each ADEV point (from the EDF), rate unit.
        total_deviation: (tau_s, totdev, totdev_std) at long τ, or None.
        reason: why the axis has no terms at all ('' when the fit ran).
        alpha: the dominant noise type α at each τ (the term with the largest share of the
            Allan variance; ``noise_alpha``).
        others: 'mdev', 'hdev', 'totdev' → (deviation, its std, its EDF) at the curve's τ
            (full overlap only; NaN where the statistic has no term).
        edf: EDF of the ADEV at each τ, blended over the noise types by their shares
            (:mod:`gyro_calib.noise.mixture`).
        shares: share of Q, N, B, K, R in the Allan variance at each τ (len × 5): the
            fitted model's, or the curve's local slope's where there is no model.
    """

    axis: str
    units: TermUnits
    curve: AllanCurve | None
    fit: NoiseFit | None
    adev_std: FloatArray | None
    total_deviation: tuple[FloatArray, FloatArray, FloatArray] | None
    reason: str = ''
    alpha: npt.NDArray[np.int64] | None = None
    others: dict[str, tuple[FloatArray, FloatArray, FloatArray]] | None = None
    edf: FloatArray | None = None
    shares: FloatArray | None = None
    outliers: OutlierReport | None = None
    """The spikes found and what removing them (or keeping them) changes (§E.6)."""
    taus_left_out: str = ''
    """The τ of a ``--taus`` list this record cannot give, each with why (a summary line)."""


def listed_taus_left_out(taus: tuple[float, ...], tau0_s: float, longest_samples: int,
                         max_tau_fraction: float) -> str:
    """The τ of a ``--taus`` list a record cannot give, each with why ('' if none).

    A listed τ is averaged over m = round(τ/τ0) samples (§E.1): m < 1 is shorter than one
    sample interval; m above ``max_tau_fraction`` of the longest gap-free segment
    (``longest_samples``) is too long for the record.
    """
    m_max = int(max_tau_fraction * longest_samples)
    short = [t for t in taus if round(t / tau0_s) < 1]
    long = [t for t in taus if round(t / tau0_s) > m_max]
    parts = []
    if short:
        parts.append(f'τ = {", ".join(f"{t:g}" for t in short)} s is shorter than the sample '
                     f'interval ({tau0_s:g} s)')
    if long:
        parts.append(f'τ = {", ".join(f"{t:g}" for t in long)} s is longer than '
                     f'{m_max * tau0_s:g} s (a fraction {max_tau_fraction:g} of the longest '
                     f'gap-free segment, {longest_samples * tau0_s:g} s)')
    if not parts:
        return ''
    return f'--taus (the setting taus): {"; ".join(parts)}: left out of the curve.'


class AxisAnalysis(TableReport):
    """Each axis's result, computed once per new data (a base of the calibrator)."""

    _cache: dict[str, tuple[tuple[int, int, bool], AxisResult]]
    _flushed: bool

    def axis_result(self, axis: str) -> AxisResult:
        """Curve, fit, error bars and total deviation of one axis (cached until new data)."""
        stream, ch = self._channel(axis)
        self._drain(stream)  # samples added one by one count at once
        key = (ch.stats.samples, ch.n_used_samples, self._flushed)
        cached = self._cache.get(axis)
        if cached is not None and cached[0] == key:
            return cached[1]
        res = self._compute(stream, ch)
        self._cache[axis] = (key, res)
        return res

    def axis_results(self) -> dict[str, AxisResult]:
        """:meth:`axis_result` of every axis."""
        return {a: self.axis_result(a) for a in self.axes()}

    def _compute(self, stream: InputStream, ch: ChannelAccumulator) -> AxisResult:
        units = units_for_axis(ch.name)
        s = self.settings
        st = ch.stats

        def none(reason: str) -> AxisResult:
            return AxisResult(ch.name, units, None, None, None, None, reason,
                              outliers=self._outlier_report(ch, units, None, None))

        motion = self._motion_reason(stream)
        if st.samples == 0 and motion:
            return none(f'no sample of {ch.name} on {stream.topic} was taken with '
                        f'{self._tables_phrase()} steady (at rest or at one constant '
                        f'rate).{motion}')
        if motion and st.non_finite < st.samples:
            rest_curve = ch.curve()
            if rest_curve is None or int(np.count_nonzero(rest_curve.avar > 0)) < 2:
                return none(f'the spans of {ch.name} on {stream.topic} with '
                            f'{self._tables_phrase()} steady are too short for any noise '
                            f'term ({st.samples} sample(s) '
                            f'in steady spans).{motion}')
        if st.samples == 0:
            return none(f'no samples have arrived on {stream.topic} yet.')
        if st.non_finite == st.samples:
            return none(f'all {st.samples} samples of {ch.name} on {stream.topic} were '
                        f'non-finite (NaN or inf): the channel carries no data.')
        if ch.is_constant:
            lock = (' A static RLG inside its lock-in band without dither gives no pulses: '
                    'dither it or turn it.' if stream.topic in PULSE_TOPICS else '')
            return none(f'{ch.name} on {stream.topic} is constant (every finite sample equals '
                        f'{ch.first_value!r}): a stuck or disconnected channel shows no noise, '
                        f'so no term can be measured.{lock}')
        if ch.kind == 'phase' and not math.isfinite(ch.phase_scale):
            what = ('scale_factor_rad_per_pulse (CLI --scale-factor-rad-per-pulse, or '
                    '--calibration with a hand-off file holding scale_factor_rad_per_pulse)'
                    if stream.topic == GYRO_PULSES else
                    f'K of channel {ch.name} (--calibration with a format-4 hand-off file '
                    'whose imu: section holds scale_factor_rad_per_pulse)'
                    if stream.topic == IMU_PULSES else
                    'fog_scale_factor_counts_per_rad')
            return none(f'{stream.topic} needs a scale factor to turn counts into rad and '
                        f'none was given: set {what}. No value in rad is reported.')
        curve = ch.curve()
        usable = 0 if curve is None else int(np.count_nonzero(curve.avar > 0))
        listed = isinstance(s.tau_spec, tuple)  # --taus τ1,τ2,…: the fit names the list
        if curve is None or usable < (1 if listed else 2):
            n = ch.n_used_samples
            need = max(s.min_segment_samples, int(math.ceil(4.0 / s.max_tau_fraction)) + 1)
            longest = max((g.n_samples for g in ch.segments), default=0)
            if listed and longest >= need:  # the record is long enough: the list is not
                taus = ', '.join(f'{v:g}' for v in s.tau_spec)
                return none(f'--taus {taus} (the setting taus) lists no averaging time the '
                            f'record of {ch.name} allows (from one sample interval up to a '
                            f'fraction {s.max_tau_fraction:g} of its longest gap-free '
                            f'segment, {longest} samples): list τ in that range, or leave '
                            f'taus at its default grid.{motion}')
            return none(f'the record of {ch.name} is too short for any noise term: '
                        f'{st.samples} sample(s) received, the longest gap-free segment has '
                        f'{longest}, {n} usable in segments of at least '
                        f'{s.min_segment_samples}; the Allan '
                        f'variance needs averaging times up to a fraction '
                        f'{s.max_tau_fraction:g} of a segment, so at least {need} samples in '
                        f'one segment.{motion}')
        context = 'pulses' if stream.topic in PULSE_TOPICS else ''
        fit = self._fit(curve, units, context)
        left_out = ''
        if isinstance(s.tau_spec, tuple):  # a τ the record cannot give is named, not dropped
            longest = max((g.n_samples for g in ch.segments), default=0)
            left_out = listed_taus_left_out(s.tau_spec, curve.tau0_s, longest,
                                            s.max_tau_fraction)
            if left_out:  # said in the summary (taus_left_out) and in the fit's notes (JSON)
                fit = replace(fit, notes=(left_out, *fit.notes))
        # error bars (§E.2): the EDF blended over the noise types by their shares at each τ
        model = self._noise_model(curve, fit, units)
        shares = curve_shares(curve, model)
        alpha = dominant_alpha(shares)
        edf = curve_edf(curve, shares, uniform_quantisation=stream.topic in PULSE_TOPICS)
        std = adev_std(curve.adev, edf)
        others = {}
        for name, (var, _, _) in curve.others.items():
            dev = np.sqrt(var)
            nu = curve_edf(curve, curve_shares(curve, model, name), name)
            others[name] = (dev, adev_std(dev, nu), nu)
        totdev = (self._totdev(ch, model, curve.tau0_s, stream.topic in PULSE_TOPICS)
                  if curve.overlap == 'partial' else None)
        return AxisResult(ch.name, units, curve, fit, std, totdev, '', alpha, others, edf,
                          shares, self._outlier_report(ch, units, curve, fit, context),
                          left_out)

    def _fit(self, curve: AllanCurve, units: TermUnits, context: str) -> NoiseFit:
        """The joint term fit of one curve with the settings' limits (§E.3)."""
        s = self.settings
        return fit_noise_terms(curve, units, min_significance=s.min_term_significance,
                               edge_significance=s.edge_term_significance,
                               ramp_significance=s.ramp_term_significance,
                               min_tau_s=s.fit_min_tau_s, max_tau_s=s.fit_max_tau_s,
                               context=context, min_clusters=s.fit_min_clusters,
                               exclude_band_limited=bool(s.fit_exclude_band_limited),
                               tau_list=s.tau_spec if isinstance(s.tau_spec, tuple) else None)

    def _outlier_report(self, ch: ChannelAccumulator, units: TermUnits,
                        curve: AllanCurve | None, fit: NoiseFit | None,
                        context: str = '') -> OutlierReport | None:
        """The spikes of one channel and what the other treatment of them gives (§E.6)."""
        tally = ch.outlier_tally
        if tally is None:
            return None
        s = self.settings
        statistic = 'rate' if ch.kind == 'rate' else 'increment'
        other = ch.shadow_curve()
        if not tally.spikes or curve is None or other is None:
            return OutlierReport(ch.name, s.outliers, s.outlier_sigma, s.outlier_block_samples,
                                 statistic, tally)
        main_1s = adev_at(curve.tau_s, curve.adev)
        other_1s = adev_at(other.tau_s, other.adev)
        other_fit = self._fit(other, units, context) if int(
            np.count_nonzero(other.avar > 0)) >= 2 else None
        terms: dict[str, tuple[float, float]] = {}
        for key in units.keys:
            a = fit.estimates.get(key) if fit is not None else None
            b = other_fit.estimates.get(key) if other_fit is not None else None
            if a is None and b is None:
                continue
            terms[key] = (float(a.value) if a is not None else math.nan,
                          float(b.value) if b is not None else math.nan)
        if s.outliers == 'remove':  # (recorded, removed) whichever the estimator took
            main_1s, other_1s = other_1s, main_1s
            terms = {k: (b, a) for k, (a, b) in terms.items()}
        symbols = {key: SYMBOLS[k] for k, key in enumerate(units.keys)}
        return OutlierReport(ch.name, s.outliers, s.outlier_sigma, s.outlier_block_samples,
                             statistic, tally, (main_1s, other_1s), terms, symbols)

    def _noise_model(self, curve: AllanCurve, fit: NoiseFit,
                     units: TermUnits) -> FloatArray | None:
        """(Q², N², B², K², R²) that identifies the noise types at each τ (§E.2).

        The term fit's model; where it has no random term (too few τ points once a
        band-limited range was left out, say), the same fit over every τ with enough
        clusters, nothing left out for misfit and no term reported — only to read the
        types' shares; None when that has none either (then the local slope decides).
        """
        if np.any(fit.theta[:4] > 0):
            return fit.theta
        s = self.settings
        wide = fit_noise_terms(curve, units, min_tau_s=s.fit_min_tau_s, max_tau_s=s.fit_max_tau_s,
                               min_clusters=s.fit_min_clusters, exclude_band_limited=False,
                               min_points=3)
        return wide.theta if np.any(wide.theta[:4] > 0) else None

    @staticmethod
    def _totdev(ch: ChannelAccumulator, model: FloatArray | None, tau0_s: float,
                pulses: bool) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """TOTDEV at long τ (partial overlap) with its blended EDF (§E.2 (6a))."""
        td = ch.total_deviation()
        if td is None:
            return None
        tau, dev, n_points, m = td
        level0 = np.maximum(np.round(tau / tau0_s), 1).astype(np.int64)
        shares = None if model is None else model_shares('totdev', level0, tau0_s, model)
        if shares is None:
            shares = slope_shares(tau, dev**2)
        pure = np.stack([edf_totdev(n_points, m, a) for a in TERM_ALPHA[:4]])
        if pulses:
            pure[0] = pure[0] * uniform_quantisation_factor('totdev', level0)
        edf = blended_edf(shares, pure, level0)
        return tau, dev, adev_std(dev, edf)
