"""What a certificate needs from a calibration run, in a form that travels between processes.

:func:`evidence_from_outcome` takes a finished :class:`~gyro_calib.bag_calibration.
BagCalibration` (the sessions that ran) and keeps, per method, the estimates with their
degrees of freedom and uncertainty bases, the budget sources the estimator knows, what is
missing and why, the rejections, and the method's figures as PNG bytes; and for the run, each
input bag with the SHA-256 of its files and the bench settings with where each came from.
Everything here is a frozen dataclass of plain values, so a Dask worker can return it.
"""

from __future__ import annotations

import hashlib
import math
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.errors import GyroCalibError
from gyro_calib.estimate import Estimate
from gyro_calib.registry import METHODS
from gyro_calib.report.uncertainty import BudgetLine, basis_widening
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from gyro_calib.bag_calibration import BagCalibration
    from gyro_calib.bagio import BagInfo
    from gyro_calib.session import CalibrationOptions, MethodSession

FIGURE_CAPTIONS = {
    'rbrlg_k_tilde_pairs': 'K̃ per forward/reverse pair with the running mean and its ±1σ band '
                           '(METHODS §A.2)',
    'rbrlg_stations': 'Station fit N_og(β) = c₀ + c₁·cos β + c₂·sin β with residuals '
                      '(METHODS §A.3)',
    'fog_turntable_nonlinearity': 'FOG turntable: residuals of the linear fit (nonlinearity) '
                                  '(METHODS §B)',
    'fog_self_cal_range': 'FOG self-calibration: K against the range used (METHODS §B)',
    'dither_coning': 'Dither: the two components and a with its interval against the limit '
                     '(METHODS §C)',
    'thermal_bias_vs_h': 'Thermal bias model over the calibration data (METHODS §D)',
    'thermal_residuals': 'Thermal model residuals against time (METHODS §D)',
    'thermal_before_after': 'Bias before and after compensation (METHODS §D)',
    'thermal_allan': 'Allan deviation before and after compensation (METHODS §D)',
}
"""Captions of the methods' figures by file stem (others are captioned by their name)."""


@dataclass(frozen=True, slots=True)
class Figure:
    """One figure: file stem, caption, PNG bytes."""

    name: str
    caption: str
    png: bytes


@dataclass(frozen=True, slots=True)
class BagInput:
    """One input bag.

    Attributes:
        path: as given.
        files: (file name inside the bag, SHA-256 hex) of each file, sorted.
        start_ns, end_ns: log-time span, ns.
        messages: message count.
        temperature: per sensor of ``/gyro/temperature`` recorded in it (header.frame_id):
            (sensor, lowest, mean, highest in °C, readings); () when none is recorded.
    """

    path: str
    files: tuple[tuple[str, str], ...]
    start_ns: int
    end_ns: int
    messages: int
    temperature: tuple[tuple[str, float, float, float, int], ...] = ()

    @property
    def duration_s(self) -> float:
        """Log-time span, s."""
        return (self.end_ns - self.start_ns) / 1e9


@dataclass(frozen=True, slots=True)
class Setting:
    """A bench setting used: name, value as printed, where it came from, by which method."""

    name: str
    value: str
    origin: str
    method: str = ''


@dataclass(frozen=True, slots=True)
class MethodEvidence:
    """One method's run, as the certificate shows it.

    Attributes:
        method: registry name.
        title: one line describing the method.
        estimates: hand-off key (or session result) → estimate, SI.
        budgets: key → its uncertainty sources (as the estimator knows them).
        missing: key → why it was not measured.
        rejections: one line per rejected window/event/station, with its stamp.
        notices: stream events (restarts, drops).
        summary: the lines under the method's summary table (counts, bases).
        figures: the method's figures.
        span_ns: (first, last) stamp the results rest on, or None.
    """

    method: str
    title: str
    estimates: Mapping[str, Estimate]
    budgets: Mapping[str, tuple[BudgetLine, ...]]
    missing: Mapping[str, str]
    rejections: tuple[str, ...]
    notices: tuple[str, ...]
    summary: tuple[str, ...]
    figures: tuple[Figure, ...]
    span_ns: tuple[int, int] | None


@dataclass(frozen=True, slots=True)
class RunEvidence:
    """A calibration run: its methods, input bags and settings."""

    methods: tuple[MethodEvidence, ...]
    bags: tuple[BagInput, ...]
    settings: tuple[Setting, ...]


def sha256_files(path: Path) -> tuple[tuple[str, str], ...]:
    """(name, SHA-256 hex) of a bag's files: every file of a bag directory, or the one file."""
    path = Path(path)
    files = sorted(p for p in path.rglob('*') if p.is_file()) if path.is_dir() else [path]
    out = []
    for f in files:
        digest = hashlib.sha256()
        with f.open('rb') as stream:
            for block in iter(lambda: stream.read(1 << 20), b''):
                digest.update(block)
        out.append((str(f.relative_to(path)) if path.is_dir() else f.name, digest.hexdigest()))
    return tuple(out)


def bag_input(info: BagInfo, files: tuple[tuple[str, str], ...] | None = None) -> BagInput:
    """The bag's identity: files with their hashes, span, count; the temperatures it records.

    ``files``: the bag's (name, SHA-256) as :func:`sha256_files` gave them already (a batch's
    plan task hashed the bag before it was calibrated); None: hashed here.
    """
    return BagInput(str(info.path), sha256_files(info.path) if files is None else files,
                    info.start_ns, info.end_ns, info.message_count, recorded_temperature(info))


def recorded_temperature(info: BagInfo) -> tuple[tuple[str, float, float, float, int], ...]:
    """(sensor, lowest, mean, highest °C, readings) of each ``/gyro/temperature`` sensor.

    Only that topic is read (nothing when the bag does not record it); NaN readings are left
    out.
    """
    from gyro_calib.bagio import TEMPERATURE, iter_sample_batches
    from gyro_calib.topics import GYRO_TEMPERATURE

    if info.topics.get(GYRO_TEMPERATURE) is None:
        return ()
    import numpy as np

    parts: dict[str, list[Any]] = {}
    for batch in iter_sample_batches(info.path, {GYRO_TEMPERATURE: TEMPERATURE},
                                     namespace=info.namespace):
        cols = batch.columns.get(GYRO_TEMPERATURE)
        if cols is None:
            continue
        values = cols.values['temperature_degc']
        for code, name in enumerate(cols.frame_id.names):
            picked = values[(cols.frame_id.codes == code) & np.isfinite(values)]
            if picked.size:
                parts.setdefault(name or '(unnamed)', []).append(picked)
    out = []
    for name, chunks in sorted(parts.items()):
        v = np.concatenate(chunks)
        out.append((name, float(v.min()), float(v.mean()), float(v.max()), int(v.size)))
    return tuple(out)


def settings_used(options: CalibrationOptions, method: str = '') -> tuple[Setting, ...]:
    """Each bench setting with its value and origin.

    Each bench setting (:data:`gyro_calib.config.BENCH_SETTINGS`) with its value and where it
    came from (flag or node parameter, config file, the bench settings stored with the
    method's bags, or the default), as the method's session took it; then its config file.
    A setting given that differs from the one stored with the bags carries the note
    ``calibrate`` prints (:meth:`~gyro_calib.session.CalibrationOptions.conflicts`).
    """
    from gyro_calib.config import BENCH_SETTINGS
    from gyro_calib.registry import METHODS

    used = METHODS[method].bench_settings if method in METHODS else tuple(BENCH_SETTINGS)
    out = []
    for name, spec in BENCH_SETTINGS.items():
        if name == 'gyro_id':
            continue
        try:
            value, origin = options.setting_with_origin(name)
        except GyroCalibError as exc:  # e.g. the bags disagree: say so, do not guess
            value, origin = None, ' '.join(str(exc).split())
        shown = '—' if value is None or (isinstance(value, float) and math.isnan(value)) \
            else f'{value} {spec.unit}'.strip()
        if origin == 'default':
            origin = 'not given: the method\'s default'
        elif name in used:
            origin += ''.join(f'; note: {line}' for line in options.conflicts((name,)))
        out.append(Setting(name, shown, origin, method))
    if options.config_file is not None:
        out.append(Setting('config file', str(options.config_file), 'flag --config', method))
    if options.calibration_file is not None:
        out.append(Setting('calibration file', str(options.calibration_file),
                           'flag --calibration', method))
    return tuple(out)


def _budgets(session: MethodSession,
             estimates: Mapping[str, Estimate]) -> dict[str, tuple[BudgetLine, ...]]:
    """The sources of each estimate's uncertainty.

    The sources of each estimate's u: what the estimator states, split where it knows the
    parts (dither: statistical and the rocking Type B allowance).
    """
    out: dict[str, tuple[BudgetLine, ...]] = {}
    for key, est in estimates.items():
        source = est.basis or f'{session.name} estimator (stated u, {est.dof} dof)'
        out[key] = (BudgetLine(source, est.std_uncertainty, float(est.dof),
                               basis_widening(est.basis)),)
    if session.name == 'dither':
        section = session.json_section()
        parts: dict[str, Any] = {}
        for axis, key in (('z', 'dither_misalignment_z_rad'),
                          ('y', 'dither_misalignment_y_rad')):
            parts[key] = (section.get('components') or {}).get(axis)
        parts['dither_axis_misalignment_rad'] = section.get('misalignment')
        for key, part in parts.items():
            part_est = estimates.get(key)
            stat = (part or {}).get('statistical_std_rad')
            if part_est is None or stat is None or not math.isfinite(stat):
                continue
            stat = min(float(stat), part_est.std_uncertainty)
            rest = math.sqrt(max(part_est.std_uncertainty**2 - stat**2, 0.0))
            lines = [BudgetLine('statistical scatter of the sideband fits', stat,
                                float(part_est.dof))]
            if rest > 0:
                lines.append(BudgetLine('rocking allowance and clock-lock widening '
                                        '(Type B, as a standard uncertainty)', rest, math.inf))
            out[key] = tuple(lines)
    if session.name == 'triad':
        out.update(_triad_budgets(getattr(session, 'triad_result', None)))
    return out


def _triad_budgets(result: Any) -> dict[str, tuple[BudgetLine, ...]]:
    """The triad's budget per source (METHODS §F eq. (12)) of each K_i and sense axis s_i.

    ``imu.<c>.scale_factor_rad_per_pulse``: each source's u(K_i); ``imu.<c>.sense_axis_rad``:
    each source's √trace C(s_i) (the certificate splits a component's u in these shares). The
    counts are the statistical source (ν of the row fit); the swept angle and the bench
    parameters (tilt α) are Type B (ν = ∞).
    """
    out: dict[str, tuple[BudgetLine, ...]] = {}
    if result is None:
        return out
    for i, ch in enumerate(result.channels):
        k = ch.scale_factor_rad_per_pulse
        if k is None:
            continue
        lines_k, lines_s = [], []
        for line in result.budget:
            dof = float(k.dof) if line.source == 'counts' else math.inf
            widening = basis_widening(k.basis) if line.source == 'counts' else 1.0
            rel, direction = float(line.scale_factor_relative[i]), float(line.direction_rad[i])
            if math.isfinite(rel):
                lines_k.append(BudgetLine(line.source, rel * k.value, dof, widening))
            if math.isfinite(direction):
                lines_s.append(BudgetLine(line.source, direction, dof, widening))
        out[f'imu.{ch.name}.scale_factor_rad_per_pulse'] = tuple(lines_k)
        out[f'imu.{ch.name}.sense_axis_rad'] = tuple(lines_s)
    return out


def _triad_estimates(session: MethodSession) -> dict[str, Estimate]:
    """The triad's fitted bench parameters (``imu.fitted.<name>``, e.g. the tilt α correction)."""
    result = getattr(session, 'triad_result', None)
    if session.name != 'triad' or result is None:
        return {}
    return {f'imu.fitted.{name}': est for name, est in result.parameters.items()}


def method_evidence(session: MethodSession, *, figures: bool = True) -> MethodEvidence:
    """One session's evidence (figures drawn into a temporary directory and read back)."""
    estimates = {**session.results(), **_triad_estimates(session)}
    figs: list[Figure] = []
    notices = list(session.notices())
    if figures:
        with tempfile.TemporaryDirectory(prefix='gyro_calib_fig_') as tmp:
            try:
                paths = session.plot(Path(tmp))
            except Exception as exc:  # noqa: BLE001  (a figure must not cost the certificate)
                paths = []
                notices.append(f'the {session.name} figures could not be drawn: '
                               f'{type(exc).__name__}: {" ".join(str(exc).split())}')
            for path in paths:
                stem = Path(path).stem
                figs.append(Figure(stem, FIGURE_CAPTIONS.get(stem, stem.replace('_', ' ')),
                                   Path(path).read_bytes()))
    rejections = tuple(f'{format_stamp(r.stamp_ns)}: {r.reason}' for r in session.rejections())
    return MethodEvidence(
        session.name, METHODS[session.name].title, estimates, _budgets(session, estimates),
        dict(session.missing()), rejections, tuple(notices),
        tuple(session.summary_lines()), tuple(figs), session.data_span_ns())


def evidence_from_outcome(outcome: BagCalibration, options: CalibrationOptions, *,
                          figures: bool = True,
                          hashes: Mapping[str, tuple[tuple[str, str], ...]] | None = None,
                          ) -> RunEvidence:
    """The evidence of a finished bag calibration.

    The bags' hashes are read from their files, or taken from ``hashes`` (bag path as
    ``str(info.path)`` → :func:`sha256_files` of it) for the bags it names.
    """
    hashes = hashes or {}
    per_method = getattr(outcome, 'options', {}) or {}
    settings = tuple(s for name in outcome.sessions
                     for s in settings_used(per_method.get(name, options), name))
    return RunEvidence(
        tuple(method_evidence(s, figures=figures) for s in outcome.sessions.values()),
        tuple(bag_input(i, hashes.get(str(i.path))) for i in outcome.infos), settings)
