"""What the triad estimator takes and gives (METHODS §F.2–F.5).

:class:`TriadPair` (one forward/reverse pair, eqs. 5–6) and :class:`BenchParameter` (a bench
setting the directions depend on) go in; :class:`TriadResult` with a :class:`ChannelResult` per
gyro and the :class:`BudgetLine` s of its uncertainty (eq. 12) come out.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.estimate import Estimate, Rejection

    Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class TriadPair:
    """One forward/reverse pair about one direction, all channels (METHODS §F eqs. 5–6).

    Attributes:
        direction: u, unit rotation direction of the forward window in the body frame (3,).
        swept_angle_rad: φ, the angle swept each way (2π·m for m whole turns), rad.
        count_difference: ΔN = N⁺ − N⁻ per channel (3,), pulses (eq. 5 for unequal T±).
        count_difference_std: its standard uncertainty per channel (3,), pulses.
        swept_angle_std_rad: standard uncertainty of φ, common to the channels, rad.
        direction_sensitivity: ∂u/∂p (3, q) for the bench parameters given to
            :func:`triad_calibration`, or None (u exact).
        sum_rate: (N⁺ + N⁻)/(T⁺ + T⁻) per channel (3,), pulses/s, for the bias; or None.
        sum_rate_std: its standard uncertainty (3,), pulses/s; or None.
        excess_rate_rad_s: (A⁺ − A⁻)/(T⁺ + T⁻), rad/s (0 for equal angles).
        earth_rate_along_u_rad_s: Ω_u = ω_E·u (eq. 13), rad/s; NaN if unknown.
        stamp_ns: start stamp, int ns.
        rejected: per channel, why this pair is not used for it ('' = used).
        walk_weight_s: ∂Var(ΔN)/∂a = 4·(w⁺²·T⁺ + w⁻²·T⁻), s: what a count random walk of
            density a (pulses²/s, the ARW over K²) adds to ``count_difference_std``² (eq. 6b).
        duration_s: T⁺ + T⁻, s (a adds a/(T⁺ + T⁻) to ``sum_rate_std``²).
        model_difference_std, model_sum_rate_std: ``count_difference_std`` and
            ``sum_rate_std`` from the count error model (rounding at the end fits, eq. (6a))
            where those (the weights of the solve) differ; None: the same. The covariance and
            the measured walk rest on the model; the weights, and so the estimates, do not.
        end_terms: the window ends' counts ΔN rests on: ((mount, stamp ns), ∂ΔN/∂count,
            u²_end per channel (3,) pulses²) each, eq. (6a); two pairs whose windows share an
            end (windows back to back) share its error, a covariance between the pairs.
            Empty: unknown.
    """

    direction: Array
    swept_angle_rad: float
    count_difference: Array
    count_difference_std: Array
    swept_angle_std_rad: float = 0.0
    direction_sensitivity: Array | None = None
    sum_rate: Array | None = None
    sum_rate_std: Array | None = None
    excess_rate_rad_s: float = 0.0
    earth_rate_along_u_rad_s: float = math.nan
    stamp_ns: int = 0
    rejected: tuple[str, str, str] = ('', '', '')
    walk_weight_s: float = 0.0
    duration_s: float = 0.0
    model_difference_std: Array | None = None
    model_sum_rate_std: Array | None = None
    end_terms: tuple[tuple[tuple[str, int], float, Array], ...] = ()

    def as_modelled(self) -> TriadPair:
        """This pair with its count uncertainties from the error model (eq. (6a))."""
        if self.model_difference_std is None:
            return self
        return dataclasses.replace(
            self, count_difference_std=self.model_difference_std,
            sum_rate_std=(self.sum_rate_std if self.model_sum_rate_std is None
                          else self.model_sum_rate_std),
            model_difference_std=None, model_sum_rate_std=None)


@dataclass(frozen=True, slots=True)
class BenchParameter:
    """A bench setting the directions u depend on (column of ``direction_sensitivity``).

    Attributes:
        name: e.g. 'tilt α'.
        std_rad: standard uncertainty of the stated setting, rad (a systematic).
        fitted: estimate a correction from the data (the stated value ± std as prior);
            otherwise its uncertainty is only propagated.
    """

    name: str
    std_rad: float
    fitted: bool = False


@dataclass(frozen=True, slots=True)
class BudgetLine:
    """Standard uncertainty contributed by one source (METHODS §F eq. 12).

    Attributes:
        source: 'counts', 'swept angle' or a bench parameter's name.
        scale_factor_relative: u(K_i)/K_i per channel (3,), NaN where not measurable.
        direction_rad: rms angle error of s_i per channel, √trace C(s_i), rad (3,).
        matrix: u(M_jk) (3, 3), rad/pulse (NaN without M).
    """

    source: str
    scale_factor_relative: Array
    direction_rad: Array
    matrix: Array


@dataclass(frozen=True, slots=True)
class ChannelResult:
    """One gyro of the triad.

    Attributes:
        name: the channel name.
        row_pulse_per_rad: r_i = s_i/K_i, three components, pulses/rad (eq. 8).
        scale_factor_rad_per_pulse: K_i = 1/|r_i| (eq. 10), rad/pulse.
        sense_axis: s_i, three components of the unit sense axis (body frame) (eq. 10).
        sense_axis_covariance: 3×3 covariance of s_i (rank 2: across s_i only).
        bias_rad_s: the gyro's bias along s_i, K_i·β_i (eq. 14), rad/s; None if not measured.
        not_measurable: why r_i is not solved ('' when it is).
        bias_missing: why the bias is not measured ('' when it is).
        rejected: pairs not used for this channel, with their reasons.
    """

    name: str
    row_pulse_per_rad: tuple[Estimate, Estimate, Estimate] | None
    scale_factor_rad_per_pulse: Estimate | None
    sense_axis: tuple[Estimate, Estimate, Estimate] | None
    sense_axis_covariance: Array | None
    bias_rad_s: Estimate | None
    not_measurable: str = ''
    bias_missing: str = ''
    rejected: tuple[Rejection, ...] = ()


@dataclass(frozen=True, slots=True)
class TriadResult:
    """Everything the triad method measures (METHODS §F).

    Attributes:
        channels: one :class:`ChannelResult` per channel, in the input order.
        pulses_to_body_rad: M = R⁻¹, 3×3 Estimates, rad/pulse (eq. 11); None if not measurable.
        pulses_to_body_covariance: 9×9 covariance of M (row-major), (rad/pulse)²; or None.
        bias_body_rad_s: b = M·β (ω_B = M·ṅ − b), three Estimates, rad/s; or None.
        parameters: fitted bench parameters: name → correction to the stated value, rad.
        budget: standard uncertainty per source (eq. 12).
        birge_ratio: √(χ²/ν) of the joint fit (NaN with no degree of freedom).
        basis: what the covariance rests on.
        not_measurable: why M is not reported ('' when it is).
        bias_missing: why b is not reported ('' when it is).
    """

    channels: tuple[ChannelResult, ...]
    pulses_to_body_rad: tuple[tuple[Estimate, ...], ...] | None
    pulses_to_body_covariance: Array | None
    bias_body_rad_s: tuple[Estimate, Estimate, Estimate] | None
    parameters: dict[str, Estimate] = field(default_factory=dict)
    budget: tuple[BudgetLine, ...] = ()
    birge_ratio: float = math.nan
    basis: str = ''
    not_measurable: str = ''
    bias_missing: str = ''
