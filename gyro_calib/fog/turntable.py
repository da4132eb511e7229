"""Turntable scale factor of the FOG, IEEE Std 952 style, and the equivalence mapping.

Per constant-rate segment (METHODS §B, §E; issue 10 Part 1 items 3–4):

- the span: whole table revolutions between the first and last valid zero-index events
  when there are two or more (the horizontal Earth rate, turning with the table, then
  cancels exactly; ω = 2π·m/Δt), else the whole steady span between joint_states samples
  (ω = Δψ/Δt from the encoder), where that residual is bounded by
  2·Ω_h·sin(tilt_max)/|Δψ| (Ω_h = Ω_e·cos φ, or Ω_e without a latitude) and enters the
  segment's variance as a uniform distribution of that half-width;
- the output rate R = (C(t₂) − C(t₁))/(t₂ − t₁), the counts at the ends from local line
  fits (:class:`~gyro_calib.fog.counts.CountCells`);
- its noise: the span cut into equal blocks; the scatter of the block increments about
  R·T_b estimates the angle random walk N² (counts²/s) — with the block-boundary count
  errors left in, so it errs on the safe side; pooled over segments (ARW does not
  depend on rate) it gives each segment the variance N²/T + (se₁² + se₂²)/T², the second
  term the quantisation of its end counts.

Fits (:mod:`gyro_calib.fog.fits`; each rate one point, as IEEE Std 952 fits them; sandwich
covariance from the segment variances): R = K·ω + B over all
segments → K, nonlinearity (and the bias B/K when all rates have one sign);
R = K₊·ω⁺ + K₋·ω⁻ + B → asymmetry 2(K₊ − K₋)/(K₊ + K₋) and, with rates of both signs, the
bias B/K (the line's intercept would carry the asymmetry's even term K·(a/2)·mean|ω|);
R = B + K₁ω + K₂ω² + K₃ω³ → k₂ = K₂/K₁, k₃ = K₃/K₁ (≥ 5 rates).
The mapping is the same line fitted over the segments at the mapping rates only, weighted by
their lengths (a local slope: weighting is only a matter of efficiency there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate
from gyro_calib.fog.counts import random_walk_increment_s
from gyro_calib.fog.fits import (
    LinearFit,
    line_design,
    nonlinearity,
    polynomial_design,
    ratio_std,
    two_slope_design,
    weighted_least_squares,
)
from gyro_calib.fog.segments import rate_deg_s, stamp_text
from gyro_calib.units import EARTH_RATE_DEG_H

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.fog.counts import CountCells
    from gyro_calib.fog.segments import SteadyRun
    from gyro_calib.fog.settings import FogSettings

    FloatArray = npt.NDArray[np.float64]

EARTH_RATE_RAD_S = math.radians(EARTH_RATE_DEG_H) / 3600.0
"""Earth rotation rate, rad/s."""


@dataclass(frozen=True, slots=True)
class SegmentMeasurement:
    """Mean table and output rates over one constant-rate segment.

    Attributes:
        start_ns, end_ns: the span measured (zero-index events or joint_states samples), ns.
        rate_rad_s: table rate ω over the span, rad/s.
        output_rate_counts_s: output rate R over the span, counts/s.
        duration_s: T, s.
        revolutions: whole revolutions m between zero-index events (0: no index used).
        end_variance_counts2: se₁² + se₂² of the end counts, counts².
        block_ss_counts2: Σ (D_j − R·T_b)² over the noise blocks, counts².
        block_count: J, noise blocks.
        block_s: T_b, s.
        boundary_variance_counts2: mean se² of the block-boundary counts, counts².
        earth_bound_rad_s: half-width of the horizontal Earth-rate residual (0 with index).
        fit_window_s: mean width of the local fits at the block boundaries, s.
    """

    start_ns: int
    end_ns: int
    rate_rad_s: float
    output_rate_counts_s: float
    duration_s: float
    revolutions: int
    end_variance_counts2: float
    block_ss_counts2: float
    block_count: int
    block_s: float
    boundary_variance_counts2: float
    earth_bound_rad_s: float
    fit_window_s: float = 0.0

    def arw_estimate(self) -> tuple[float, int]:
        """(N² estimate in counts²/s, its degrees of freedom) from this segment's blocks.

        Each boundary count is a local fit, the mean of the random walk over its window, so
        an increment holds N²·T_eff (:func:`random_walk_increment_s`), not N²·T_b.
        """
        j = self.block_count
        if j < 2:
            return 0.0, 0
        # the block increments also carry the errors of their boundary counts; they are
        # left in (the quantisation of a steady count sequence averages far better than a
        # white-noise model says, so subtracting a modelled share biases N² low)
        t_eff = random_walk_increment_s(self.block_s, self.fit_window_s)
        return self.block_ss_counts2 / ((j - 1) * t_eff), j - 1


def _reference_events(angles: FloatArray, tol: float) -> npt.NDArray[np.bool_]:
    """Events at the segment's reference mark: the largest group agreeing modulo 2π."""
    best: npt.NDArray[np.bool_] = np.zeros(len(angles), dtype=bool)
    for ref in angles:
        off = angles - ref
        off = off - 2.0 * math.pi * np.round(off / (2.0 * math.pi))
        group = np.abs(off) <= tol
        if group.sum() > best.sum():
            best = group
    return best


def measure_segment(run: SteadyRun, index_ns: npt.NDArray[np.int64], cells: CountCells,
                    settings: FogSettings) -> SegmentMeasurement | str:
    """Measure one steady run; a whole-sentence reason when it cannot be used.

    Args:
        run: the constant-rate span from :class:`~gyro_calib.fog.segments.SegmentDetector`.
        index_ns: zero-index stamps (sorted), ns.
        cells: the reduced output stream covering the run.
        settings: the calibration settings.
    """
    where = f'{stamp_text(run.start_ns)}–{stamp_text(run.end_ns)}'
    if run.excursion is not None:
        t0, t1, dev = run.excursion
        return (f'segment at {rate_deg_s(run.rate_rad_s)} {where} has a rate excursion: the '
                f'table left that rate from {stamp_text(t0)} to {stamp_text(t1)} (largest '
                f'deviation {math.degrees(dev):.4g} °/s) and came back; the segment was not '
                f'used — repeat this rate.')
    min_ns = int(settings.min_segment_s * 1e9)
    if run.span_a is None or run.span_b is None or run.span_b[0] - run.span_a[0] < min_ns:
        return (f'segment at {rate_deg_s(run.rate_rad_s)} {where} is shorter than '
                f'min_segment_s = {settings.min_segment_s:g} s after the '
                f'{settings.segment_guard_s:g} s guards; not used.')
    (ta, psi_a), (tb, psi_b) = run.span_a, run.span_b
    omega_enc = (psi_b - psi_a) / ((tb - ta) / 1e9)
    t1, t2, revs = ta, tb, 0
    omega = omega_enc
    events = index_ns[(index_ns >= ta) & (index_ns <= tb)]
    if len(events) >= 2 and omega_enc != 0.0:
        angles = psi_a + omega_enc * (events - ta) / 1e9
        valid = _reference_events(np.asarray(angles, np.float64),
                                  math.radians(settings.index_angle_tolerance_deg))
        if valid.sum() >= 2:
            ev = events[valid]
            m = int(round(abs(angles[valid][-1] - angles[valid][0]) / (2.0 * math.pi)))
            if m >= 1:
                t1, t2, revs = int(ev[0]), int(ev[-1]), m
                omega = math.copysign(2.0 * math.pi * m, omega_enc) / ((t2 - t1) / 1e9)
    duration = (t2 - t1) / 1e9
    bound = 0.0
    if revs == 0:
        lat = math.radians(settings.latitude_deg) if settings.latitude_known else 0.0
        turned = abs(omega * duration)
        bound = (EARTH_RATE_RAD_S * math.cos(lat) * math.sin(math.radians(
            settings.max_sense_axis_tilt_deg)) * min(1.0, 2.0 / turned if turned else 1.0))
    blocks = int(max(1, min(settings.noise_blocks, duration // settings.min_block_s)))
    edges = [t1 + (t2 - t1) * k // blocks for k in range(blocks + 1)]
    h = int(settings.fit_half_width_s * 1e9)
    fits = []
    for edge in edges:
        fit = cells.count_at(edge, h, run.start_ns, run.end_ns, settings.min_fit_samples,
                             min_transitions=settings.min_fit_transitions,
                             max_half_width_ns=int(settings.max_fit_half_width_s * 1e9))
        if fit is None:
            return (f'segment at {rate_deg_s(run.rate_rad_s)} {where}: fewer than '
                    f'{settings.min_fit_samples} output samples within ±'
                    f'{settings.max_fit_half_width_s:g} s of {stamp_text(edge)} (gap in '
                    f'/fog/output); not used.')
        if fit.rms_residual > settings.max_fit_residual_counts:
            return (f'segment at {rate_deg_s(run.rate_rad_s)} {where}: the output counts '
                    f'around {stamp_text(edge)} deviate from a line by '
                    f'{fit.rms_residual:.3g} counts rms (limit '
                    f'{settings.max_fit_residual_counts:g}): count glitch or an unsteady '
                    f'output (an injection not recorded on /fog/injection?), or an angle '
                    f'random walk larger than the limit allows over the fit window (then raise '
                    f'max_fit_residual_counts); not used.')
        fits.append(fit)
    counts = np.array([f.value for f in fits])
    rate_out = float((counts[-1] - counts[0]) / duration)
    block_s = duration / blocks
    increments = np.diff(counts)
    ss = float(np.sum((increments - rate_out * np.diff(edges) / 1e9) ** 2))
    se2 = np.array([f.std_uncertainty ** 2 for f in fits])
    return SegmentMeasurement(
        start_ns=t1, end_ns=t2, rate_rad_s=omega, output_rate_counts_s=rate_out,
        duration_s=duration, revolutions=revs, end_variance_counts2=float(se2[0] + se2[-1]),
        block_ss_counts2=ss, block_count=blocks, block_s=block_s,
        boundary_variance_counts2=float(np.mean(se2)), earth_bound_rad_s=bound,
        fit_window_s=float(np.mean([f.window_s for f in fits])))


QUANTISATION_COUNTS2_PER_INCREMENT = 1.0
"""Most the integer output's quantisation can add to one block increment, counts²: each
local-fit count at a block boundary can be off by up to ½ count when the count transitions
beat slowly against the sample rate (see FogCalibrator._steady)."""


@dataclass(frozen=True, slots=True)
class SegmentNoise:
    """Angle random walk pooled over segments.

    Attributes:
        arw_counts2_s: N², counts²/s (≥ 0): the block scatter, boundary errors left in
            (the variances of the segments' output rates use it: on the safe side).
        dof: degrees of freedom of the pooled estimate.
        quantisation_counts2_s: the most of N² the count quantisation can account for,
            counts²/s: QUANTISATION_COUNTS2_PER_INCREMENT / T_b pooled over the segments.
    """

    arw_counts2_s: float
    dof: int
    quantisation_counts2_s: float = 0.0

    def angle_random_walk(self, k_abs: float) -> tuple[float, float]:
        """(ARW, its standard uncertainty), rad/√s.

        (ARW, its standard uncertainty), rad/√s: the midpoint of the interval √N²/|K| over
        N² ∈ [N²_blocks − Q − 2σ, N²_blocks + 2σ] (Q the most the quantisation can add,
        σ = N²·√(2/dof) the scatter's own) and the standard deviation of a rectangular
        distribution over it (GUM 4.3.7), so that an output whose block scatter is all
        quantisation gets an interval reaching down to zero.
        """
        if not self.dof:
            return math.sqrt(self.arw_counts2_s) / k_abs, math.inf
        n2 = self.arw_counts2_s
        sigma = n2 * math.sqrt(2.0 / self.dof)
        lo = math.sqrt(max(n2 - self.quantisation_counts2_s - 2.0 * sigma, 0.0)) / k_abs
        hi = math.sqrt(n2 + 2.0 * sigma) / k_abs
        return 0.5 * (lo + hi), (hi - lo) / (2.0 * math.sqrt(3.0))

    @property
    def basis(self) -> str:
        """What the ARW uncertainty rests on."""
        return (f'block scatter over {self.dof} dof; the count quantisation may account for '
                f'up to {self.quantisation_counts2_s:.3g} counts²/s of it (≤ '
                f'{QUANTISATION_COUNTS2_PER_INCREMENT:g} count² per block increment): '
                f'midpoint of the 2σ interval, rectangular')

    def variances(self, segments: list[SegmentMeasurement], k_abs: float) -> FloatArray:
        """Variance of each segment's output rate, (counts/s)²."""
        t = np.array([s.duration_s for s in segments])
        end = np.array([s.end_variance_counts2 for s in segments])
        bound = np.array([s.earth_bound_rad_s for s in segments]) * k_abs
        variances: FloatArray = self.arw_counts2_s / t + end / t**2 + bound**2 / 3.0
        return variances


def pooled_noise(segments: list[SegmentMeasurement]) -> SegmentNoise:
    """Pool the segments' block estimates of N² (weighted by their degrees of freedom)."""
    total, quantisation, dof = 0.0, 0.0, 0
    for s in segments:
        est, nu = s.arw_estimate()
        total += est * nu
        if nu:
            quantisation += QUANTISATION_COUNTS2_PER_INCREMENT / s.block_s * nu
        dof += nu
    if not dof:
        return SegmentNoise(0.0, 0)
    return SegmentNoise(max(total / dof, 0.0), dof, quantisation / dof)


def distinct_rates(rates_rad_s: FloatArray, settings: FogSettings) -> int:
    """Number of rates that differ by more than the segment tolerance."""
    floor = math.radians(settings.segment_rate_floor_deg_s)
    count, last = 0, None
    for r in np.sort(rates_rad_s):
        if last is None or r - last > settings.segment_rate_tolerance * abs(r) + floor:
            count += 1
            last = r
    return count


@dataclass(frozen=True, slots=True)
class TurntableFit:
    """IEEE Std 952 turntable calibration (issue 10 Part 1 item 3).

    Attributes:
        scale_factor: K, counts/rad.
        bias: B/K, rad/s (Earth rate along the table axis removed when ``earth_removed``).
        earth_removed: True when a latitude was given.
        nonlinearity_ppm: max |residual| / full-scale output, ppm (None with fewer than 3
            distinct rates: a line through two rates leaves no residual to measure it by).
        asymmetry_ppm: 2(K₊ − K₋)/(K₊ + K₋), ppm (None without rates of both signs).
        quadratic_s_per_rad: k₂ = K₂/K₁ (None with fewer than 5 distinct rates).
        cubic_s2_per_rad2: k₃ = K₃/K₁ (None likewise).
        angle_random_walk_rad_sqrt_s: pooled N / |K| from the segments' blocks, rad/√s.
        segments: the segments fitted.
        variances: their output-rate variances, (counts/s)².
        residuals: R_i − (K·ω_i + B), counts/s.
        line: the line fit (operator rows: K, B).
        notes: whole sentences about the fit (why optional terms are missing).
    """

    scale_factor: Estimate
    bias: Estimate
    earth_removed: bool
    nonlinearity_ppm: Estimate | None
    asymmetry_ppm: Estimate | None
    quadratic_s_per_rad: Estimate | None
    cubic_s2_per_rad2: Estimate | None
    angle_random_walk_rad_sqrt_s: Estimate
    segments: tuple[SegmentMeasurement, ...]
    variances: FloatArray
    residuals: FloatArray
    line: LinearFit
    notes: tuple[str, ...] = field(default=())

    @property
    def rates_rad_s(self) -> FloatArray:
        """Table rates of the segments, rad/s."""
        return np.array([s.rate_rad_s for s in self.segments])

    @property
    def outputs_counts_s(self) -> FloatArray:
        """Output rates of the segments, counts/s."""
        return np.array([s.output_rate_counts_s for s in self.segments])


def _segment_arrays(segments: list[SegmentMeasurement]) -> tuple[FloatArray, FloatArray,
                                                                 FloatArray]:
    w = np.array([s.rate_rad_s for s in segments])
    r = np.array([s.output_rate_counts_s for s in segments])
    t = np.array([s.duration_s for s in segments])
    return w, r, t


def fit_turntable(segments: list[SegmentMeasurement], noise: SegmentNoise,
                  settings: FogSettings) -> TurntableFit | str:
    """Least-squares turntable calibration over ``segments``; a reason when impossible."""
    if not segments:
        return 'no constant-rate segment of the rate table was measured.'
    w, r, t = _segment_arrays(segments)
    n_rates = distinct_rates(w, settings)
    if n_rates < settings.min_turntable_rates:
        return (f'{n_rates} distinct table rate(s) measured; the turntable fit needs '
                f'min_turntable_rates = {settings.min_turntable_rates}.')
    zero_var = noise.variances(segments, 0.0)
    t = np.ones_like(t)  # each segment one point
    first = weighted_least_squares(line_design(w), r, t, zero_var)
    k_abs = abs(float(first.beta[0]))
    var = noise.variances(segments, k_abs)
    line = weighted_least_squares(line_design(w), r, t, var)
    k, b = float(line.beta[0]), float(line.beta[1])
    n, dof = len(segments), noise.dof
    basis = (f'least squares over {n} segments; each segment N²/T + end-count quantisation, '
             f'N² pooled from {dof} block dof')
    scale = Estimate(k, line.std(0), n, dof, basis=basis)
    bias = b / k
    bias_std = ratio_std(b, k, line.cov[1, 1], line.cov[0, 0], line.cov[0, 1])
    bias_basis = basis
    notes: list[str] = []
    nl_est = None
    if n_rates >= 3:
        nl = nonlinearity(line, r)
        nl_est = Estimate(nl.ppm, nl.std_ppm, n, max(n - 2, 0),
                          basis='uncertainty of the largest residual / full scale')
    else:
        notes.append(f'nonlinearity is not measurable from {n_rates} distinct rates: a line '
                     f'through two rates leaves no residual (measure three or more rates).')
    asym = None
    if np.any(w > 0) and np.any(w < 0):
        try:
            two = weighted_least_squares(two_slope_design(w), r, t, var)
            p, q = float(two.beta[0]), float(two.beta[1])
            s = p + q
            grad = np.array([4.0 * q / s**2, -4.0 * p / s**2])
            a_std = float(np.sqrt(max(grad @ two.cov[:2, :2] @ grad, 0.0)))
            asym = Estimate(2.0 * (p - q) / s * 1e6, a_std * 1e6, n, dof)
            # an asymmetry is an even term (a/2)·K·|ω|: the line's intercept would carry
            # K·(a/2)·mean|ω| of it; the two-slope fit's intercept is the zero-rate output
            b2 = float(two.beta[2])
            cov_bk = float(np.sum(two.operator[2] * line.operator[0] * var))
            bias, bias_std = b2 / k, ratio_std(b2, k, two.cov[2, 2], line.cov[0, 0], cov_bk)
            bias_basis = basis + '; intercept of the two-slope (asymmetry) fit'
        except np.linalg.LinAlgError:
            notes.append('asymmetry needs at least three distinct rates with both signs.')
    else:
        notes.append('asymmetry needs table rates of both signs.')
    if settings.latitude_known:
        bias -= EARTH_RATE_RAD_S * math.sin(math.radians(settings.latitude_deg))
    quad = cubic = None
    if n_rates >= 5:
        poly = weighted_least_squares(polynomial_design(w, 3), r, t, var)
        k1, k2, k3 = (float(v) for v in poly.beta[:3])
        quad = Estimate(k2 / k1, ratio_std(k2, k1, poly.cov[1, 1], poly.cov[0, 0],
                                           poly.cov[0, 1]), n, dof)
        cubic = Estimate(k3 / k1, ratio_std(k3, k1, poly.cov[2, 2], poly.cov[0, 0],
                                            poly.cov[0, 2]), n, dof)
    else:
        notes.append('quadratic and cubic scale-factor terms need at least 5 distinct rates.')
    arw, arw_std = noise.angle_random_walk(k_abs)
    return TurntableFit(
        scale_factor=scale, bias=Estimate(bias, bias_std, n, dof, basis=bias_basis),
        earth_removed=settings.latitude_known,
        nonlinearity_ppm=nl_est,
        asymmetry_ppm=asym, quadratic_s_per_rad=quad, cubic_s2_per_rad2=cubic,
        angle_random_walk_rad_sqrt_s=Estimate(
            arw, arw_std, n, noise.dof,
            basis=noise.basis),
        segments=tuple(segments), variances=var, residuals=line.residuals, line=line,
        notes=tuple(notes))


@dataclass(frozen=True, slots=True)
class MappingFit:
    """Equivalence mapping: output counts per unit table rate near the mapping rates.

    All mapping segments in one weighted line fit (seed 001 eqs. 8–10; METHODS §B): the
    0.01 °/s difference alone is noise-limited, the 1 °/s one carries the lever arm.

    Attributes:
        scale_factor: K_map, counts/s per rad/s (= counts/rad).
        segments: indices (into the segment list given) of the mapping segments.
        operator: slope row of the fit over those segments (for covariances).
        rates_found_deg_s: the mapping rates present, °/s.
        rates_missing_deg_s: the mapping rates absent, °/s.
    """

    scale_factor: Estimate
    segments: tuple[int, ...]
    operator: FloatArray
    rates_found_deg_s: tuple[float, ...]
    rates_missing_deg_s: tuple[float, ...]

    def output_step_counts_s(self, step_deg_s: float) -> float:
        """Output-rate change of a table-rate step (0.01, 0.1, 1 °/s in the paper), counts/s."""
        return self.scale_factor.value * math.radians(step_deg_s)


def fit_mapping(segments: list[SegmentMeasurement], noise: SegmentNoise,
                settings: FogSettings) -> MappingFit | str:
    """The equivalence mapping over the segments at ``settings.mapping_rates_deg_s``."""
    tol = settings.mapping_rate_tolerance_deg_s
    chosen: list[int] = []
    found: set[float] = set()
    for i, s in enumerate(segments):
        for rate in settings.mapping_rates_deg_s:
            if abs(math.degrees(s.rate_rad_s) - rate) <= tol:
                chosen.append(i)
                found.add(rate)
    missing = tuple(r for r in settings.mapping_rates_deg_s if r not in found)
    listed = ', '.join(f'{r:g}' for r in settings.mapping_rates_deg_s)
    if len(found) < 2:
        return (f'no equivalence mapping: turntable segments at {len(found)} of the mapping '
                f'rates ({listed} °/s) were measured; at least two are needed.')
    subset = [segments[i] for i in chosen]
    w, r, t = _segment_arrays(subset)  # weights T_i: a segment's ARW variance is ∝ 1/T_i
    first = weighted_least_squares(line_design(w), r, t, noise.variances(subset, 0.0))
    var = noise.variances(subset, abs(float(first.beta[0])))
    fit = weighted_least_squares(line_design(w), r, t, var)
    est = Estimate(float(fit.beta[0]), fit.std(0), len(subset), noise.dof,
                   basis=f'one least-squares line over {len(subset)} segments at '
                         f'{len(found)} mapping rates')
    return MappingFit(est, tuple(chosen), fit.operator[0].copy(),
                      tuple(sorted(found)), missing)


def mapping_turntable_covariance(mapping: MappingFit, turntable: TurntableFit,
                                 segments: list[SegmentMeasurement]) -> float:
    """cov(K_map, K) from the segments both fits share, (counts/rad)²."""
    index = {id(s): i for i, s in enumerate(turntable.segments)}
    k_row = turntable.line.operator[0]
    cov = 0.0
    for coef, seg_i in zip(mapping.operator, mapping.segments):
        j = index.get(id(segments[seg_i]))
        if j is not None:
            cov += coef * k_row[j] * turntable.variances[j]
    return float(cov)
