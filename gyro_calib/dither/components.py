"""From the orientations' reduced sums to each one's component and what it rests on.

The threshold model of METHODS §C: each orientation's signed component (bias-corrected, the
modelled rocking subtracted), its statistical σ widened where the vibration frequency
divides the sample rate (clock lock), the detection floor σ_c beside it, the rocking
allowance κ·a it is shifted by at most, and, for a weak component, what record or table
amplitude would resolve it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.dither.block import AXES
from gyro_calib.dither.floor import (
    detection_floor,
    required_record_s,
    required_table_rate_amplitude_rad_s,
)
from gyro_calib.dither.misalignment import (
    RAD_PER_ARCMIN,
    Component,
    RockingAllowance,
    allowance_half_width,
)
from gyro_calib.dither.wording import arcmin
from gyro_calib.units import RAD_PER_ARCSEC

if TYPE_CHECKING:
    from gyro_calib.dither.block import OrientationRecord
    from gyro_calib.dither.regression import SidebandSolution
    from gyro_calib.dither.settings import DitherSettings

CLOCK_LOCK_FACTOR = 2.0
"""λ: with the vibration frequency dividing the pulse sample rate (table and sample clocks
locked, e.g. 20 Hz at 2 kHz), a component's random uncertainty is at least λ times its
white-noise σ. The pulse quantisation then repeats with the table phase at every sample and
only the dither and the count drift can decorrelate it; where they do not (the drift of a
gyro with IA north, 11.5 pulses/s), part of the quantisation error stays coherent with the
sidebands for longer than the data checks (block scatter, null sidebands) can see on one
record. Monte Carlo (benchmarks/dither_floor_monte_carlo.py, A = 20 rad/s, 60 s, IA north,
20 Hz): scatter 1.8× the white σ, ±1σ coverage 50 % without this widening."""


ALLOWANCE_SECOND_ORDER = 0.01
"""Relative margin on κ = k/θ_d for what the first-order allowance leaves out (the shift
θ_r/θ_d is exact to first order in the small angles; the exact kinematics moved a component
by up to 1.0002·κ·a and a by up to 1.0004·ρ·a at a = 60′,
benchmarks/dither_rocking_allowance.py)."""


def clock_lock(table_hz: float, sample_rate_hz: float, record_s: float) -> int:
    """The n if the vibration frequency divides the sample rate (|f_z − f_s/n| < 1/T), else 0.

    Then the table phase at the samples repeats every n samples and slips by less than one
    table cycle over the record T: the table never dithers the quantisation.
    """
    if not (table_hz > 0 and sample_rate_hz > 0 and record_s > 0):
        return 0
    n = max(round(sample_rate_hz / table_hz), 1)
    return n if abs(table_hz - sample_rate_hz / n) < 1.0 / record_s else 0


class ComponentEstimation:
    """Each orientation's component from its reduced sums (a base of the calibrator)."""

    __slots__ = ()
    settings: DitherSettings
    orientations: dict[str, OrientationRecord]

    def _raw_solution(self, axis: str) -> SidebandSolution | None:
        rec = self.orientations[axis]
        if rec.equations.n_blocks < 1:
            return None
        return rec.equations.solve()

    def _dither_amplitude_pulses(self) -> float:
        amps = [b.dither_amplitude_pulses for r in self.orientations.values() for b in r.blocks]
        return float(np.mean(amps)) if amps else math.nan

    def rocking_allowance(self, theta_d_rad: float) -> RockingAllowance:
        """The rocking allowance of these settings at dither amplitude θ_d (rad; NaN = no K)."""
        s = self.settings
        k = s.rocking_per_misalignment if s.rocking_treatment == 'bound' else 0.0
        kappa = 0.0 if k == 0.0 else k / theta_d_rad * (1.0 + ALLOWANCE_SECOND_ORDER)
        return RockingAllowance(s.rocking_treatment, s.rocking_model, kappa,
                                s.rocking_arcsec_per_arcmin)

    def components(self) -> tuple[dict[str, Component], dict[str, str]]:
        """Each measured orientation's component, and why the others have none.

        Every measured component is reported (issue 16): one the record cannot tell from
        zero gets its interval and a note saying what would resolve it (:meth:`summary`).
        """
        s = self.settings
        sols = {axis: self._raw_solution(axis) for axis in AXES}
        raw = {axis: float(sol.beta[0]) for axis, sol in sols.items() if sol is not None}
        a_raw = math.hypot(*raw.values()) if raw else 0.0
        cos_a = math.cos(a_raw)  # the output's dither line is θ_d·cos a/K
        amp_pulses = self._dither_amplitude_pulses()
        theta_d = (s.scale_factor_rad_per_pulse * amp_pulses / cos_a if s.has_scale_factor
                   else math.nan)
        rocking = self.rocking_allowance(theta_d)
        arw_pulses = (math.radians(s.angle_random_walk_deg_sqrt_h) / 60.0
                      / s.scale_factor_rad_per_pulse if s.has_scale_factor else 0.0)
        comps: dict[str, Component] = {}
        missing: dict[str, str] = {}
        signed: dict[str, float] = {}
        for axis in AXES:
            sol, rec = sols[axis], self.orientations[axis]
            if sol is None or not math.isfinite(sol.residual_variance_pulses2):
                missing[axis] = (f'no accepted block with the table along {axis.upper()} '
                                 '(joint_states frame_id "' + axis + '").')
                continue
            sign = 1.0 if axis == 'z' else -1.0
            value = sign * sol.beta[0] * cos_a
            if s.rocking_treatment == 'model':
                in_phase = (s.rocking_in_phase_xz_arcsec if axis == 'z'
                            else s.rocking_in_phase_xy_arcsec) * RAD_PER_ARCSEC
                value += in_phase / theta_d
            signed[axis] = float(value)
        random_std: dict[str, float] = {}
        built: dict[str, dict[str, Any]] = {}
        for axis in signed:
            sol, rec = sols[axis], self.orientations[axis]
            assert sol is not None  # signed holds only the axes with a solution
            sigma = math.sqrt(sol.covariance[0, 0]) * cos_a
            fs = rec.mean('sample_rate_hz')
            floor = detection_floor(
                table_rate_amplitude_rad_s=rec.mean('table_rate_amplitude_rad_s'),
                dither_amplitude_rad=rec.mean('dither_amplitude_pulses'),
                record_s=rec.record_s, sample_rate_hz=fs, scale_factor_rad_per_pulse=1.0,
                angle_random_walk_rad_sqrt_s=arw_pulses,
                dither_frequency_hz=rec.mean('dither_frequency_hz'),
                table_frequency_hz=rec.mean('table_frequency_hz'),
                misalignment_rad=abs(signed[axis]))
            fz = rec.mean('table_frequency_hz')
            lock_std, lock_note = 0.0, ''
            n_lock = clock_lock(fz, fs, rec.record_s)
            if n_lock:
                white = sigma / math.sqrt(max(sol.inflation, 1.0))
                lock_std = math.sqrt(max((CLOCK_LOCK_FACTOR * white) ** 2 - sigma ** 2, 0.0))
                lock_note = (
                    f'table along {axis.upper()}: the vibration frequency {fz:.3f} Hz divides the '
                    f'{fs:.0f} Hz sample rate ({n_lock}×): the pulse quantisation is locked to '
                    'the table phase and does not average as white noise (Monte Carlo: up to '
                    '1.8× the floor at 60 s, ±1σ coverage 50 %), which the data checks of one '
                    f'record cannot fully see; the uncertainty is therefore widened to '
                    f'{CLOCK_LOCK_FACTOR:g}× the white-noise σ ({arcmin(white)} → '
                    f'{arcmin(math.hypot(sigma, lock_std))}). For the floor, vibrate half way '
                    f'between two divisors of the sample rate, e.g. {fs / (n_lock + 0.5):.2f} Hz '
                    f'or {fs / (n_lock - 0.5):.2f} Hz.')
            random_std[axis] = math.hypot(sigma, lock_std)
            built[axis] = dict(
                axis=axis, signed_rad=signed[axis], statistical_std_rad=sigma,
                quadrature_rad=(-1.0 if axis == 'z' else 1.0) * float(sol.beta[1]) * cos_a,
                quadrature_std_rad=math.sqrt(sol.covariance[1, 1]) * cos_a, floor=floor,
                n_blocks=sol.n_blocks, dof=sol.dof, record_s=rec.record_s, sample_rate_hz=fs,
                birge_ratio_squared=sol.birge_ratio_squared,
                null_ratio_squared=sol.null_ratio_squared,
                count_drift_pulses_s=rec.mean('drift_pulses_s'),
                clock_lock_std_rad=lock_std, clock_lock_note=lock_note,
                table_rate_amplitude_rad_s=rec.mean('table_rate_amplitude_rad_s'))
        bound, note = self._component_allowance(signed, built, rocking)
        for axis, kw in built.items():
            comps[axis] = Component(rocking_bound_rad=bound, rocking_note=note, **kw)
        return comps, missing

    @staticmethod
    def _component_allowance(signed: dict[str, float], built: dict[str, dict[str, Any]],
                             rocking: RockingAllowance) -> tuple[float, str]:
        """(κ·â/(1 − ρ), why unbounded) for the components (module misalignment docstring).

        The shift of one component is at most κ·a, and a is bounded only with both
        orientations measured and ρ < 1; without K, κ is not known at all.
        """
        if rocking.kappa == 0.0:
            return 0.0, ''
        if not rocking.sized:
            return math.inf, ('the rocking allowance k·a/θ_d needs θ_d in rad, i.e. the scale '
                              'factor K (give --scale-factor-rad-per-pulse or --calibration '
                              'FILE, or rocking_treatment: none if the bench has no '
                              'transverse rocking)')
        if len(signed) < 2:
            return math.inf, ('the rocking allowance κ·a needs a, and one orientation bounds '
                              'a only from below: record the other orientation')
        if rocking.rho >= 1.0:
            return math.inf, (f'ρ = {rocking.rho:.2f} ≥ 1: the rocking k·a may be as large as '
                              'the misalignment signal (κ = k/θ_d); measure the rocking '
                              '(rocking_treatment = model) or use a larger dither amplitude')
        vz, vy = (built[a]['statistical_std_rad'] ** 2 for a in AXES)
        value = math.sqrt(max(0.0, signed['z'] ** 2 + signed['y'] ** 2 - vz - vy))
        return allowance_half_width(value, rocking.kappa, rocking.rho), ''

    def _resolution_note(self, c: Component) -> str | None:
        """What a weak component rests on.

        What a component rests on when it is weak: few blocks, or not told from zero
        (then the table amplitude or record that would resolve half the limit).
        """
        s = self.settings
        rec = self.orientations[c.axis]
        notes = []
        if c.n_blocks < s.min_blocks:
            notes.append(f'rests on only {c.n_blocks} block(s) ({c.record_s:.0f} s; min_blocks '
                          f'= {s.min_blocks}): its block-scatter check is weak')
        k = s.verdict_coverage_factor
        if not c.significant:
            target = s.max_misalignment_arcmin * RAD_PER_ARCMIN / (2 * k)
            amp = rec.mean('table_rate_amplitude_rad_s')
            common = dict(dither_amplitude_rad=rec.mean('dither_amplitude_pulses'),
                          sample_rate_hz=c.sample_rate_hz, scale_factor_rad_per_pulse=1.0,
                          dither_frequency_hz=rec.mean('dither_frequency_hz'),
                          table_frequency_hz=rec.mean('table_frequency_hz'))
            a_needed = required_table_rate_amplitude_rad_s(target, record_s=c.record_s,
                                                           **common)
            t_needed = required_record_s(target, table_rate_amplitude_rad_s=amp, **common)
            notes.append(
                f'cannot be told from zero ({arcmin(c.signed_rad)} ± '
                f'{arcmin(c.random_std_rad)} statistical; the floor of this {c.record_s:.0f} s '
                f'record at table rate amplitude {amp:.3g} rad/s is '
                f'{arcmin(c.floor.component_std_rad)}); to resolve half the '
                f'{s.max_misalignment_arcmin:g}′ limit at k = {k:g} (σ ≤ {arcmin(target)}) '
                f'use A ≥ {a_needed:.3g} rad/s for the same record, or record '
                f'{t_needed / 60:.0f} min at this amplitude')
        if not notes:
            return None
        return f'table along {c.axis.upper()}: the component ' + '; it '.join(notes) + '.'
