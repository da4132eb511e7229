"""Self-calibration by ladder-wave injection on a static base (METHODS §B; seed 001 §2–4).

Each `/fog/injection` value J (counts/s a linear loop would add) is in force from its
stamp until the next message: one plateau. For each plateau (issue 10 Part 1 item 5):

- the settled part is found from the data: the output rate of each 50 ms cell is compared
  with the plateau's final level (median of its second half) and scatter (MAD, but no
  less than the cell's count quantisation, 1.5/(T_cell·√looks), one look per count
  transition, at most one per sample); the transient lasts from the start until three
  cells in a row lie within ``settle_threshold_sigma`` of the level, and as long again is
  skipped for its tail below that threshold. Too little settled time
  left → rejected;
- the settled part must be stationary: a rate change between its two halves (from
  local-fit counts) beyond ``plateau_drift_sigma`` and ``plateau_drift_fraction`` of the
  largest injection means the loop did not hold the injection (out of lock, front end
  beyond its range) → rejected;
- N_i is the mean output rate between local-fit counts at the settled part's ends, with a
  Type A variance from equal blocks (angle random walk grows with the injection, as the
  front end leaves null, so it is not pooled across plateaus);
- the plateau must follow the injection: (N_i − N_ref)/(J_i − J_ref) against the latest
  accepted zero-injection plateau (else the previous accepted one) must lie within
  [``min_response_ratio``, ``max_response_ratio``].

Fit: ω_i = J_i / K_map (the equivalence mapping) and N_i = K·ω_i + N₀, so K = s·K_map with
s the slope of N against J. The table of K against the number of plateaus used (as the
paper's Table 1) nests the plateaus by |J| from zero up; the linear range is the largest
such range whose IEEE nonlinearity stays within ``self_cal_nonlinearity_spec_ppm``, and
the self-calibrated K is the slope over it, its uncertainty including the mapping's. A
quintic over the largest range where a cubic agrees with its slope at zero gives the
zero-amplitude (small-signal) K beside it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate
from gyro_calib.fog.counts import random_walk_increment_s
from gyro_calib.fog.fits import (
    line_design,
    nonlinearity,
    polynomial_design,
    weighted_least_squares,
)
from gyro_calib.fog.segments import stamp_text

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.fog.counts import CountCells
    from gyro_calib.fog.settings import FogSettings
    from gyro_calib.fog.turntable import MappingFit, TurntableFit

    FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class PlateauMeasurement:
    """Mean output rate over the settled part of one injected plateau.

    Attributes:
        start_ns, end_ns: the plateau as the injection messages cut it, ns.
        injection_counts_s: J, counts/s.
        settled_ns: where the output had settled, ns.
        output_rate_counts_s: N, counts/s.
        variance_counts2_s2: Type A variance of N, (counts/s)².
        settled_s: length of the span N is measured over, s.
        drift_counts_s: change of the output rate across the settled part (trend), counts/s.
        late_rate_counts_s: N over the second half of the settled part alone, counts/s (N
            itself when the plateau had fewer than two noise blocks).
        late_variance_counts2_s2: its Type A variance, (counts/s)².
        half_difference_variance_counts2_s2: variance of (second-half − first-half rate),
            (counts/s)² (inf without two noise blocks).
    """

    start_ns: int
    end_ns: int
    injection_counts_s: float
    settled_ns: int
    output_rate_counts_s: float
    variance_counts2_s2: float
    settled_s: float
    drift_counts_s: float
    late_rate_counts_s: float = math.nan
    late_variance_counts2_s2: float = math.nan
    half_difference_variance_counts2_s2: float = math.inf

    @property
    def std_counts_s(self) -> float:
        """Standard uncertainty of N, counts/s."""
        return math.sqrt(max(self.variance_counts2_s2, 0.0))

    def describe(self) -> str:
        """The plateau for log lines."""
        return f'plateau J = {self.injection_counts_s:.6g} counts/s at {stamp_text(self.start_ns)}'


def describe_plateau(start_ns: int, injection_counts_s: float) -> str:
    """A plateau for log lines before it is measured."""
    return f'plateau J = {injection_counts_s:.6g} counts/s at {stamp_text(start_ns)}'


def measure_plateau(start_ns: int, end_ns: int, injection_counts_s: float, cells: CountCells,
                    settings: FogSettings, largest_injection_counts_s: float
                    ) -> PlateauMeasurement | str:
    """Measure one plateau; a whole-sentence reason when it cannot be used."""
    what = describe_plateau(start_ns, injection_counts_s)
    length = (end_ns - start_ns) / 1e9
    t_cells, rates = cells.cell_rates(start_ns, end_ns)
    if len(rates) < 6:
        return (f'{what} lasted {length:.3g} s: shorter than the loop needs to settle and be '
                f'measured (fewer than 6 output cells of {settings.cell_s:g} s); not used.')
    half = len(rates) // 2
    level = float(np.median(rates[half:]))
    sigma = 1.4826 * float(np.median(np.abs(rates[half:] - level)))
    # a cell's rate cannot resolve better than its ±½-count quantisation allows: about
    # 1/(T_cell·√looks), one independent look per count transition (at most one per sample)
    cell_s = cells.cell_ns / 1e9
    per_cell = max(float(np.median(cells.cell_sizes(start_ns, end_ns))), 3.0)
    looks = min(per_cell, 1.0 + abs(level) * cell_s)
    sigma = max(sigma, 1.5 / (math.sqrt(looks) * cell_s))
    outside = np.abs(rates[:half] - level) > settings.settle_threshold_sigma * sigma
    # the transient: from the start until three cells in a row lie inside (a lone cell
    # outside later is noise; a real drift is the trend test's business)
    inside_run = np.convolve(~outside, np.ones(3, dtype=int), mode='valid') == 3
    first_quiet = int(np.argmax(inside_run)) if inside_run.any() else half
    settled = start_ns
    if first_quiet > 0:
        # the transient's tail below the threshold: skip as long again as it was seen
        seen_until = int(t_cells[first_quiet - 1]) + cells.cell_ns
        settled = min(start_ns + 2 * (seen_until - start_ns), end_ns)
    h = int(settings.fit_half_width_s * 1e9)
    t1, t2 = settled + h, end_ns - h
    span = (t2 - t1) / 1e9
    if span < settings.min_plateau_settled_s:
        return (f'{what} lasted {length:.3g} s; the output settled '
                f'{(settled - start_ns) / 1e9:.3g} s after it began, leaving {max(span, 0):.3g} s '
                f'to measure, less than min_plateau_settled_s = '
                f'{settings.min_plateau_settled_s:g} s: the plateau is shorter than the loop '
                f'needs to settle; not used.')
    blocks = int(max(1, min(settings.noise_blocks, span // settings.min_block_s)))
    if blocks >= 2:
        blocks -= blocks % 2  # an even count: the two halves are compared for a drift
    edges = [t1 + (t2 - t1) * k // blocks for k in range(blocks + 1)]
    fits = []
    for edge in edges:
        fit = cells.count_at(edge, h, settled, end_ns, settings.min_fit_samples,
                             min_transitions=settings.min_fit_transitions,
                             max_half_width_ns=int(settings.max_fit_half_width_s * 1e9))
        if fit is None:
            return (f'{what}: fewer than {settings.min_fit_samples} output samples within '
                    f'±{settings.max_fit_half_width_s:g} s of {stamp_text(edge)} (gap in '
                    f'/fog/output); not used.')
        if fit.rms_residual > settings.max_fit_residual_counts:
            return (f'{what}: the output counts around {stamp_text(edge)} deviate from a '
                    f'line by {fit.rms_residual:.3g} counts rms (limit '
                    f'{settings.max_fit_residual_counts:g}): a count glitch, or an angle random '
                    f'walk larger than the limit allows over the fit window (then raise '
                    f'max_fit_residual_counts); not used.')
        fits.append(fit)
    counts = np.array([f.value for f in fits])
    se2 = np.array([f.std_uncertainty ** 2 for f in fits])
    rate = float((counts[-1] - counts[0]) / span)
    variance = float((se2[0] + se2[-1]) / span**2)
    drift = 0.0
    late_rate, late_var, diff_var = rate, variance, math.inf
    if blocks >= 2:
        block_s = span / blocks
        ss = float(np.sum((np.diff(counts) - rate * np.diff(edges) / 1e9) ** 2))
        t_eff = random_walk_increment_s(block_s, float(np.mean([f.window_s for f in fits])))
        arw2 = ss / ((blocks - 1) * t_eff)  # boundary errors left in: on the safe side
        variance += arw2 / span
        # stationarity: the rate over the second half against the first, from local-fit
        # counts (cell rates would see the slow beat of the count quantisation as a trend)
        mid = blocks // 2
        half_s = span / 2.0
        drift = 2.0 * float(counts[-1] - 2.0 * counts[mid] + counts[0]) / half_s
        var_drift = 4.0 * ((se2[0] + 4.0 * se2[mid] + se2[-1]) / half_s**2 + 4.0 * arw2 / span)
        late_half = (edges[-1] - edges[mid]) / 1e9
        late_rate = float((counts[-1] - counts[mid]) / late_half)
        late_var = float((se2[mid] + se2[-1]) / late_half**2 + arw2 / late_half)
        diff_var = var_drift / 4.0
        z = abs(drift) / math.sqrt(var_drift) if var_drift > 0 else math.inf
        floor = settings.plateau_drift_fraction * largest_injection_counts_s
        if z > settings.plateau_drift_sigma and abs(drift) > floor:
            return (f'{what}: the output rate drifted by {drift:.4g} counts/s across its '
                    f'settled part ({z:.1f} σ): the loop did not hold this injection '
                    f'(front end beyond its range, or out of lock); not used.')
    return PlateauMeasurement(start_ns, end_ns, injection_counts_s, settled, rate, variance,
                              span, drift, late_rate, late_var, diff_var)


def check_response(plateau: PlateauMeasurement, reference: PlateauMeasurement | None,
                   settings: FogSettings, largest_injection_counts_s: float) -> str | None:
    """Reason why ``plateau`` does not follow its injection, or None when it does."""
    if reference is None:
        return None
    dj = plateau.injection_counts_s - reference.injection_counts_s
    dn = plateau.output_rate_counts_s - reference.output_rate_counts_s
    if dj == 0.0:
        noise = 10.0 * math.hypot(plateau.std_counts_s, reference.std_counts_s)
        allowed = max(noise, 1e-3 * largest_injection_counts_s, 1e-9)
        if abs(dn) > allowed:
            return (f'{plateau.describe()}: the output rate differs by {dn:.4g} counts/s from '
                    f'the plateau at the same injection at {stamp_text(reference.start_ns)} '
                    f'(allowed {allowed:.3g}): the loop did not return to the same state '
                    f'(lost lock?); not used.')
        return None
    ratio = dn / dj
    if not settings.min_response_ratio <= ratio <= settings.max_response_ratio:
        return (f'{plateau.describe()}: the output moved by {dn:.4g} counts/s for an injection '
                f'change of {dj:.4g} counts/s (ratio {ratio:.3g}, accepted '
                f'{settings.min_response_ratio:g}–{settings.max_response_ratio:g}) against '
                f'the plateau at {stamp_text(reference.start_ns)}: the output does not follow '
                f'the injection; not used.')
    return None


@dataclass(frozen=True, slots=True)
class RangeRow:
    """One row of the K-against-plateaus table (seed 001 Table 1).

    Attributes:
        plateaus: plateaus used (the n smallest |J|).
        max_injection_counts_s: largest |J| among them, counts/s.
        slope: dN/dJ over them (dimensionless).
        nonlinearity_ppm: IEEE nonlinearity of that fit, ppm (NaN with fewer than 3 points).
        scale_factor: K = slope·K_map, counts/rad (None without a mapping; its uncertainty
            includes the mapping's).
        range_rad_s: largest |ω_i| = max|J|/|K_map| (NaN without a mapping), rad/s.
    """

    plateaus: int
    max_injection_counts_s: float
    slope: Estimate
    nonlinearity_ppm: Estimate
    scale_factor: Estimate | None
    range_rad_s: float

    def nonlinearity_text(self) -> str:
        """The row's nonlinearity for summaries, or why a line through two levels has none."""
        nl = self.nonlinearity_ppm
        if not math.isfinite(nl.value):
            return (f'nonlinearity not measurable from {self.plateaus} plateaus (a line through '
                    f'two levels leaves no residual)')
        return f'nonlinearity {nl.value:.4g} ± {nl.std_uncertainty:.2g} ppm'


@dataclass(frozen=True, slots=True)
class SelfCalFit:
    """Self-calibration over the accepted plateaus.

    Attributes:
        table: K against the number of plateaus used.
        linear: the row of the linear range (None if no range meets the spec).
        scale_factor: K over the linear range, counts/rad (None without mapping or range).
        linear_range_rad_s: the linear range, rad/s (None likewise).
        small_signal: zero-amplitude K from a cubic, counts/rad (None when not available).
        difference: self-cal K − turntable K, counts/rad (None without both).
        plateaus: the plateaus fitted, ordered by |J|.
        notes: whole sentences on what is missing and why.
    """

    table: tuple[RangeRow, ...]
    linear: RangeRow | None
    scale_factor: Estimate | None
    linear_range_rad_s: Estimate | None
    small_signal: Estimate | None
    difference: Estimate | None
    plateaus: tuple[PlateauMeasurement, ...]
    notes: tuple[str, ...]

    @property
    def significance_sigma(self) -> float:
        """|difference| / its standard uncertainty (NaN without a difference)."""
        d = self.difference
        if d is None or d.std_uncertainty == 0:
            return math.nan
        return abs(d.value) / d.std_uncertainty


SETTLING_NOTE = 'the loop was still settling in the first halves of the plateaus'
"""How the note of :func:`unsettled_first_halves` begins."""

SETTLING_SIGMA = 3.0
"""Significance at which the plateaus' first halves, pooled, show the loop still settling."""


def unsettled_first_halves(plateaus: list[PlateauMeasurement]) -> str | None:
    """A sentence when the loop was still settling, else None.

    A whole sentence when the loop was still settling in the plateaus' first halves, else
    None.

    A transient too small to see in one plateau's noise still biases its mean output towards
    the previous level (a first-order approach with time constant τ leaves (J_prev − J)·τ/T
    in the mean over T), and with a ladder that alternates in sign it biases the slope. Over
    all plateaus in time order, the rate difference between the second and the first half
    d_i is regressed on the injection step ΔJ_i = J_i − J_(i−1) (no intercept, unweighted,
    σ_β from the scatter about the line: each plateau's own variance rests on a few blocks
    and grows with its transient, so weights 1/var d_i would hide exactly the plateaus that
    show it): a settled loop gives a slope β consistent with 0; β > SETTLING_SIGMA·σ_β
    means it was not, and the plateaus are then measured over their second halves only
    (unbiased as long as the transient has died out within the first half).
    """
    timed = sorted((p for p in plateaus if math.isfinite(p.half_difference_variance_counts2_s2)
                    and p.half_difference_variance_counts2_s2 > 0
                    and math.isfinite(p.late_rate_counts_s)),
                   key=lambda p: p.start_ns)
    if len(timed) < 3:
        return None
    step = np.array([b.injection_counts_s - a.injection_counts_s
                     for a, b in zip(timed, timed[1:])])
    diff = np.array([p.drift_counts_s / 2.0 for p in timed[1:]])
    info = float(np.sum(step**2))
    if info <= 0:
        return None
    # unweighted, σ from the scatter about the line: a plateau's own variance comes from a
    # few blocks and grows with its transient, so weighting by it hides the transients
    beta = float(np.sum(diff * step)) / info
    scatter = float(np.sum((diff - beta * step) ** 2)) / (len(step) - 1)
    if scatter <= 0:
        return None
    z = beta / math.sqrt(scatter / info)
    if z <= SETTLING_SIGMA:
        return None
    return (f'{SETTLING_NOTE} (their second halves exceed their first by {beta:.3g} × the '
            f'injection step, {z:.1f} σ over {len(step)} steps, although no single plateau '
            f'shows it): every plateau is measured over the second half of its settled part '
            f'(longer plateaus, or a loop that settles faster, give the full precision).')


def _scaled(slope: float, var_slope: float, k_map: Estimate | None) -> Estimate | None:
    return None if k_map is None else Estimate(
        slope * k_map.value,
        math.sqrt(max(k_map.value**2 * var_slope + slope**2 * k_map.std_uncertainty**2, 0.0)),
        0, 0)


def fit_self_cal(plateaus: list[PlateauMeasurement], mapping: MappingFit | None,
                 turntable: TurntableFit | None, cov_map_turntable: float,
                 settings: FogSettings) -> SelfCalFit | str:
    """Fit the accepted plateaus; a reason when too few."""
    order = sorted(range(len(plateaus)),
                   key=lambda i: (abs(plateaus[i].injection_counts_s), plateaus[i].start_ns))
    plats = [plateaus[i] for i in order]
    j = np.array([p.injection_counts_s for p in plats])
    late = unsettled_first_halves(plateaus)
    if late is None:
        n_out = np.array([p.output_rate_counts_s for p in plats])
        var = np.array([max(p.variance_counts2_s2, 0.0) for p in plats])
    else:
        n_out = np.array([p.late_rate_counts_s for p in plats])
        var = np.array([max(p.late_variance_counts2_s2, 0.0) for p in plats])
    w = np.ones(len(plats))  # each plateau one point, as the paper and IEEE Std 952 fit
    if len(plats) < settings.min_plateaus or len(np.unique(j)) < 2:
        return (f'{len(plats)} plateau(s) at {len(np.unique(j))} injection level(s) accepted; '
                f'self-calibration needs min_plateaus = {settings.min_plateaus} at two or more '
                f'levels.')
    k_map = mapping.scale_factor if mapping is not None else None
    rows: list[RangeRow] = []
    for n in range(2, len(plats) + 1):
        if len(np.unique(j[:n])) < 2:
            continue
        fit = weighted_least_squares(line_design(j[:n]), n_out[:n], w[:n], var[:n])
        slope = Estimate(float(fit.beta[0]), fit.std(0), n, n - 2)
        if n >= 3:
            nl = nonlinearity(fit, n_out[:n])
            nl_est = Estimate(nl.ppm, nl.std_ppm, n, n - 2)
        else:
            nl_est = Estimate(math.nan, math.nan, n, 0)
        max_j = float(np.max(np.abs(j[:n])))
        k = _scaled(slope.value, float(fit.cov[0, 0]), k_map)
        if k is not None:
            k = Estimate(k.value, k.std_uncertainty, n, n - 2)
        rng = max_j / abs(k_map.value) if k_map is not None else math.nan
        rows.append(RangeRow(n, max_j, slope, nl_est, k, rng))
    spec = settings.self_cal_nonlinearity_spec_ppm
    linear = None
    for row in rows:
        if row.plateaus >= settings.min_plateaus and row.nonlinearity_ppm.value <= spec:
            linear = row
    notes: list[str] = []
    if late is not None:
        notes.append(late)
    if linear is None:
        notes.append(f'no range of {settings.min_plateaus} or more plateaus from zero up stays '
                     f'within self_cal_nonlinearity_spec_ppm = {spec:g} ppm.')
    if k_map is None:
        notes.append('no equivalence mapping: the injected plateaus cannot be converted to '
                     'rates, so no self-calibrated K (run the mapping rates on the turntable).')
    small = _small_signal(j, n_out, w, var, k_map)
    scale = lin_range = diff = None
    if linear is not None and linear.scale_factor is not None and k_map is not None:
        scale = dataclasses.replace(
            linear.scale_factor, basis=f'LS slope over {linear.plateaus} plateaus × mapping; '
                                       f'plateau Type A variances and the mapping uncertainty')
        rel = k_map.std_uncertainty / abs(k_map.value)
        lin_range = Estimate(linear.range_rad_s, linear.range_rad_s * rel, linear.plateaus,
                             linear.plateaus - 2)
        if turntable is not None:
            k_tt = turntable.scale_factor
            s = linear.slope
            var_d = (k_map.value**2 * s.std_uncertainty**2 + s.value**2
                     * k_map.std_uncertainty**2 + k_tt.std_uncertainty**2
                     - 2.0 * s.value * cov_map_turntable)
            diff = Estimate(scale.value - k_tt.value, math.sqrt(max(var_d, 0.0)),
                            linear.plateaus, linear.plateaus - 2)
        else:
            notes.append('no turntable scale factor to compare the self-calibrated K with.')
    return SelfCalFit(tuple(rows), linear, scale, lin_range, small, diff, tuple(plats),
                      tuple(notes))


def _small_signal(j: FloatArray, n_out: FloatArray, w: FloatArray, var: FloatArray,
                  k_map: Estimate | None) -> Estimate | None:
    """Zero-amplitude K: the slope at J = 0 of a quintic in J, over a range chosen from the data.

    A polynomial over a wide range extrapolates its slope at zero with a bias its residuals
    do not show (a response like arcsin bends with every odd power). The range is the
    largest one over which a cubic and a quintic agree on the slope at zero within twice
    the noise of their difference — there the terms beyond the fifth power are negligible
    against the noise — and the quintic's slope (less biased, noisier) is reported with its
    own uncertainty and the mapping's.
    """
    if k_map is None:
        return None
    best = None
    for n in range(7, len(j) + 1):
        if len(np.unique(j[:n])) < 7:
            continue
        try:
            cubic = weighted_least_squares(polynomial_design(j[:n], 3), n_out[:n], w[:n],
                                           var[:n])
            quintic = weighted_least_squares(polynomial_design(j[:n], 5), n_out[:n], w[:n],
                                             var[:n])
        except np.linalg.LinAlgError:
            continue
        row = quintic.operator[0] - cubic.operator[0]
        diff = float(quintic.beta[0] - cubic.beta[0])
        sigma = math.sqrt(max(float(np.sum(row * row * var[:n])), 0.0))
        if abs(diff) <= 2.0 * sigma:
            best = (quintic, n)
    if best is None:
        return None
    fit, n = best
    est = _scaled(float(fit.beta[0]), float(fit.cov[0, 0]), k_map)
    assert est is not None
    return Estimate(est.value, est.std_uncertainty, n, n - 6,
                    basis=f'slope at zero of a quintic over {n} plateaus (a cubic agrees within '
                          f'2σ there); mapping uncertainty included')
