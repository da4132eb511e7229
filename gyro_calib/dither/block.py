"""One block of the record: is it usable, and its reduction to the sideband normal equations.

The per-window fit of METHODS §C for one block of ``block_s`` (steps 1–3 of
:mod:`gyro_calib.dither.calibrator`): fit the table motion from joint_states, fit the
output's own dither line with the table lines and a straight line as nuisance terms, build
the sideband regressors G_in = ∫ω_T·φ and G_quad in closed form, project every nuisance term
out and add the block's 2×2 reduced normal equations to its orientation's record. A block
without table data, without a dither line, sampled too slowly, with the vibration frequency
on a dither line or harmonic, or with glitching counts is rejected with its reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.dither.lines import (
    fit_dither_line,
    fit_table_motion,
    nuisance_columns,
    sinusoid_columns,
)
from gyro_calib.dither.regression import (
    ReducedNormalEquations,
    choose_null_multiples,
    null_sideband_regressors,
    reduce_block,
    sideband_regressors,
)
from gyro_calib.dither.wording import stamp
from gyro_calib.estimate import Rejection
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.dither.settings import DitherSettings

    FloatArray = npt.NDArray[np.float64]

AXES = ('z', 'y')
FRAME_CODES = {'z': 0.0, 'y': 1.0}


@dataclass(frozen=True, slots=True)
class BlockSummary:
    """What one accepted block found (kept for plots and checks; a few numbers).

    Attributes:
        start_ns: block start stamp, ns.
        span_s: time covered by its pulse samples, s.
        beta: the block's own (β_in, β_quad), rad.
        beta_std: their standard uncertainties from the block alone, rad.
        dither_frequency_hz: fitted Ω_d/2π, Hz.
        dither_amplitude_pulses: fitted |P|, pulses.
        table_frequency_hz: fitted Ω_z/2π, Hz.
        table_rate_amplitude_rad_s: fitted A, rad/s.
        residual_rms_pulses: rms residual of the block's model, pulses.
        sample_rate_hz: pulse sample rate in the block, Hz.
        drift_pulses_s: straight-line drift of the count (Earth rate + bias), pulses/s.
    """

    start_ns: int
    span_s: float
    beta: tuple[float, float]
    beta_std: tuple[float, float]
    dither_frequency_hz: float
    dither_amplitude_pulses: float
    table_frequency_hz: float
    table_rate_amplitude_rad_s: float
    residual_rms_pulses: float
    sample_rate_hz: float
    drift_pulses_s: float


@dataclass(slots=True)
class OrientationRecord:
    """Everything kept about one orientation: reduced sums, block summaries, spectra."""

    axis: str
    equations: ReducedNormalEquations = field(default_factory=ReducedNormalEquations)
    blocks: list[BlockSummary] = field(default_factory=list)
    spectrum_sum: FloatArray | None = None
    residual_spectrum_sum: FloatArray | None = None
    spectrum_rate_hz: float = math.nan
    n_spectra: int = 0
    last_residual: tuple[FloatArray, FloatArray] | None = None
    null_multiples: tuple[int, ...] | None = None

    @property
    def record_s(self) -> float:
        """Time covered by accepted blocks, s."""
        return float(sum(b.span_s for b in self.blocks))

    def mean(self, name: str) -> float:
        """Mean of a block attribute over accepted blocks."""
        return float(np.mean([getattr(b, name) for b in self.blocks]))



def line_conflicts(dither_hz: float, table_hz: float, *, separation_hz: float,
                   harmonics: int) -> list[str]:
    """Why the sidebands f_d ± f_z cannot be told from another modelled line (empty if fine).

    Lines modelled: zero frequency (the straight line), the dither line f_d and its
    harmonic 2·f_d, the table lines h·f_z (h = 1 … H). A sideband within ``separation_hz``
    of any of them — the vibration frequency near the dither frequency, a harmonic or a
    sub-harmonic of it, or too low — is collinear with that line over a block.
    """
    lines = {'zero frequency': 0.0, 'the dither line f_d': dither_hz,
             'the dither harmonic 2·f_d': 2 * dither_hz}
    lines.update({('the table line f_z' if h == 1 else f'the table harmonic {h}·f_z'):
                  h * table_hz for h in range(1, harmonics + 1)})
    out = []
    for name, sb in (('f_d − f_z', abs(dither_hz - table_hz)),
                     ('f_d + f_z', dither_hz + table_hz)):
        for line_name, f in lines.items():
            if abs(sb - f) < separation_hz:
                out.append(f'the sideband {name} = {sb:.2f} Hz lies within {separation_hz:g} Hz '
                           f'of {line_name} ({f:.2f} Hz)')
    for h in range(1, harmonics + 1):
        if abs(dither_hz - h * table_hz) < separation_hz:
            out.append(f'the dither line ({dither_hz:.2f} Hz) lies on the table line '
                       f'{h}·f_z = {h * table_hz:.2f} Hz')
    return out


class BlockReduction:
    """Judges and reduces blocks into the orientations' records (a base of the calibrator)."""

    __slots__ = ()
    settings: DitherSettings
    orientations: dict[str, OrientationRecord]
    rejections: list[Rejection]

    def _reject(self, start_ns: int, reason: str) -> None:
        self.rejections.append(Rejection(start_ns, reason))

    def _reduce(self, start: int, end: int, p_t: npt.NDArray[np.int64], counts: FloatArray,
                t_t: npt.NDArray[np.int64], t_v: FloatArray) -> str | None:
        """Judge and reduce one block; return its axis if accepted."""
        s = self.settings
        where = f'block {stamp(start)}–{stamp(end)}'
        if len(p_t) < 64:
            self._reject(start, f'{where}: {len(p_t)} pulse samples; a block needs at least 64 '
                                '(is /gyro/pulses recorded?).')
            return None
        if len(t_t) < 16:
            self._reject(start, (
                f'{where}: {len(t_t)} /vibration_table/joint_states samples: the table stream '
                'is missing or stopped; each orientation needs the table joint_states beside '
                'the pulses.'))
            return None
        codes = np.unique(t_v[:, 2])
        if len(codes) > 1:
            self._reject(start, f'{where}: the joint_states frame_id changes inside the block '
                                '(orientation changed); the block is not used.')
            return None
        axis = AXES[int(codes[0])]
        max_gap = int(s.max_gap_s * NS_PER_S)
        for name, t in (('pulse', p_t), ('joint_states', t_t)):
            gaps = np.diff(t)
            if len(gaps) and gaps.max() > max_gap:
                i = int(np.argmax(gaps))
                self._reject(start, f'{where}: {name} samples missing for '
                                    f'{gaps[i] / NS_PER_S:.3f} s from {stamp(int(t[i]))} '
                                    f'(max_gap_s = {s.max_gap_s:g}).')
                return None
        if t_t[0] - p_t[0] > max_gap or p_t[-1] - t_t[-1] > max_gap:
            self._reject(start, (
                f'{where}: joint_states cover only {stamp(int(t_t[0]))}–{stamp(int(t_t[-1]))} '
                f'of the pulses\' {stamp(int(p_t[0]))}–{stamp(int(p_t[-1]))}: the table stream '
                'started late or stopped early.'))
            return None
        mid = (int(p_t[0]) + int(p_t[-1])) // 2
        tau = (p_t - mid).astype(np.float64) / NS_PER_S
        tau_t = (t_t - mid).astype(np.float64) / NS_PER_S
        span = float(tau[-1] - tau[0])
        fs = (len(p_t) - 1) / span
        fs_table = (len(t_t) - 1) / float(tau_t[-1] - tau_t[0])
        table = fit_table_motion(tau_t, t_v[:, 0], harmonics=s.table_harmonics,
                                 sample_rate_hz=fs_table,
                                 band_hz=(2.0 / span, min(s.table_band_max_hz, 0.45 * fs_table)))
        amp = table.rate_amplitude_rad_s
        if not amp >= s.min_table_rate_amplitude_rad_s:
            self._reject(start, f'{where}: the table along {axis.upper()} is not vibrating '
                                f'(rate amplitude {amp:.2g} rad/s < '
                                f'{s.min_table_rate_amplitude_rad_s:g}).')
            return None
        fz = table.frequency_hz
        if fs / 2 <= s.dither_band_max_hz:
            self._reject(start, (
                f'{where}: pulses sampled at {fs:.0f} Hz cannot resolve a dither up to '
                f'{s.dither_band_max_hz:g} Hz (it would alias): sample faster than '
                f'{2 * (s.dither_band_max_hz + fz):.0f} Hz '
                f'(dither and sidebands at ±{fz:.1f} Hz), '
                'or set dither_band_max_hz to just above your gyro\'s dither frequency.'))
            return None
        y = counts - counts[0]
        dither = fit_dither_line(tau, y, table, harmonics=s.table_harmonics, sample_rate_hz=fs,
                                 band_hz=(s.dither_band_min_hz, s.dither_band_max_hz))
        fd = dither.frequency_hz
        edge = 2.0 / span
        if (dither.amplitude_pulses < s.min_dither_amplitude_pulses
                or not s.dither_band_min_hz + edge <= fd <= s.dither_band_max_hz - edge):
            self._reject(start, (
                f'{where}: no dither line in the output (strongest line '
                f'{dither.amplitude_pulses:.2f} pulses at {fd:.1f} Hz; needs '
                f'≥ {s.min_dither_amplitude_pulses:g} pulses inside {s.dither_band_min_hz:g}–'
                f'{s.dither_band_max_hz:g} Hz): the output looks dither-stripped. The method '
                'needs the raw (unstripped) pulse output, whose dither line gives φ(t).'))
            return None
        if fd + fz >= fs / 2:
            self._reject(start, (
                f'{where}: the upper sideband f_d + f_z = {fd + fz:.1f} Hz is above the Nyquist '
                f'frequency {fs / 2:.0f} Hz of the {fs:.0f} Hz pulses (it aliases): sample faster '
                f'than {2 * (fd + fz):.0f} Hz or vibrate slower.'))
            return None
        if dither.residual_rms_pulses > s.max_residual_rms_pulses:
            self._reject(start, (
                f'{where}: counts deviate from the fitted dither and table lines by '
                f'{dither.residual_rms_pulses:.2f} pulses rms (limit '
                f'{s.max_residual_rms_pulses:g}): count glitches or an unsteady dither.'))
            return None
        conflicts = line_conflicts(fd, fz, separation_hz=s.line_separation_hz,
                                   harmonics=s.table_harmonics)
        if conflicts:
            self._reject(start, (
                f'{where}: vibration frequency {fz:.2f} Hz is too close to the dither frequency '
                f'{fd:.2f} Hz, a harmonic or sub-harmonic of it: {"; ".join(conflicts)}. Choose '
                f'a vibration frequency clear of them (e.g. {0.05 * fd:.0f}–{0.12 * fd:.0f} Hz).'))
            return None
        rec = self.orientations[axis]
        if rec.null_multiples is None:  # fixed at the orientation's first block
            rec.null_multiples = choose_null_multiples(
                fd, fz, fs, harmonics=s.table_harmonics, separation_hz=s.line_separation_hz)
        g_in, g_quad = sideband_regressors(tau, dither, table)
        nulls = null_sideband_regressors(tau, dither, table, rec.null_multiples)
        nuisance = np.hstack((nuisance_columns(tau, table, s.table_harmonics),
                              sinusoid_columns(tau, np.array([dither.angular_frequency_rad_s]))))
        reduction, residual = reduce_block(dither.residual_pulses, nuisance,
                                           np.column_stack((g_in, g_quad, nulls)))
        rec.equations.add(reduction)
        dof = max(reduction.n_samples - reduction.n_nuisance - len(reduction.rhs), 1)
        sigma2 = float(residual @ residual) / dof
        beta = reduction.solve()
        std = np.sqrt(np.diag(np.linalg.inv(reduction.normal)) * sigma2)
        rec.blocks.append(BlockSummary(start, span, (float(beta[0]), float(beta[1])),
                                       (float(std[0]), float(std[1])), fd,
                                       dither.amplitude_pulses, fz, amp,
                                       float(np.sqrt(np.mean(residual ** 2))), fs,
                                       dither.drift_pulses_s))
        self._add_spectra(rec, y - y.mean(), residual, fs)
        rec.last_residual = (tau, residual)
        return axis

    def _add_spectra(self, rec: OrientationRecord, counts: FloatArray, residual: FloatArray,
                     fs: float) -> None:
        n = self.settings.spectrum_samples
        if len(counts) < n // 2:
            return
        window = np.hanning(n)
        norm = 2.0 / window.sum()
        spectra = []
        for series in (counts, residual):
            part = series[:n] - np.mean(series[:n])
            if len(part) < n:
                part = np.concatenate((part, np.zeros(n - len(part))))
            spectra.append((np.abs(np.fft.rfft(part * window)) * norm) ** 2)
        if rec.spectrum_sum is None:
            rec.spectrum_sum, rec.residual_spectrum_sum = spectra
            rec.spectrum_rate_hz = fs
        else:
            rec.spectrum_sum = rec.spectrum_sum + spectra[0]
            rec.residual_spectrum_sum = rec.residual_spectrum_sum + spectra[1]
        rec.n_spectra += 1
