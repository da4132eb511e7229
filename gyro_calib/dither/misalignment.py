"""From the two orientations' components to a, its uncertainty and the acceptance verdict.

Each orientation measures one signed component (METHODS §C): along Z s_z ≈ a·sin ψ₀,
along Y s_y ≈ a·cos ψ₀ (kinematics sign convention), each with standard uncertainty σ.
Then a = √(s_z² + s_y²).

Bias near zero. √ of noisy squares is biased up: E[ŝ_z² + ŝ_y²] = a² + σ_z² + σ_y². The
reported a (and each reported |component|) is the bias-corrected
√max(0, ŝ_z² + ŝ_y² − σ_z² − σ_y²), which is unbiased in a² and reads 0 when the record
cannot tell a from zero. Its standard uncertainty is the propagated
√(ŝ_z²σ_z² + ŝ_y²σ_y²)/â when â ≥ 2·max σ; below that the direction of (ŝ_z, ŝ_y) is noise
and the reported uncertainty is max(σ_z, σ_y), which the spread of √(ŝ_z² + ŝ_y²) never
exceeds (the Rice distribution's standard deviation lies between 0.66σ and σ).

Rocking allowance (derived in docs/guide/dither.md; checked by
benchmarks/dither_rocking_allowance.py against the exact kinematics). Transverse rocking in
phase with the dither lands on the same regressor as a (METHODS §C): a rocking of amplitude
θ_r about case Y (θ_xz) adds −θ_r·ω_T·sin(Ω_d t) to the rate the table along Z shows, exactly
what a component s_z = θ_r/θ_d would add (its sideband is ω_T·s_z·φ, φ = θ_d·sin Ω_d t). So a
component is shifted by δ = θ_r/θ_d; rocking in quadrature with the dither lands on the
quadrature regressor and shifts nothing. With θ_r ≤ k·a (the paper: 1″ at 35′) and
κ = k/θ_d, each component is shifted by at most κ·a, and the pair (δ_z, δ_y) by at most
ρ·a with ρ = √2·κ (``'proportional'``: both rockings k·a) or ρ = κ (``'components'``:
k·a·|cos ψ₀|, k·a·|sin ψ₀|). Hence the measured â lies in a·(1 ± ρ): the allowance is a
**multiplicative interval on a**, a ∈ [â/(1 + ρ), â/(1 − ρ)] (no upper end when ρ ≥ 1),
widened by the statistical k·σ at each end. Its half-width at the measured value, reported as
the ``systematic_bound``, is the upper side ρ·â/(1 − ρ) (the larger one); a component's is
κ·â/(1 − ρ). The standard uncertainty ``std`` still combines the parts as GUM does (bound/√3,
rectangular) for users who want one number; the verdict uses the interval, not ``std``.
One orientation alone cannot size its own allowance (a is not known from one component), and
without K neither can anything (κ needs θ_d in rad): the allowance is then unbounded, and said
so. Under ``'model'`` the given in-phase rocking is subtracted; under ``'none'`` it is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.dither.floor import DetectionFloor
from gyro_calib.dither.wording import RAD_PER_ARCMIN as RAD_PER_ARCMIN
from gyro_calib.dither.wording import duration


@dataclass(frozen=True, slots=True)
class RockingAllowance:
    """How far in-phase transverse rocking may have moved what the output carries.

    Attributes:
        treatment: ``'bound'``, ``'model'`` or ``'none'`` (the settings' rocking_treatment).
        model: ``'proportional'`` or ``'components'`` (the settings' rocking_model).
        kappa: κ = k/θ_d, the largest shift of one component per unit a (0 when the rocking is
            not bounded: ``'model'``, ``'none'`` or k = 0; NaN when it cannot be sized: no K).
        rocking_arcsec_per_arcmin: k as the user gave it, ″ per ′.
    """

    treatment: str
    model: str
    kappa: float
    rocking_arcsec_per_arcmin: float = 0.0

    @property
    def sized(self) -> bool:
        """False when the allowance is needed but cannot be sized (no K)."""
        return not math.isnan(self.kappa)

    @property
    def rho(self) -> float:
        """ρ: |â − a| ≤ ρ·a (√2·κ proportional, κ components; NaN unsized)."""
        return self.kappa * (math.sqrt(2.0) if self.model == 'proportional' else 1.0)

    def description(self) -> str:
        """The model the allowance rests on, one phrase (named in ``--json``)."""
        if self.treatment == 'none':
            return 'none (rocking_treatment = none: in-phase rocking ignored)'
        if self.treatment == 'model':
            return 'none (rocking_treatment = model: the given in-phase rocking subtracted)'
        if self.kappa == 0.0:
            return 'none (rocking_arcsec_per_arcmin = 0)'
        k = f'{self.rocking_arcsec_per_arcmin:.3g}″ per ′'
        form = '√2·κ' if self.model == 'proportional' else 'κ'
        if not self.sized:
            return (f'in-phase rocking θ_r ≤ k·a (k = {k}, {self.model}): not sized — '
                    'κ = k/θ_d needs θ_d in rad, i.e. the scale factor K')
        return (f'in-phase rocking θ_r ≤ k·a (k = {k}, {self.model}): each component shifted '
                f'by ≤ κ·a, a by ≤ {form}·a, κ = k/θ_d = {self.kappa:.3g}; '
                f'a ∈ [â/(1 + {self.rho:.3g}), â/(1 − {self.rho:.3g})]')


@dataclass(frozen=True, slots=True)
class Component:
    """One orientation's measured misalignment component.

    Attributes:
        axis: ``'z'`` (sees a·|sin ψ₀|) or ``'y'`` (sees a·|cos ψ₀|).
        signed_rad: ŝ, the signed component after any rocking model, rad.
        statistical_std_rad: σ of ŝ from the residuals (block scatter if larger), rad.
        rocking_bound_rad: half-width of the rocking allowance κ·â/(1 − ρ) (module
            docstring), rad: 0 when the rocking is not bounded, inf when it cannot be sized
            (one orientation only, no K, or ρ ≥ 1; ``rocking_note`` says which).
        quadrature_rad: rocking out of phase with the dither seen by this orientation, rad.
        quadrature_std_rad: its standard uncertainty, rad.
        floor: the predicted detection floor of this record.
        n_blocks: blocks used.
        dof: residual degrees of freedom.
        record_s: length of record used, s.
        sample_rate_hz: pulse sample rate, Hz.
        birge_ratio_squared: block scatter against the white-noise prediction.
        null_ratio_squared: null-sideband χ²/dof (≈ 1 when the noise at the sidebands is
            white; the statistical σ is already widened by it when above 1).
        count_drift_pulses_s: mean straight-line drift of the count, pulses/s.
        clock_lock_std_rad: Type B widening for clock-locked quantisation, rad (0 unless the
            vibration frequency divides the sample rate): √(max(0, (λ·σ_white)² − σ²)), so
            that the random part √(σ² + this²) is at least λ times the white-noise σ.
        clock_lock_note: the sentence that says why it was added ('' when 0).
        rocking_note: why the rocking allowance is unbounded ('' when it is not).
        table_rate_amplitude_rad_s: mean fitted table rate amplitude A, rad/s.
    """

    axis: str
    signed_rad: float
    statistical_std_rad: float
    rocking_bound_rad: float
    quadrature_rad: float
    quadrature_std_rad: float
    floor: DetectionFloor
    n_blocks: int
    dof: int
    record_s: float
    sample_rate_hz: float
    birge_ratio_squared: float
    null_ratio_squared: float = math.nan
    count_drift_pulses_s: float = math.nan
    clock_lock_std_rad: float = 0.0
    clock_lock_note: str = ''
    rocking_note: str = ''
    table_rate_amplitude_rad_s: float = math.nan

    @property
    def random_std_rad(self) -> float:
        """√(σ² + clock-lock²): the part that shrinks with record length, rad."""
        return math.hypot(self.statistical_std_rad, self.clock_lock_std_rad)

    @property
    def type_b_std_rad(self) -> float:
        """Rectangular Type B from the rocking allowance, bound/√3, rad (inf if unbounded)."""
        return self.rocking_bound_rad / math.sqrt(3.0)

    @property
    def std_rad(self) -> float:
        """Combined standard uncertainty √(σ² + clock-lock² + (bound/√3)²), rad."""
        return math.hypot(self.random_std_rad, self.type_b_std_rad)

    @property
    def magnitude_rad(self) -> float:
        """Bias-corrected |ŝ|: √max(0, ŝ² − σ²), rad (what the hand-off reports)."""
        return math.sqrt(max(0.0, self.signed_rad ** 2 - self.statistical_std_rad ** 2))

    @property
    def significant(self) -> bool:
        """True if |ŝ| ≥ 2·σ_random (the record tells the component from zero)."""
        return abs(self.signed_rad) >= 2.0 * self.random_std_rad


@dataclass(frozen=True, slots=True)
class Misalignment:
    """a from both components.

    Attributes:
        value_rad: bias-corrected â, rad.
        raw_rad: √(ŝ_z² + ŝ_y²), rad.
        statistical_std_rad: its statistical standard uncertainty (module docstring), rad.
        rocking_bound_rad: half-width of the rocking allowance on a, ρ·â/(1 − ρ), rad (0 not
            bounded, inf unbounded).
        azimuth_rad: ψ₀ = atan2(ŝ_z, ŝ_y) in the kinematics sign convention, rad.
        resolved: True if â_raw ≥ 2·max(σ_z, σ_y).
        clock_lock_std_rad: the components' clock-lock widening propagated to a, rad.
        rho: ρ of the rocking allowance, |â − a| ≤ ρ·a (0 not bounded, NaN unsized).
    """

    value_rad: float
    raw_rad: float
    statistical_std_rad: float
    rocking_bound_rad: float
    azimuth_rad: float
    resolved: bool
    clock_lock_std_rad: float = 0.0
    rho: float = 0.0

    @property
    def random_std_rad(self) -> float:
        """√(σ² + clock-lock²), rad (shrinks with record length)."""
        return math.hypot(self.statistical_std_rad, self.clock_lock_std_rad)

    @property
    def std_rad(self) -> float:
        """Combined √(σ² + clock-lock² + (bound/√3)²), rad (inf if the bound is)."""
        return math.hypot(self.random_std_rad, self.rocking_bound_rad / math.sqrt(3.0))


def allowance_half_width(value_rad: float, ratio: float, rho: float) -> float:
    """Upper half-width of the rocking allowance at â, rad.

    ratio·â/(1 − ρ): the rocking allowance's upper half-width at â, rad (inf if ρ ≥ 1 or
    unsized; 0 when ratio is 0).
    """
    if ratio == 0.0:
        return 0.0
    if not (math.isfinite(rho) and rho < 1.0):
        return math.inf
    return ratio * value_rad / (1.0 - rho)


def combine_components(z: Component, y: Component,
                       rocking: RockingAllowance | None = None) -> Misalignment:
    """The a = √(s_z² + s_y²), bias-corrected, with its uncertainty and rocking allowance."""
    sz, sy = z.signed_rad, y.signed_rad
    vz, vy = z.statistical_std_rad ** 2, y.statistical_std_rad ** 2
    raw = math.hypot(sz, sy)
    value = math.sqrt(max(0.0, sz * sz + sy * sy - vz - vy))
    sigma_max = math.sqrt(max(vz, vy))
    resolved = raw >= 2.0 * sigma_max
    std = math.sqrt(sz * sz * vz + sy * sy * vy) / raw if resolved else sigma_max
    lz, ly = z.clock_lock_std_rad ** 2, y.clock_lock_std_rad ** 2
    lock = math.sqrt(sz * sz * lz + sy * sy * ly) / raw if resolved else math.sqrt(max(lz, ly))
    rho = 0.0 if rocking is None else rocking.rho
    bound = allowance_half_width(value, rho, rho) if rho != 0.0 else 0.0
    return Misalignment(value, raw, std, bound, math.atan2(sz, sy), resolved, lock, rho)


@dataclass(frozen=True, slots=True)
class Interval:
    """Where a lies at coverage factor k, the rocking allowance included (module docstring).

    Attributes:
        lower_rad: lower end, rad (≥ 0).
        upper_rad: upper end, rad (inf when nothing bounds a from above).
        coverage_factor: k.
        lower_from: what gives the lower end (``'a'``, ``'component Z'``, ``'component Y'``,
            or ``'nothing'``).
    """

    lower_rad: float
    upper_rad: float
    coverage_factor: float
    lower_from: str = 'nothing'


def misalignment_interval(misalignment: Misalignment | None, components: dict[str, Component],
                          rocking: RockingAllowance, coverage_factor: float) -> Interval:
    """The k-interval of the misalignment a.

    a's k-interval: [(â − kσ)/(1 + ρ), (â + kσ)/(1 − ρ)], and a ≥ (|ŝ| − kσ)/(1 + κ) per
    component (a ≥ |component|, each component shifted by ≤ κ·a). Unsized rocking (no K) bounds
    nothing: a ≥ 0 only and no upper end.
    """
    k = coverage_factor
    rho, kappa = rocking.rho, rocking.kappa
    lower, source, upper = 0.0, 'nothing', math.inf
    if rocking.sized:
        for axis, c in components.items():
            low = (c.magnitude_rad - k * c.random_std_rad) / (1.0 + kappa)
            if low > lower:
                lower, source = low, f'component {axis.upper()}'
        m = misalignment
        if m is not None:
            low = (m.value_rad - k * m.random_std_rad) / (1.0 + rho)
            if low > lower:
                lower, source = low, 'a'
            if rho < 1.0:
                upper = (m.value_rad + k * m.random_std_rad) / (1.0 - rho)
    return Interval(max(lower, 0.0), upper, k, source)


@dataclass(frozen=True, slots=True)
class Verdict:
    """Acceptance against the misalignment limit.

    Attributes:
        decided: True if the record decides it at the chosen coverage.
        accepted: True (a < limit), False (a > limit), None (undecided).
        sentence: a whole sentence for the bench engineer.
        more_record_s: record to add in each orientation to decide (NaN if decided or never).
        sample_rate_needed_hz: pulse rate that would have decided it with the same record.
        table_rate_amplitude_needed_rad_s: table amplitude that would have decided it with
            the same record, rad/s (NaN if decided or never).
    """

    decided: bool
    accepted: bool | None
    sentence: str
    more_record_s: float = math.nan
    sample_rate_needed_hz: float = math.nan
    table_rate_amplitude_needed_rad_s: float = math.nan

    @property
    def state(self) -> str:
        """``'accept'``, ``'reject'`` or ``'undecidable'`` (the hand-off's word)."""
        return {True: 'accept', False: 'reject', None: 'undecidable'}[self.accepted]


def interval_verdict(interval: Interval, misalignment: Misalignment | None,
                     rocking: RockingAllowance, *, limit_rad: float, record_s: float,
                     sample_rate_hz: float, table_rate_amplitude_rad_s: float,
                     missing_axes: tuple[str, ...] = ()) -> Verdict:
    """The verdict from the interval against the limit.

    Reject when the interval's lower end is above the limit, accept when its upper end is
    below; otherwise undecidable, with the record, sample rate or table amplitude that would
    decide it if â stayed where it is (σ ∝ 1/√(f_s·T), ∝ 1/A), or why none would.
    """
    am = RAD_PER_ARCMIN
    k = interval.coverage_factor
    lim = f'{limit_rad / am:g}′'
    up = '∞' if math.isinf(interval.upper_rad) else f'{interval.upper_rad / am:.2f}′'
    head = (f'a between {interval.lower_rad / am:.2f}′ and {up} (k = {k:g}, rocking allowance '
            'included')
    if interval.lower_rad > limit_rad:
        via = '' if interval.lower_from in ('a', 'nothing') else (
            f'; from {interval.lower_from} alone, a ≥ |component|')
        return Verdict(True, False, f'{head}{via}): above the {lim} limit: reject.')
    if interval.upper_rad < limit_rad:
        return Verdict(True, True, f'{head}): below the {lim} limit: accept.')
    head += f'): cannot decide a < {lim}'
    if missing_axes:
        return Verdict(False, None, (
            f'{head}: one orientation bounds a only from below (a ≥ |component|); record the '
            f'table along {" and ".join(a.upper() for a in missing_axes)} to bound it from '
            'above.'))
    if not rocking.sized:
        return Verdict(False, None, (
            f'{head}: the rocking allowance k·a/θ_d needs θ_d in rad: give the scale factor K '
            '(--scale-factor-rad-per-pulse or --calibration FILE), or set rocking_treatment: '
            'none if this bench has no transverse rocking.'))
    m = misalignment
    assert m is not None
    rho, value, sigma = m.rho, m.value_rad, m.random_std_rad
    targets = []
    if rho < 1.0 and (1.0 - rho) * limit_rad > value:
        targets.append(((1.0 - rho) * limit_rad - value) / k)  # upper end below the limit
    if value > (1.0 + rho) * limit_rad:
        targets.append((value - (1.0 + rho) * limit_rad) / k)  # lower end above it
    if not targets or sigma <= 0:
        return Verdict(False, None, (
            f'{head} with any record: the rocking allowance alone (a ∈ [â/(1 + {rho:.3g}), '
            f'â/(1 − {rho:.3g})] at â = {value / am:.2f}′) spans the limit; measure the '
            'in-phase rocking (rocking_treatment = model), or a larger dither amplitude θ_d '
            'makes κ = k/θ_d smaller.'))
    target = max(targets)
    factor = (sigma / target) ** 2
    more = record_s * (factor - 1.0)
    rate = sample_rate_hz * factor
    amp = table_rate_amplitude_rad_s * sigma / target
    amp_text = (f', or a table rate amplitude of {amp:.3g} rad/s' if math.isfinite(amp)
                else '')
    return Verdict(False, None, (
        f'{head} (needs σ(a) ≤ {target / am:.2f}′, now {sigma / am:.2f}′): record '
        f'{duration(more)} more in each orientation, or sample at {rate / 1000:.1f} kHz'
        f'{amp_text} (if â stays at {value / am:.2f}′).'), more, rate, amp)
