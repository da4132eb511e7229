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

Rocking. Transverse rocking in phase with the dither lands on the same regressor as a
(METHODS §C). Under ``'bound'`` each component may be shifted by up to
δ = θ_rock,max/θ_d with θ_rock,max ≤ k·a (k = 1″ per 35′ by default); a moves by at most
(|ŝ_z|·δ_z + |ŝ_y|·δ_y)/â, added as a rectangular Type B uncertainty (bound/√3; the
bound is taken at a_true ≤ (â + σ)/(1 − √2·k/θ_d), since the rocking may have shrunk â). Under
``'model'`` the given in-phase rocking is subtracted; under ``'none'`` it is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.dither.floor import DetectionFloor

RAD_PER_ARCMIN = math.pi / 180.0 / 60.0


@dataclass(frozen=True, slots=True)
class Component:
    """One orientation's measured misalignment component.

    Attributes:
        axis: ``'z'`` (sees a·|sin ψ₀|) or ``'y'`` (sees a·|cos ψ₀|).
        signed_rad: ŝ, the signed component after any rocking model, rad.
        statistical_std_rad: σ of ŝ from the residuals (block scatter if larger), rad.
        rocking_bound_rad: δ, largest shift in-phase rocking may cause (0 if not bounded,
            NaN if it cannot be bounded without K), rad.
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

    @property
    def random_std_rad(self) -> float:
        """√(σ² + clock-lock²): the part that shrinks with record length, rad."""
        return math.hypot(self.statistical_std_rad, self.clock_lock_std_rad)

    @property
    def type_b_std_rad(self) -> float:
        """Rectangular Type B from the rocking bound, δ/√3, rad (0 when not bounded: NaN
        without K; inf when the rocking may be as large as the signal)."""
        b = self.rocking_bound_rad
        return 0.0 if math.isnan(b) else b / math.sqrt(3.0)

    @property
    def std_rad(self) -> float:
        """Total standard uncertainty: √(σ² + clock-lock² + (δ/√3)²), rad."""
        return math.hypot(self.random_std_rad, self.type_b_std_rad)

    @property
    def magnitude_rad(self) -> float:
        """Bias-corrected |ŝ|: √max(0, ŝ² − σ²), rad (what the hand-off reports)."""
        return math.sqrt(max(0.0, self.signed_rad ** 2 - self.statistical_std_rad ** 2))

    @property
    def significant(self) -> bool:
        """True if |ŝ| ≥ 2·σ (the component is told from zero)."""
        return abs(self.signed_rad) >= 2.0 * self.std_rad


@dataclass(frozen=True, slots=True)
class Misalignment:
    """a from both components.

    Attributes:
        value_rad: bias-corrected â, rad.
        raw_rad: √(ŝ_z² + ŝ_y²), rad.
        statistical_std_rad: its statistical standard uncertainty (module docstring), rad.
        rocking_bound_rad: largest shift of a the rocking bound allows, rad.
        azimuth_rad: ψ₀ = atan2(ŝ_z, ŝ_y) in the kinematics sign convention, rad.
        resolved: True if â_raw ≥ 2·max(σ_z, σ_y).
        clock_lock_std_rad: the components' clock-lock widening propagated to a, rad.
    """

    value_rad: float
    raw_rad: float
    statistical_std_rad: float
    rocking_bound_rad: float
    azimuth_rad: float
    resolved: bool
    clock_lock_std_rad: float = 0.0

    @property
    def random_std_rad(self) -> float:
        """√(σ² + clock-lock²), rad (shrinks with record length)."""
        return math.hypot(self.statistical_std_rad, self.clock_lock_std_rad)

    @property
    def std_rad(self) -> float:
        """√(σ² + clock-lock² + (bound/√3)²), rad."""
        b = 0.0 if math.isnan(self.rocking_bound_rad) else self.rocking_bound_rad
        return math.hypot(self.random_std_rad, b / math.sqrt(3.0))


def combine_components(z: Component, y: Component) -> Misalignment:
    """a = √(s_z² + s_y²), bias-corrected, with its uncertainty and rocking bound."""
    sz, sy = z.signed_rad, y.signed_rad
    vz, vy = z.statistical_std_rad ** 2, y.statistical_std_rad ** 2
    raw = math.hypot(sz, sy)
    value = math.sqrt(max(0.0, sz * sz + sy * sy - vz - vy))
    sigma_max = math.sqrt(max(vz, vy))
    resolved = raw >= 2.0 * sigma_max
    std = math.sqrt(sz * sz * vz + sy * sy * vy) / raw if resolved else sigma_max
    lz, ly = z.clock_lock_std_rad ** 2, y.clock_lock_std_rad ** 2
    lock = math.sqrt(sz * sz * lz + sy * sy * ly) / raw if resolved else math.sqrt(max(lz, ly))
    bz, by = z.rocking_bound_rad, y.rocking_bound_rad
    if raw > 0:
        bound = (abs(sz) * bz + abs(sy) * by) / raw
    else:
        bound = max(bz, by)
    return Misalignment(value, raw, std, bound, math.atan2(sz, sy), resolved, lock)


@dataclass(frozen=True, slots=True)
class Verdict:
    """Acceptance against the misalignment limit.

    Attributes:
        decided: True if the record decides it at the chosen coverage.
        accepted: True (a < limit), False (a > limit), None (undecided).
        sentence: a whole sentence for the bench engineer.
        more_record_s: record to add in each orientation to decide (NaN if decided or never).
        sample_rate_needed_hz: pulse rate that would have decided it with the same record.
    """

    decided: bool
    accepted: bool | None
    sentence: str
    more_record_s: float = math.nan
    sample_rate_needed_hz: float = math.nan


def _fmt_duration(seconds: float) -> str:
    if seconds < 120:
        return f'{seconds:.0f} s'
    if seconds < 7200:
        return f'{seconds / 60:.0f} min'
    return f'{seconds / 3600:.1f} h'


def acceptance_verdict(value_rad: float, std_rad: float, *, statistical_std_rad: float,
                       limit_rad: float, coverage_factor: float, record_s: float,
                       sample_rate_hz: float, what: str = 'a') -> Verdict:
    """Accept, reject, or say what record would decide ``value ± std`` against ``limit``.

    The statistical part of the uncertainty scales as 1/√(f_s·T); the Type B part (rocking
    bound) does not, so some verdicts no record can reach — the sentence says so.
    """
    am = RAD_PER_ARCMIN
    k = coverage_factor
    head = f'{what} = {value_rad / am:.2f}′ ± {std_rad / am:.2f}′'
    lim = f'{limit_rad / am:g}′'
    if value_rad + k * std_rad < limit_rad:
        return Verdict(True, True, f'{head}: below the {lim} limit (k = {k:g}): accept.')
    if value_rad - k * std_rad > limit_rad:
        return Verdict(True, False, f'{head}: above the {lim} limit (k = {k:g}): reject.')
    needed = abs(value_rad - limit_rad) / k
    type_b2 = max(std_rad ** 2 - statistical_std_rad ** 2, 0.0)
    stat_needed2 = needed ** 2 - type_b2
    if stat_needed2 <= 0 or statistical_std_rad <= 0:
        why = ('it sits on the limit' if needed < 0.05 * limit_rad else
               'the rocking bound alone is larger than the margin')
        return Verdict(False, None, (
            f'{head}: cannot decide {what} < {lim} (k = {k:g}) with any record: {why}; '
            f'measure the transverse rocking (rocking_treatment = model) or re-bond the gyro.'))
    factor = statistical_std_rad ** 2 / stat_needed2
    more = record_s * (factor - 1.0)
    rate = sample_rate_hz * factor
    return Verdict(False, None, (
        f'{head}: cannot decide {what} < {lim} (k = {k:g}; needs u({what}) ≤ '
        f'{math.sqrt(stat_needed2 + type_b2) / am:.2f}′); record {_fmt_duration(more)} more '
        f'in each orientation, or sample at {rate / 1000:.1f} kHz.'), more, rate)
