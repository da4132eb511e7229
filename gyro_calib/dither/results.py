"""Result assembly: the summary, the hand-off estimates, their parts and what is missing.

From the components (:mod:`gyro_calib.dither.components`) to everything the method reports:
a = √(z² + y²) bias-corrected with its k-interval and the acceptance verdict (METHODS §C),
the coning drift of eq. (24) and the dither × rocking total with their uncertainty by the
unscented transform, θ_d (with K) or the dither amplitude in pulses, the ``--json`` parts of
each uncertainty, and per hand-off key not measured a sentence saying why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.dither.block import AXES
from gyro_calib.dither.components import ComponentEstimation
from gyro_calib.dither.coning import ConingDrift, coning_drift
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
)
from gyro_calib.dither.misalignment import (
    Component,
    Interval,
    Misalignment,
    RockingAllowance,
    Verdict,
    combine_components,
    interval_verdict,
    misalignment_interval,
)
from gyro_calib.dither.wording import RAD_PER_ARCMIN, arcmin, plus_minus
from gyro_calib.estimate import Estimate
from gyro_calib.units import RAD_PER_ARCSEC

if TYPE_CHECKING:
    from gyro_calib.estimate import Rejection

RESULT_KEYS = (KEY_A, KEY_Z, KEY_Y, KEY_FREQUENCY, KEY_AMPLITUDE, KEY_AMPLITUDE_PULSES,
               KEY_CONING, KEY_CONING_TOTAL)
"""Every key :meth:`DitherCalibrator.results` may return (issue 12 part 2, the total coning,
and ``dither_amplitude_pulses``, given instead of ``dither_amplitude_rad`` without K)."""
COMPONENT_KEYS = {'z': KEY_Z, 'y': KEY_Y}


def describe_component(c: Component) -> str:
    """One component as the summary, the figures and the log state it (same numbers)."""
    ab = 'a·|sin ψ₀|' if c.axis == 'z' else 'a·|cos ψ₀|'
    if c.rocking_bound_rad == 0.0:
        rock = ''
    elif math.isinf(c.rocking_bound_rad):
        rock = '; rocking allowance unbounded'
    else:
        rock = f'; rocking allowance ±{arcmin(c.rocking_bound_rad)}'
    lock = (f'; clock-lock {arcmin(c.clock_lock_std_rad)}' if c.clock_lock_std_rad else '')
    return (f'table along {c.axis.upper()}: {ab} = {arcmin(c.magnitude_rad)} '
            f'{plus_minus(c.std_rad)} (statistical {arcmin(c.statistical_std_rad)}{lock}{rock}; '
            f'floor for this {c.record_s:.0f} s record {arcmin(c.floor.component_std_rad)}; '
            f'{c.n_blocks} blocks)')


@dataclass(frozen=True, slots=True)
class DitherSummary:
    """Everything measured so far, for reports and plots.

    Attributes:
        components: per measured orientation, its :class:`Component` (every one measured is
            reported, however wide its uncertainty).
        withheld: per orientation with no component, why (no accepted block).
        misalignment: a from both (None until both orientations are measured).
        verdict: acceptance against ``max_misalignment_arcmin`` from the interval (None
            without a component).
        coning: eq. (24) and the dither × rocking term (None without a).
        dither_frequency_hz: mean Ω_d/2π over accepted blocks (NaN if none).
        dither_amplitude_pulses: mean fitted dither line amplitude (NaN if none).
        dither_amplitude_rad: θ_d with K (NaN without K).
        notes: per orientation, conditions worth a line (e.g. a vibration frequency that
            divides the sample rate).
        unresolved: per orientation whose component rests on few blocks or cannot be told
            from zero, a sentence with what would resolve it.
        interval: a's k-interval with the rocking allowance (None without a component).
        rocking: the rocking allowance the results rest on.
    """

    components: dict[str, Component]
    withheld: dict[str, str]
    misalignment: Misalignment | None
    verdict: Verdict | None
    coning: ConingDrift | None
    dither_frequency_hz: float
    dither_amplitude_pulses: float
    dither_amplitude_rad: float
    notes: dict[str, str] = field(default_factory=dict)
    unresolved: dict[str, str] = field(default_factory=dict)
    interval: Interval | None = None
    rocking: RockingAllowance | None = None

    def misalignment_line(self) -> str | None:
        """The a as the summary and the figures state it (None without a)."""
        m = self.misalignment
        if m is None:
            return None
        floor = max(c.floor.component_std_rad for c in self.components.values())
        state = '' if m.resolved else ' (not resolved from zero)'
        if m.rocking_bound_rad == 0.0:
            rock = ''
        elif math.isinf(m.rocking_bound_rad):
            rock = '; rocking allowance unbounded'
        else:
            rock = (f'; rocking allowance ±{arcmin(m.rocking_bound_rad)}: a ∈ '
                    f'[â/(1 + {m.rho:.3g}), â/(1 − {m.rho:.3g})]')
        lock = (f'; clock-lock {arcmin(m.clock_lock_std_rad)}' if m.clock_lock_std_rad
                else '')
        return (f'a = {arcmin(m.value_rad)} {plus_minus(m.std_rad)}{state} (statistical '
                f'{arcmin(m.statistical_std_rad)}{lock}{rock}); floor {arcmin(floor)}; '
                f'ψ₀ = {math.degrees(m.azimuth_rad):.0f}° (kinematics sign convention)')

    def lines(self) -> list[str]:
        """Human summary: each component and a with the floor beside it, verdict, coning."""
        out = []
        for axis in AXES:
            c = self.components.get(axis)
            if c is not None:
                out.append(describe_component(c))
            elif axis in self.withheld:
                out.append(f'table along {axis.upper()}: {self.withheld[axis]}')
        out.extend(self.unresolved.values())
        out.extend(self.notes.values())
        for axis, c in self.components.items():
            if c.null_ratio_squared > 1.5:
                out.append(
                    f'table along {axis.upper()}: the noise at the sidebands is not white '
                    f'(null-sideband χ²/dof = {c.null_ratio_squared:.2f}; the count drifts '
                    f'{c.count_drift_pulses_s:.2g} pulses/s): pulse quantisation is locked to '
                    'the dither, table and sample clocks, and σ was widened by '
                    f'{math.sqrt(c.null_ratio_squared):.2f}×. A vibration frequency that does '
                    'not divide the sample rate (e.g. 19.87 Hz rather than 20 Hz at 2 kHz) '
                    'avoids it.')
        notes = {c.rocking_note for c in self.components.values() if c.rocking_note}
        out.extend(f'rocking allowance unbounded: {n}.' for n in sorted(notes))
        line = self.misalignment_line()
        if line is not None:
            out.append(line)
        if self.verdict is not None:
            out.append(self.verdict.sentence)
        if self.coning is not None:
            cd = self.coning
            total = (f'{cd.total_rad_s:.3g} rad/s' if math.isfinite(cd.total_rad_s)
                     else 'needs K (θ_d in rad)')
            out.append(f'coning drift eq. (24): {cd.eq24_rad_s:.3g} rad/s '
                       f'({math.degrees(cd.eq24_rad_s) * 3600:.2g} °/h); with dither × rocking '
                       f'(worst case): {total}')
        if math.isfinite(self.dither_frequency_hz):
            amp = (f'{self.dither_amplitude_rad / RAD_PER_ARCSEC:.1f}″'
                   if math.isfinite(self.dither_amplitude_rad)
                   else f'{self.dither_amplitude_pulses:.2f} pulses (no K given)')
            out.append(f'dither: {self.dither_frequency_hz:.3f} Hz, amplitude {amp}')
        return out


class ResultAssembly(ComponentEstimation):
    """Summary, results, their parts and what is missing (a base of the calibrator)."""

    __slots__ = ()
    rejections: list[Rejection]

    def summary(self) -> DitherSummary:
        """Everything measured so far (components, a, interval, verdict, coning, dither)."""
        s = self.settings
        comps, missing = self.components()
        unresolved: dict[str, str] = {}
        for axis, c in comps.items():
            reason = self._resolution_note(c)
            if reason is not None:
                unresolved[axis] = reason
        misalignment = verdict = coning = interval = None
        freqs = [b.dither_frequency_hz for r in self.orientations.values() for b in r.blocks]
        amp_pulses = self._dither_amplitude_pulses()
        a_for_cos = math.hypot(*(c.signed_rad for c in comps.values())) if comps else 0.0
        theta_d = (s.scale_factor_rad_per_pulse * amp_pulses / math.cos(a_for_cos)
                   if s.has_scale_factor else math.nan)
        rocking = self.rocking_allowance(theta_d)
        if len(comps) == 2:
            z, y = comps['z'], comps['y']
            misalignment = combine_components(z, y, rocking)
            coning = coning_drift(z.magnitude_rad, y.magnitude_rad,
                                  dither_frequency_hz=float(np.mean(freqs)),
                                  dither_amplitude_rad=theta_d,
                                  rocking_per_misalignment=s.rocking_per_misalignment,
                                  rocking_phase_rad=s.rocking_phase_rad, model=s.rocking_model)
        if comps:
            interval = misalignment_interval(misalignment, comps, rocking,
                                             s.verdict_coverage_factor)
            verdict = interval_verdict(
                interval, misalignment, rocking,
                limit_rad=s.max_misalignment_arcmin * RAD_PER_ARCMIN,
                record_s=min(c.record_s for c in comps.values()),
                sample_rate_hz=min(c.sample_rate_hz for c in comps.values()),
                table_rate_amplitude_rad_s=max(c.table_rate_amplitude_rad_s
                                               for c in comps.values()),
                missing_axes=tuple(a for a in AXES if a not in comps))
        notes = {axis: c.clock_lock_note for axis, c in comps.items() if c.clock_lock_note}
        return DitherSummary(comps, missing, misalignment, verdict, coning,
                             float(np.mean(freqs)) if freqs else math.nan, amp_pulses, theta_d,
                             notes, unresolved, interval, rocking)

    def _coning_estimates(self, summary: DitherSummary) -> dict[str, Estimate]:
        """Eq. (24) and the total, with uncertainty by the unscented transform of (ŝ_z, ŝ_y)."""
        s = self.settings
        z, y = summary.components['z'], summary.components['y']
        sz, sy, vz, vy = z.magnitude_rad, y.magnitude_rad, z.std_rad, y.std_rad
        spread = math.sqrt(3.0)
        points = [(sz, sy, 1 / 3)] + [(sz + d * spread * vz, sy, 1 / 6) for d in (-1, 1)] + [
            (sz, sy + d * spread * vy, 1 / 6) for d in (-1, 1)]
        vals = [coning_drift(abs(pz), abs(py), dither_frequency_hz=summary.dither_frequency_hz,
                             dither_amplitude_rad=summary.dither_amplitude_rad,
                             rocking_per_misalignment=s.rocking_per_misalignment,
                             rocking_phase_rad=s.rocking_phase_rad, model=s.rocking_model)
                for pz, py, _ in points]
        weights = np.array([w for *_, w in points])
        out = {}
        n = z.n_blocks + y.n_blocks
        dof = min(z.dof, y.dof)
        unbounded = not (math.isfinite(vz) and math.isfinite(vy))
        for key, attr in ((KEY_CONING, 'eq24_rad_s'), (KEY_CONING_TOTAL, 'total_rad_s')):
            if unbounded:  # a's uncertainty has no bound, so has ε's (value still measured)
                value = getattr(vals[0], attr)
                if math.isfinite(value):
                    out[key] = Estimate(float(value), math.inf, n, dof)
                continue
            v = np.array([getattr(c, attr) for c in vals])
            if not np.all(np.isfinite(v)):
                continue
            mean = float(weights @ v)
            std = math.sqrt(max(float(weights @ (v - mean) ** 2), 0.0))
            out[key] = Estimate(float(v[0]), std, n, dof)
        return out

    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (SI units), only those measured so far.

        ``dither_misalignment_z_rad`` / ``_y_rad``: bias-corrected a·|sin ψ₀|, a·|cos ψ₀|;
        ``dither_axis_misalignment_rad``: bias-corrected a (both orientations needed). Every
        measured one is returned, however wide: the standard uncertainty combines the
        statistical part and the rocking allowance (bound/√3) and is inf when the allowance
        cannot be sized (:meth:`result_parts` has the parts and the interval).
        ``dither_amplitude_rad`` needs K; without it ``dither_amplitude_pulses`` is given.
        """
        summary = self.summary()
        out: dict[str, Estimate] = {}
        for axis, c in summary.components.items():
            out[COMPONENT_KEYS[axis]] = Estimate(c.magnitude_rad, c.std_rad, c.n_blocks, c.dof,
                                                 tuple(self.rejections), c.clock_lock_note)
        m = summary.misalignment
        if m is not None:
            z, y = summary.components['z'], summary.components['y']
            out[KEY_A] = Estimate(m.value_rad, m.std_rad, z.n_blocks + y.n_blocks,
                                  min(z.dof, y.dof), tuple(self.rejections),
                                  ' '.join(c.clock_lock_note for c in (z, y)
                                           if c.clock_lock_note))
            out.update(self._coning_estimates(summary))
        blocks = [b for r in self.orientations.values() for b in r.blocks]
        if blocks:
            n = len(blocks)
            freqs = np.array([b.dither_frequency_hz for b in blocks])
            amps = np.array([b.dither_amplitude_pulses for b in blocks])
            f_std = float(np.std(freqs, ddof=1) / math.sqrt(n)) if n > 1 else math.nan
            a_std = float(np.std(amps, ddof=1) / math.sqrt(n)) if n > 1 else math.nan
            out[KEY_FREQUENCY] = Estimate(float(freqs.mean()), f_std, n, n - 1)
            if self.settings.has_scale_factor:
                scale = summary.dither_amplitude_rad / float(amps.mean())
                # θ_d = K·P/cos a: a's uncertainty (rocking bound included) enters as tan a·u(a)
                comps = self.components()[0]
                a_raw = math.hypot(*(c.signed_rad for c in comps.values())) if comps else 0.0
                u_a = (m.std_rad if m is not None else
                       math.hypot(*(c.std_rad for c in comps.values())) if comps else 0.0)
                if not math.isfinite(u_a):  # unbounded a: its statistical part instead
                    u_a = (m.random_std_rad if m is not None else
                           math.hypot(*(c.random_std_rad for c in comps.values())))
                rel = math.tan(a_raw) * u_a
                std = math.hypot(a_std * scale, rel * summary.dither_amplitude_rad)
                out[KEY_AMPLITUDE] = Estimate(summary.dither_amplitude_rad, std, n, n - 1)
            else:
                out[KEY_AMPLITUDE_PULSES] = Estimate(float(amps.mean()), a_std, n, n - 1)
        return out

    def result_parts(self) -> dict[str, dict[str, Any]]:
        """Per misalignment key, the parts of its uncertainty (``--json``).

        ``std_statistical`` (the random part: residuals, block scatter, clock-lock widening),
        ``systematic_bound`` (half-width of the rocking allowance; inf when it cannot be
        sized, 0 when not bounded), ``systematic_model`` (what the bound rests on),
        ``interval`` ([lower, upper] at ``coverage_factor``, the allowance included).
        """
        summary = self.summary()
        rocking = summary.rocking
        model = rocking.description() if rocking is not None else ''
        k = self.settings.verdict_coverage_factor
        out: dict[str, dict[str, Any]] = {}
        m = summary.misalignment
        a_hi = (summary.interval.upper_rad if summary.interval is not None else math.inf)
        kappa = rocking.kappa if rocking is not None else 0.0
        for axis, c in summary.components.items():
            slack = k * c.random_std_rad + (kappa * a_hi if kappa else 0.0)
            out[COMPONENT_KEYS[axis]] = {
                'std_statistical': c.random_std_rad, 'systematic_bound': c.rocking_bound_rad,
                'systematic_model': model + (f' ({c.rocking_note})' if c.rocking_note else ''),
                'interval': [max(c.magnitude_rad - slack, 0.0), c.magnitude_rad + slack],
                'coverage_factor': k}
        if m is not None and summary.interval is not None:
            out[KEY_A] = {
                'std_statistical': m.random_std_rad, 'systematic_bound': m.rocking_bound_rad,
                'systematic_model': model,
                'interval': [summary.interval.lower_rad, summary.interval.upper_rad],
                'coverage_factor': k}
        return out

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet), a whole sentence."""
        s = self.settings
        summary = self.summary()
        have = self.results()
        out: dict[str, str] = {}
        last = self.rejections[-1].reason if self.rejections else None
        tail = f' Last rejection: {last}' if last else ''
        for axis in AXES:
            key = COMPONENT_KEYS[axis]
            if key not in have:
                out[key] = summary.withheld.get(axis, f'no table along {axis.upper()} yet.') + (
                    tail if axis not in summary.components else '')
        if KEY_A not in have:
            absent = [a.upper() for a in AXES if a not in summary.components]
            out[KEY_A] = (f'a = √(z² + y²) needs both orientations\' components; none with '
                          f'the table along {" and ".join(absent)}. One orientation sees only '
                          'a·|sin ψ₀| or a·|cos ψ₀|, which depends on the mounting azimuth ψ₀ '
                          '(it bounds a from below: see the verdict).')
            for key in (KEY_CONING, KEY_CONING_TOTAL):
                out[key] = 'the coning drift needs a, which needs both orientations.'
        elif KEY_CONING_TOTAL not in have:
            out[KEY_CONING_TOTAL] = ('the dither × rocking coning needs θ_d in rad: give '
                                     'scale_factor_rad_per_pulse (K).')
        for key, est in have.items():
            if math.isinf(est.std_uncertainty):
                out[key] = (f'its value ({est.value:.6g}) is measured and shown with its '
                            'statistical part (summary, --json), but its uncertainty is '
                            'unbounded (the rocking allowance, see above): the hand-off file '
                            'takes only values with a stated uncertainty.')
        interval, verdict = summary.interval, summary.verdict
        if verdict is None:
            for key in (KEY_VERDICT, KEY_LOWER, KEY_UPPER, KEY_LIMIT):
                out[key] = 'the verdict needs at least one measured component.'
        elif interval is not None and not math.isfinite(interval.upper_rad):
            out[KEY_UPPER] = ('nothing bounds a from above yet: ' + verdict.sentence)
        if KEY_FREQUENCY not in have:
            out[KEY_FREQUENCY] = 'no accepted block yet (needs the dither line).' + tail
        if KEY_AMPLITUDE not in have:
            out[KEY_AMPLITUDE] = (
                'θ_d in rad needs the scale factor K (scale_factor_rad_per_pulse); it is '
                'reported in pulses under dither_amplitude_pulses.'
                if not s.has_scale_factor else 'no accepted block yet.' + tail)
        return out
