"""The calibration certificate of one gyro: the model, its HTML (self-contained) and its PDF.

:func:`build_certificate` joins the hand-off file (the values, as the INS receives them) with
what the run knows (:class:`~gyro_calib.report.evidence.RunEvidence`: degrees of freedom,
budgets, rejections, figures, input hashes, settings) and a spec (verdicts). Values are the
hand-off's, converted to the unit a lab quotes (:mod:`gyro_calib.report.units`); k and U follow
from the degrees of freedom (:mod:`gyro_calib.report.uncertainty`): the run's where the bags
are given, else the hand-off's ``<key>_dof``, else k = 2 with the reason in the row itself; a
method that states an interval of its own (the dither misalignment a) is quoted with it and
judged by it. No verdict without grounds: a certificate with nothing measured is refused, a
spec quantity not measured makes the unit's verdict NO VERDICT, and a hand-off value the given
bags contradict is refused (:data:`CONTRADICTION_U`) unless accepted. Only a certificate issued
by a laboratory (an :class:`~gyro_calib.report.lab.Issue`: lab, number, customer) holds what
ISO/IEC 17025 7.8.2, 7.8.4 and 7.8.6 ask, laid out in its template (:data:`TEMPLATE`); without
one it is a draft and says so on every page. An IMU (a triad's ``imu:`` section) is certified
by its quantities — K_i, misalignments, axis angles, non-orthogonality, body biases, noise —
as :mod:`gyro_calib.report.imu` derives them, with its conditions and M
(docs/certificates_imu.md).
"""

from __future__ import annotations

import base64
import dataclasses
import datetime
import functools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from html import unescape
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gyro_calib import __version__
from gyro_calib.errors import ConfigError
from gyro_calib.handoff import Calibration, HandoffKey
from gyro_calib.outputs import write_all_or_none
from gyro_calib.registry import METHODS, handoff_schema
from gyro_calib.report.conditions import (
    WALL_CLOCK_FROM_NS,
    calibration_date,
    temperature_text,
)
from gyro_calib.report.evidence import MethodEvidence, RunEvidence
from gyro_calib.report.imu import (
    budget_shares,
    imu_group,
    imu_quantities,
    is_imu_key,
    matrix_text,
    noise_bounds,
    procedure_text,
)
from gyro_calib.report.lab import Issue
from gyro_calib.report.spec import (
    NOT_MEASURED,
    Spec,
    interval_verdict,
    limit_for,
    overall,
    overall_class,
    refuse_unknown_imu_channels,
    verdict,
)
from gyro_calib.report.uncertainty import (
    BudgetLine,
    Expanded,
    budget_source,
    contribution_percent,
    expanded_uncertainty,
    format_dof,
)
from gyro_calib.report.units import user_unit
from gyro_calib.units import ARCSEC_PER_RAD

TEMPLATE = 'certificate.html.j2'
"""The certificate's Jinja2 HTML (package data beside this module): self-contained, no
script, no external resource, A4 print CSS."""

REJECTIONS_LISTED = 40
"""Rejection lines listed per method; the rest are counted in one line."""

CONTRADICTION_U = 1.0
"""A hand-off value further than this many combined standard uncertainties from what the
given bags give (the same estimator on the same data gives the same value) is not the bags'
result: the certificate is refused unless ``accept_handoff_values``. So is a stated u off by
more than :data:`CONTRADICTION_U_RATIO` either way."""

CONTRADICTION_U_RATIO = 2.0

INTERVALS = {'dither_axis_misalignment_rad': ('dither_axis_misalignment_lower_rad',
                                              'dither_axis_misalignment_upper_rad')}
"""Quantities whose method states an interval of its own (key → lower, upper key; an absent
upper end is unbounded): the dither misalignment a, at k = verdict_coverage_factor with the
rocking allowance as a bound — asymmetric, and the measured statement (METHODS §C)."""

FIXED_DECIMALS_MAX = 5
"""A standard uncertainty needing more decimals than this is printed in e-notation
(3.4e-9, not 0.0000000034)."""

RELATIVE_PPM_UNITS = ('″/pulse', 'counts/rad')
"""Quoted units of scale factors: their u is also given relative, in ppm."""


@dataclass(frozen=True, slots=True)
class QuantityRow:
    """One measured quantity on the certificate (values in the quoted unit unless ``_si``).

    The text fields are as printed; ``k_value``, ``expanded_si`` and ``dof_value`` (ν, at
    most n − 1; None unknown) are the numbers; ``interval`` is the method's own interval (its
    row's U, in the quoted unit) and ``std_relative`` u/|value| in ppm for scale factors.
    """

    key: str
    method: str
    description: str
    unit: str
    value_si: float
    std_si: float
    factor: float
    value: str
    std: str
    n: str
    dof: str
    k: str
    expanded: str
    budget: tuple[tuple[str, str, str, str], ...]
    k_note: str
    limit: str = ''
    verdict: str = ''
    in_handoff: bool = True
    note: str = ''
    k_value: float | None = None
    expanded_si: float | None = None
    std_relative: str = ''
    interval: tuple[float, float] | None = None
    n_value: int | None = None
    dof_value: float | None = None
    channel: str = ''
    column: str = ''
    group: str = ''


@dataclass(frozen=True, slots=True)
class MethodSection:
    """A method's part of the certificate."""

    name: str
    title: str
    source: str
    created_utc: str
    span: str
    missing: tuple[tuple[str, str], ...]
    rejections: tuple[str, ...]
    rejections_more: int
    notices: tuple[str, ...]
    summary: tuple[str, ...]
    figures: tuple[tuple[str, str, str], ...]
    conditions: tuple[tuple[str, str], ...] = ()
    not_measurable: tuple[tuple[str, str], ...] = ()
    earlier: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Certificate:
    """Everything printed on one gyro's certificate."""

    gyro_id: str
    file_stem: str
    issued_utc: str
    software: str
    handoff_path: str
    calibrated_utc: str
    complete: bool
    rows: tuple[QuantityRow, ...]
    facts: tuple[tuple[str, str, str], ...]
    mappings: tuple[tuple[str, str, str], ...]
    methods: tuple[MethodSection, ...]
    bags: tuple[tuple[str, str, str, str], ...]
    settings: tuple[tuple[str, str, str, str], ...]
    latitude: str
    rule: str
    overall: str
    spec_source: str
    spec_missing: tuple[str, ...]
    evidence_note: str
    notes: tuple[str, ...] = field(default=())
    conventions: tuple[tuple[str, str], ...] = field(default=())
    issue: Issue | None = None
    customer: str = ''
    calibration_date: str = ''
    temperature: str = ''
    item: str = 'gyro'
    imu_conditions: tuple[tuple[str, str], ...] = field(default=())
    imu_matrix: str = ''

    @property
    def overall_class(self) -> str:
        """The CSS class of the unit's verdict (PASS, FAIL, CONDITIONAL, NOVERDICT)."""
        return overall_class(self.overall)


def _utc_now() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')


def _decimals(std: float) -> int | None:
    """Decimal places that show u to two significant digits (GUM 7.2.6), None: use e-notation."""
    if not std > 0 or not math.isfinite(std):
        return None
    d = 1 - math.floor(math.log10(std))
    return max(d, 0) if d <= 12 else None


def format_number(value: float, std: float) -> str:
    """``value`` rounded where its standard uncertainty ``std`` has its second digit."""
    if not math.isfinite(value):
        return str(value)
    d = _decimals(std)
    if d is None:
        return f'{value:.6g}' if std == 0 else f'{value:.4e}'
    return f'{value:.{d}f}'


def _e_notation(x: float, digits: int) -> str:
    """``x`` to ``digits`` significant digits as 3.4e-9 (no padded exponent)."""
    mantissa, exponent = f'{x:.{digits - 1}e}'.split('e')
    return f'{mantissa}e{int(exponent)}'


def format_uncertainty(x: float, std: float) -> str:
    """An uncertainty (u, or U with the u it was made from) as printed.

    Rounded where u has its second digit (GUM 7.2.6); where that is beyond
    :data:`FIXED_DECIMALS_MAX` decimals, in e-notation: u to two significant digits, U to
    three (3.4e-9, 1.45e-8).
    """
    d = _decimals(std)
    if d is not None and d <= FIXED_DECIMALS_MAX:
        return f'{x:.{d}f}'
    if not (x > 0 and math.isfinite(x)):
        return format_number(x, std)
    return _e_notation(x, 2 if x == std else 3)


def _generic_values(values: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Every uncertain quantity of the hand-off, read generically.

    Key → {'value', 'std', 'n', 'dof'} of every uncertain quantity of the hand-off, read
    generically: scalar keys with ``_std`` (and ``_n``, ``_dof`` where present) twins, or a
    mapping with 'value' and 'std'.
    """
    out: dict[str, dict[str, Any]] = {}
    for key, value in values.items():
        if isinstance(value, Mapping) and 'value' in value and 'std' in value:
            out[key] = dict(value)
        elif (key + '_std') in values and not isinstance(value, (Mapping, list, str, bool)):
            out[key] = {'value': value, 'std': values[key + '_std'],
                        'n': values.get(key + '_n'), 'dof': values.get(key + '_dof')}
    return out


def _refuse_unstated_uncertainty(generic: Mapping[str, Mapping[str, Any]],
                                 values: Mapping[str, Any], handoff_path: str) -> None:
    """A certified value needs a positive, finite standard uncertainty (issue 35 §3).

    A hand-edited ``<key>_std: 0`` (or a mapping's ``std`` 0, absent or not a number) would
    be certified with U = 0, ν = ∞ and a budget share "nan %".

    Raises:
        ConfigError: naming the first such key, its u as written, and what to do.
    """
    for key, entry in generic.items():
        std = entry.get('std')
        if (isinstance(std, (int, float)) and not isinstance(std, bool)
                and math.isfinite(std) and std > 0):
            continue
        name = f'gyro.{key}_std' if key + '_std' in values else f'gyro.{key}.std'
        raise ConfigError(f'the hand-off file {handoff_path or "given"} states {name} = {std!r}: '
                          'a value is certified only with a positive, finite standard '
                          'uncertainty (0 would certify it with U = 0); nothing written. '
                          'Give the file as the calibration wrote it, or calibrate again.')


def _source_of(calibration: Calibration, key: str,
               schema: Mapping[str, HandoffKey]) -> Any:
    """The run a value came from, where the hand-off records it (format 3), else None."""
    source_of = getattr(calibration, 'source_of', None)
    return source_of(key, schema) if source_of is not None and key in schema else None


def _twin(key: str, values: Mapping[str, Any]) -> bool:
    for suffix in ('_std', '_n', '_dof'):
        if key.endswith(suffix) and key[:-len(suffix)] in values:
            return True
    return False


def _quantity_row(key: str, method: str, description: str, value_si: float, std_si: float,
                  est_n: int | None, budget: tuple[BudgetLine, ...], spec: Spec | None,
                  in_handoff: bool, note: str = '', dof_given: float | None = None,
                  interval_si: tuple[float, float] | None = None,
                  dof_widening: float = 1.0) -> QuantityRow:
    """One row: k from the run's budget, else the hand-off's ν, else 2 (said in the row).

    ``dof_widening``: the Student t for 68 % the run's budget says the hand-off's u was
    widened by (1: not, or not known: k₉₅(ν) on u, never an understatement).
    """
    unit = user_unit(key)
    notes = [note] if note else []
    if not budget and dof_given is not None:
        budget = (BudgetLine('degrees of freedom stated in the hand-off file', std_si,
                             float(dof_given), dof_widening),)
    elif not budget:
        notes.append('k = 2 assumed: the hand-off file states no degrees of freedom for this '
                     'value (written before gyro_calib recorded them) and no bag gave them')
    exp: Expanded = expanded_uncertainty(std_si, budget, est_n)
    f = unit.factor
    u = std_si * f
    std_gum = std_si if exp.std_gum is None else exp.std_gum
    rows = tuple((budget_source(b), format_uncertainty(b.gum_std * f, b.gum_std * f),
                  format_dof(b.dof), f'{contribution_percent(b, std_gum):.1f} %')
                 for b in exp.budget)
    interval = None
    if interval_si is not None:
        interval = (interval_si[0] * f, interval_si[1] * f)
        notes.append('U: the method\'s own interval (k = verdict_coverage_factor, 2 by '
                     'default; rocking allowance as a bound); the verdict uses it')
    limit_text, verdict_text = '', ''
    if spec is not None and key in spec.limits:
        lim = spec.limits[key]
        limit_text = lim.text()
        verdict_text = (interval_verdict(lim, value_si * f, interval, spec.rule)
                        if interval is not None else
                        verdict(lim, value_si * f, u,
                                None if exp.expanded is None else exp.expanded * f, spec.rule))
    if interval is not None:  # one digit more than u: the ends are the statement
        ends = [format_uncertainty(x, u / 10) if math.isfinite(x) else '∞' for x in interval]
        expanded_text = f'[{ends[0]}, {ends[1]}]'
    else:
        expanded_text = ('—' if exp.expanded is None
                         else format_uncertainty(exp.expanded * f, u))
    relative = ''
    if unit.label in RELATIVE_PPM_UNITS and value_si != 0 and std_si > 0:
        ppm = 1e6 * std_si / abs(value_si)
        relative = f'{format_uncertainty(ppm, ppm)} ppm'
    return QuantityRow(
        key=key, method=method, description=description, unit=unit.label or unit.si,
        value_si=value_si, std_si=std_si, factor=f, value=format_number(value_si * f, u),
        std=format_uncertainty(u, u), n='—' if est_n is None else str(est_n),
        dof=format_dof(exp.dof), k='—' if exp.k is None or interval is not None
        else f'{exp.k:.2f}', expanded=expanded_text,
        budget=rows, k_note=exp.note, limit=limit_text, verdict=verdict_text,
        in_handoff=in_handoff, note='; '.join(notes),
        k_value=None if interval is not None else exp.k,
        expanded_si=None if interval is not None else exp.expanded,
        std_relative=relative, interval=interval, dof_value=exp.dof,
        n_value=None if est_n is None else int(est_n))


def _utc(stamp_ns: int, *, time_only: bool = False) -> str:
    moment = datetime.datetime.fromtimestamp(stamp_ns / 1e9, datetime.UTC)
    text = moment.strftime('%H:%M:%S.%f' if time_only else '%Y-%m-%d %H:%M:%S.%f')
    return text[:-3]


def _span_text(start_ns: int, end_ns: int) -> str:
    """A data span in UTC, the stamps' clock.

    E.g. '2026-01-01 00:00:00.000 → 00:04:39.998 UTC (279.998 s)' (the end's date only
    when it is another day). Stamps before 2000 (:data:`WALL_CLOCK_FROM_NS`: a simulation's
    or a monotonic clock, near 1970 as UTC) are no calendar dates and are given in seconds:
    'stamps 0.000 → 100.000 s (simulation or monotonic time, not calendar dates; 100.000 s)'.
    """
    if start_ns < WALL_CLOCK_FROM_NS:
        return (f'stamps {start_ns / 1e9:.3f} → {end_ns / 1e9:.3f} s (simulation or monotonic '
                f'time, not calendar dates; {(end_ns - start_ns) / 1e9:.3f} s)')
    same_day = start_ns // 86_400_000_000_000 == end_ns // 86_400_000_000_000
    return (f'{_utc(start_ns)} → {_utc(end_ns, time_only=same_day)} UTC '
            f'({(end_ns - start_ns) / 1e9:.3f} s)')


def _interval_of(key: str, values: Mapping[str, Any]) -> tuple[float, float] | None:
    """The method's own interval of ``key`` (SI), where the hand-off holds one."""
    if key not in INTERVALS or INTERVALS[key][0] not in values:
        return None
    lower, upper = INTERVALS[key]
    return float(values[lower]), float(values.get(upper, math.inf))


def _contradiction(key: str, value: float, std: float, est_value: float,
                   est_std: float) -> tuple[float, str]:
    """(combined u between, what is wrong) of a hand-off value against the bags' ('' if fine)."""
    spread = math.hypot(std, est_std)
    z = abs(value - est_value) / spread if spread > 0 else (
        0.0 if value == est_value else math.inf)
    unit = user_unit(key)
    f, label = unit.factor, unit.label or unit.si
    if z > CONTRADICTION_U:
        return z, (f'gyro.{key} = {value * f:.10g} {label} but the bags give '
                   f'{est_value * f:.10g} ± {est_std * f:.2g} {label}: {z:.3g} combined '
                   'standard uncertainties apart')
    if 0 < est_std < math.inf and not (1 / CONTRADICTION_U_RATIO <= std / est_std
                                       <= CONTRADICTION_U_RATIO):
        return std / est_std, (f'gyro.{key}_std = {std * f:.3g} {label} but the bags give u = '
                               f'{est_std * f:.3g} {label}: {std / est_std:.3g} times theirs')
    return 0.0, ''


def build_certificate(calibration: Calibration, evidence: RunEvidence | None = None,
                      spec: Spec | None = None, *, handoff_path: str = '',
                      schema: Mapping[str, HandoffKey] | None = None,
                      issue: Issue | None = None, customer: str = '',
                      accept_handoff_values: bool = False) -> Certificate:
    """The certificate of one gyro.

    Args:
        calibration: the hand-off file's content (its values are the certificate's values).
        evidence: what the run knows (None: the hand-off alone; ν is then the file's
            ``<key>_dof``, or k = 2 is assumed and the row says so).
        spec: limits and decision rule (None: no verdicts, and the certificate says so).
        handoff_path: the hand-off file, as named on the certificate.
        schema: the hand-off keys (default: every registered method's).
        issue: the laboratory, number and customer (:mod:`gyro_calib.report.lab`); None: a
            draft, not issued by a laboratory.
        customer: the customer a draft names (an issue names its own).
        accept_handoff_values: certify a hand-off value the bags contradict as it stands
            (the row says what the bags give) instead of refusing.

    Raises:
        ConfigError: the hand-off holds no measured value; a hand-off value (or its u) is
            contradicted by the bags (:data:`CONTRADICTION_U`) and not accepted.
    """
    refuse_unknown_imu_channels(spec, calibration.imu.channels if calibration.imu is not None
                                else None, handoff_path)
    imu_measured = calibration.imu is not None and bool(imu_quantities(calibration.imu))
    if not calibration.values and calibration.imu is not None and not imu_measured:
        raise ConfigError(f'the hand-off file {handoff_path or "given"} holds an imu: section '
                          'with no measured quantity (no K, sense axis, bias or noise term): '
                          'there is nothing to certify; calibrate the triad first.')
    if not calibration.values and not imu_measured:
        raise ConfigError(f'the hand-off file {handoff_path or "given"} holds no measured value '
                          '(gyro: is empty): there is nothing to certify; calibrate the gyro '
                          'first.')
    sch = handoff_schema() if schema is None else schema
    order = {k: i for i, k in enumerate(sch)}
    ev_methods = {m.method: m for m in (evidence.methods if evidence else ())}
    estimates = {k: (m, e) for m in ev_methods.values() for k, e in m.estimates.items()}
    values = dict(calibration.values)
    generic = _generic_values(values)
    _refuse_unstated_uncertainty(generic, values, handoff_path)
    rows: list[QuantityRow] = []
    notes: list[str] = []
    contradicted: list[tuple[float, str]] = []
    for key in sorted(generic, key=lambda k: (order.get(k, len(order)), k)):
        entry = generic[key]
        value, std = float(entry['value']), float(entry['std'])
        spec_key = sch.get(key)
        method = spec_key.method if spec_key else '?'
        description = spec_key.description if spec_key else 'key not known to this gyro_calib'
        est_n: int | None = entry.get('n')
        budget: tuple[BudgetLine, ...] = ()
        note = ''
        run = _source_of(calibration, key, sch)
        latest = calibration.methods.get(method)
        if run is not None and latest is not None and run is not latest:
            note = f'kept from an earlier run: {run.source} ({run.created_utc})'
        if key in estimates and not note:
            m, est = estimates[key]
            same = (math.isclose(est.value, value, rel_tol=1e-9, abs_tol=0.0)
                    and math.isclose(est.std_uncertainty, std, rel_tol=1e-9, abs_tol=0.0))
            z, wrong = _contradiction(key, value, std, est.value, est.std_uncertainty)
            if same:
                budget = m.budgets.get(key, ())
                est_n = est.n_used if est_n is None else est_n
            elif wrong:
                contradicted.append((z, wrong))
                note = (f'{wrong}; certified as the hand-off file states it '
                        '(--accept-handoff-values): degrees of freedom not taken from the bags')
                notes.append(f'{key}: {note}.')
            else:
                note = (f'the data given give {est.value:.10g} ± {est.std_uncertainty:.3g} '
                        '(SI), within the hand-off\'s u of its value: degrees of freedom not '
                        'taken from them')
                notes.append(f'{key}: {note}.')
        rows.append(_quantity_row(key, method, description, value, std, est_n, budget, spec,
                                  True, note, entry.get('dof'), _interval_of(key, values)))
    imu_estimates: set[str] = set()  # the run's imu.* estimates the IMU's rows compared
    if calibration.imu is not None:
        rows.extend(_imu_rows(calibration, ev_methods, spec, sch, contradicted, notes,
                              imu_estimates))
    if contradicted and not accept_handoff_values:
        worst = max(contradicted, key=lambda c: c[0])[1]
        more = f' (and {len(contradicted) - 1} more value(s))' if len(contradicted) > 1 else ''
        raise ConfigError(f'the hand-off file {handoff_path or "given"} is contradicted by the '
                          f'bags given: {worst}{more}; nothing written. Give the bags it was '
                          'calibrated from (with its settings), or --accept-handoff-values to '
                          'certify the file\'s values as they stand.')
    for key, (m, est) in sorted(estimates.items(), key=lambda kv: (kv[1][0].method, kv[0])):
        if key in generic or key in imu_estimates or key.startswith('imu.fitted.'):
            continue  # an IMU's are its rows above; a fitted bench parameter its conditions
        if is_imu_key(key):
            notes.append(f'{key}: the bags given measure it ({est.value:.6g} ± '
                         f'{est.std_uncertainty:.2g}, SI) but the hand-off file\'s imu: section '
                         'does not hold it: not certified.')
            continue
        rows.append(_quantity_row(key, m.method, 'measured by the session; not a hand-off key',
                                  est.value, est.std_uncertainty, est.n_used,
                                  m.budgets.get(key, ()), spec, False))
    facts, mappings = [], []
    for key, value in values.items():
        if key in generic or _twin(key, values):
            continue
        spec_key = sch.get(key)
        description = spec_key.description if spec_key else ''
        if isinstance(value, Mapping):
            mappings.append((key, description, yaml.safe_dump(dict(value), sort_keys=False,
                                                              allow_unicode=True, width=96)))
        else:
            unit = user_unit(key)
            shown = (f'{float(value) * unit.factor:.6g} {unit.label}'.strip()
                     if isinstance(value, float) else str(value))
            facts.append((key, shown, description))
    rule, verdict_all, spec_missing, spec_source = '', '', [], ''
    if spec is not None:
        rule, spec_source = spec.rule_text, spec.source
        judged = {r.key: r.verdict for r in rows if r.verdict}
        groups = {r.group for r in rows if r.verdict and r.group}
        not_measured: list[str] = []
        for key in spec.limits:
            if key in judged or key in groups:
                continue
            if is_imu_key(key):
                if calibration.imu is None:
                    spec_missing.append(f'{key} ({spec.limits[key].text()}): not applicable — '
                                        'this unit has no imu: section (not a triad)')
                    continue
                imu = calibration.imu
                why = next((v for k, v in {**imu.missing, **imu.not_measurable}.items()
                            if k in key), 'not in the hand-off file\'s imu: section')
                spec_missing.append(f'{key} ({spec.limits[key].text()}): {NOT_MEASURED} — '
                                    f'{why}')
                not_measured.append(key)
                continue
            owner = sch[key].method if key in sch else ''
            if owner not in calibration.methods:  # the spec covers other methods too
                spec_missing.append(f'{key} ({spec.limits[key].text()}): not applicable — '
                                    f'method {owner or "?"} did not run for this gyro')
                continue
            why = (calibration.missing.get(key) or calibration.not_measurable.get(key)
                   or 'not in the hand-off file')
            spec_missing.append(f'{key} ({spec.limits[key].text()}): {NOT_MEASURED} — {why}')
            not_measured.append(key)
        verdict_all = overall(list(judged.values()), not_measured)
    sections = []
    for name, prov in calibration.methods.items():
        ev: MethodEvidence | None = ev_methods.get(name)
        missing = {k: v for k, v in prov.missing.items() if k not in values}
        rejections = ev.rejections if ev else ()
        earlier = tuple(
            f'{run.source} ({run.created_utc}): kept for '
            + ', '.join(k for k in (getattr(run, 'keys', None) or ()) if k in values)
            for run in getattr(prov, 'earlier', ()) or ())
        sections.append(MethodSection(
            name=name, title=METHODS[name].title if name in METHODS else name,
            source=prov.source, created_utc=prov.created_utc,
            span=_span_text(prov.data_start_stamp_ns, prov.data_end_stamp_ns),
            missing=tuple(missing.items()), rejections=rejections[:REJECTIONS_LISTED],
            rejections_more=max(len(rejections) - REJECTIONS_LISTED, 0),
            notices=ev.notices if ev else (), summary=ev.summary if ev else (),
            figures=tuple((name_, caption, 'data:image/png;base64,'
                           + base64.b64encode(png).decode('ascii'))
                          for name_, caption, png in _figures(ev, prov)),
            conditions=tuple((str(k), str(v))
                             for k, v in (getattr(prov, 'conditions', {}) or {}).items()),
            not_measurable=tuple((k, v) for k, v in (getattr(prov, 'not_measurable', {})
                                                     or {}).items() if k not in values),
            earlier=earlier))
    bags = tuple((b.path, name, digest, f'{_span_text(b.start_ns, b.end_ns)}, {b.messages} msgs')
                 for b in (evidence.bags if evidence else ()) for name, digest in b.files)
    settings = tuple((s.method, s.name, s.value, s.origin)
                     for s in (evidence.settings if evidence else ()))
    lats = [s for s in (evidence.settings if evidence else ()) if s.name == 'latitude_deg']
    known = sorted({f'{s.value} ({s.origin})' for s in lats if s.value != '—'})
    triad_prov = calibration.methods.get('triad')
    if not known and triad_prov is not None and 'latitude_deg' in triad_prov.conditions:
        known = [f'{triad_prov.conditions["latitude_deg"]} ° (the triad run\'s conditions in '
                 'the hand-off file)']
    latitude = ('; '.join(known) if known
                else 'not known: no bias was separated from the Earth rate' if lats
                else 'not recorded in the hand-off file (give the bags to see the settings)')
    created = sorted(p.created_utc for p in calibration.methods.values())
    stem = certificate_stem(calibration.gyro_id, handoff_path)
    calculated = ' … '.join(dict.fromkeys([created[0], created[-1]])) if created else '?'
    when = (calibration_date([(b.start_ns, b.end_ns) for b in evidence.bags], calculated)
            if evidence else calibration_date(
                [(p.data_start_stamp_ns, p.data_end_stamp_ns)
                 for p in calibration.methods.values()], calculated,
                'the data the hand-off file records'))
    return Certificate(
        gyro_id=calibration.gyro_id or '(no gyro id given)', file_stem=stem,
        issued_utc=issue.issued_utc if issue else _utc_now(),
        software=f'gyro_calib {__version__} (hand-off written by '
        f'{calibration.gyro_calib_version or "?"})', handoff_path=handoff_path,
        calibrated_utc=' … '.join(dict.fromkeys([created[0], created[-1]])) if created else '',
        complete=calibration.complete and not (calibration.imu is not None
                                               and calibration.imu.missing),
        rows=tuple(rows), facts=tuple(facts),
        mappings=tuple(mappings), methods=tuple(sections), bags=bags, settings=settings,
        latitude=latitude, rule=rule, overall=verdict_all, spec_source=spec_source,
        spec_missing=tuple(spec_missing),
        evidence_note='' if evidence else (
            'No bag was given: budgets, rejections, figures (but the noise curves the '
            'hand-off file stores) and input hashes are not known to this certificate; k '
            'rests on the degrees of freedom the hand-off file states, and where it states '
            'none k = 2 is assumed, as the row says.'),
        notes=tuple(notes), conventions=_conventions(), issue=issue,
        customer=issue.customer if issue else customer, calibration_date=when,
        temperature=temperature_text(evidence.bags if evidence else (), evidence is not None),
        item='IMU' if calibration.imu is not None and not calibration.values else 'gyro',
        imu_conditions=_imu_conditions(calibration, ev_methods.get('triad')),
        imu_matrix='' if calibration.imu is None else matrix_text(calibration.imu))


def _budget_rows(lines: tuple[BudgetLine, ...], std_si: float,
                 factor: float) -> tuple[tuple[str, str, str, str], ...]:
    """A budget as printed: source, u in the quoted unit, ν, share of u²."""
    std_gum = math.sqrt(sum(b.gum_std ** 2 for b in lines)) or std_si
    return tuple((budget_source(b), format_uncertainty(b.gum_std * factor, b.gum_std * factor),
                  format_dof(b.dof), f'{contribution_percent(b, std_gum):.1f} %')
                 for b in sorted(lines, key=lambda b: -b.gum_std))


def _imu_rows(calibration: Calibration, ev_methods: Mapping[str, MethodEvidence],
              spec: Spec | None, sch: Mapping[str, HandoffKey],
              contradicted: list[tuple[float, str]], notes: list[str],
              compared: set[str]) -> list[QuantityRow]:
    """The rows of an IMU (:mod:`gyro_calib.report.imu`): the hand-off's values and ν.

    With the bags, K_i and b (and the noise terms) are compared with the run's as a gyro's
    values are (a contradiction is appended to ``contradicted``); the budget shown is the
    run's per source (METHODS §F eq. (12)), each component of a sense axis taking its
    source's share of the axis's. k is always from the hand-off's ν (the run's where the
    hand-off states none), so a quantity has one ν on the certificate and in the file. The
    run's estimates compared are added to ``compared``.
    """
    imu = calibration.imu
    assert imu is not None

    def noise_what(term: str) -> str:
        return sch[term].description if term in sch else term

    rows: list[QuantityRow] = []
    for q in imu_quantities(imu, noise_what):
        method = 'noise' if q.key.startswith('imu.noise.') else 'triad'
        ev = ev_methods.get(method)
        est_key = q.estimate or (q.key if method == 'noise' else '')
        est = ev.estimates.get(est_key) if ev is not None and est_key else None
        if est is not None:
            compared.add(est_key)
        notes_q = [q.note] if q.note else []
        dof, n = q.dof, None
        lines: tuple[BudgetLine, ...] = ()
        if est is not None:
            same = (math.isclose(est.value, q.value, rel_tol=1e-9, abs_tol=0.0)
                    and math.isclose(est.std_uncertainty, q.std, rel_tol=1e-9, abs_tol=0.0))
            z, wrong = _contradiction(q.key, q.value, q.std, est.value, est.std_uncertainty)
            if same:
                n = est.n_used
                dof = float(est.supported_dof) if dof is None else dof
                lines = ev.budgets.get(est_key, ()) if ev is not None else ()
            elif wrong:
                contradicted.append((z, wrong))
                notes_q.append(f'{wrong}; certified as the hand-off file states it '
                               '(--accept-handoff-values)')
                notes.append(f'{q.key}: {notes_q[-1]}.')
            else:
                notes_q.append(f'the data given give {est.value:.10g} ± '
                               f'{est.std_uncertainty:.3g} (SI), within the hand-off\'s u of '
                               'its value: no budget taken from them')
                notes.append(f'{q.key}: {notes_q[-1]}.')
        elif q.budget and ev is not None and q.channel:
            k_est = ev.estimates.get(f'imu.{q.channel}.scale_factor_rad_per_pulse')
            k_value = imu.scale_factor_rad_per_pulse
            index = imu.channels.index(q.channel)
            if k_est is not None and k_value is not None and math.isclose(
                    k_est.value, float(k_value[index]), rel_tol=1e-9, abs_tol=0.0):
                n = k_est.n_used  # the same row fit
                dof = float(k_est.supported_dof) if dof is None else dof
                run_lines = ev.budgets.get(q.budget, ())
                widening = {b.source: b.widening for b in run_lines}
                lines = tuple(BudgetLine(source, u, nu, widening[source])
                              for source, u, nu in budget_shares(
                                  q.std, tuple((b.source, b.std, b.dof) for b in run_lines)))
        limit = limit_for(spec.limits, q.key) if spec is not None else None
        row_spec = (None if spec is None or limit is None
                    else dataclasses.replace(spec, limits={q.key: limit}))
        # the run's lines, where widened by Student t for 68 %, unwiden the hand-off's u alike
        stated = math.sqrt(sum(b.std ** 2 for b in lines))
        unwidened = math.sqrt(sum(b.gum_std ** 2 for b in lines))
        row = _quantity_row(q.key, method, q.description, q.value, q.std, n, (), row_spec,
                            True, '; '.join(notes_q), dof,
                            dof_widening=stated / unwidened if unwidened > 0 else 1.0)
        if lines:
            split = ('the run\'s sources (METHODS §F eq. (12))' if method == 'triad'
                     and not q.key.startswith('imu.bias_') else 'the run\'s')
            nu = ('ν as the hand-off states it' if q.dof is not None
                  else 'ν the run\'s (the hand-off states none)')
            row = dataclasses.replace(row, budget=_budget_rows(lines, q.std, row.factor),
                                      k_note=f'{row.k_note}; budget: {split}; {nu}')
        rows.append(dataclasses.replace(row, channel=q.channel, column=q.column,
                                        group=imu_group(q.key)))
    return rows


def _imu_conditions(calibration: Calibration,
                    triad: MethodEvidence | None) -> tuple[tuple[str, str], ...]:
    """What an IMU's values rest on: procedure, pairs and stations, tilt α, latitude, F."""
    imu = calibration.imu
    if imu is None:
        return ()
    prov = calibration.methods.get('triad')
    cond: Mapping[str, Any] = (getattr(prov, 'conditions', None) or {}) if prov else {}
    multiposition = calibration.methods.get('multiposition')
    out = [('channels', ', '.join(imu.channels) + ' (rows of M, in this order)'),
           ('procedure', procedure_text(cond) if prov else
            'multiposition: the IMU turned by hand through static poses, no table '
            f'(docs/methods.md §G; run on {multiposition.source})'
            if multiposition is not None else
            'not recorded: no triad or multiposition run in the hand-off file')]
    out.append(('pairs and stations', triad.summary[0] if triad is not None and triad.summary
                else 'none: a multiposition calibration has static poses, no table'
                if prov is None and multiposition is not None
                else 'not known: the hand-off file does not record them; give the bags'))
    if cond.get('mount_axis'):
        out.append(('tilt α', 'none: the remount procedure uses the single-axis table only'))
    elif 'tilt_deg' in cond:
        stated = (f'{float(cond["tilt_deg"]):.6g}° ± {float(cond.get("tilt_std_arcsec", 0)):.3g}″'
                  ' (stated)')
        fitted = triad.estimates.get('imu.fitted.tilt α') if triad is not None else None
        if fitted is not None:
            total = float(cond['tilt_deg']) + math.degrees(fitted.value)
            stated += (f'; fitted: {fitted.value * ARCSEC_PER_RAD:+.4f}″ ± '
                       f'{fitted.std_uncertainty * ARCSEC_PER_RAD:.2g}″ → α = {total:.6f}°')
        else:
            stated += ('; fitted value: not known (the hand-off file does not keep it; give '
                       'the bags)')
        out.append(('tilt α', stated))
    lat = cond.get('latitude_deg')
    out.append(('latitude', f'{lat}° (the Earth rate along each direction removed from the '
                'biases; heading ' + f'{cond.get("heading_deg", 0.0)}°)' if lat is not None
                else 'not given: the biases were not separated from the Earth rate'))
    f = np.asarray(imu.fixture_rotation, dtype=float)
    out.append(('fixture F (v_B = F·v_T)', '; '.join(
        '[' + ', '.join(f'{v:.6g}' for v in row) + ']' for row in f)))
    for key, why in {**imu.missing, **imu.not_measurable}.items():
        out.append((f'not measured: imu.{key}', why))
    for key, value in noise_bounds(imu):
        unit = user_unit(key.removesuffix('_upper_bound_2sigma'))
        out.append((key, f'≤ {value * unit.factor:.3g} {unit.label} (2σ upper bound: the fit '
                    'did not resolve the term)'))
    return tuple(out)


def _figures(ev: MethodEvidence | None, prov: Any) -> list[tuple[str, str, bytes]]:
    """The method's figures: drawn by its session, or its stored curves without a bag."""
    if ev is not None:
        return [(f.name, f.caption, f.png) for f in ev.figures]
    tables = getattr(prov, 'deviations', None) or {}
    if not tables:
        return []
    from gyro_calib.report.deviation_figure import CAPTION, deviation_figure_png

    png = deviation_figure_png(tables)
    return [('stored_deviations', CAPTION, png)] if png else []


def _conventions() -> tuple[tuple[str, str], ...]:
    """What every number of the hand-off file is.

    What every number of the hand-off file is (its ``conventions``), where the loader
    states them.
    """
    from gyro_calib import handoff

    return tuple((str(k), str(v)) for k, v in getattr(handoff, 'CONVENTIONS', {}).items())


def _file_stem(name: str) -> str:
    """A file name stem from a gyro id (characters other than letters, digits, ._- → _)."""
    return re.sub(r'[^A-Za-z0-9._-]', '_', name).strip('.') or 'gyro'


def certificate_stem(gyro_id: str | None, handoff_path: str = '') -> str:
    """The certificate's file stem: the gyro id, else the hand-off file's stem."""
    return _file_stem(gyro_id or Path(handoff_path).stem or 'gyro')


_NUMBER_CELL = re.compile(r'<td id="certificate-number">([^<]*)</td>')


def number_cell(html_text: str) -> str | None:
    """A certificate's number cell, unescaped ('none: …' on a draft); None if it has none."""
    found = _NUMBER_CELL.search(html_text)
    return unescape(found.group(1)).strip() if found else None


def replacing(out_dir: Path, stem: str, *, pdf: bool = True, flag: str = '--out') -> list[str]:
    """What writing ``<stem>.html`` (and ``.pdf``) into ``out_dir`` replaces: one line each.

    A draft (its number cell says "none: …") may be replaced by another run's certificate;
    its PDF goes with it (replaced, or removed under ``--no-pdf`` so that no draft PDF of
    another run stays beside the new HTML).

    Raises:
        ConfigError: ``<stem>.html`` is an issued certificate (it carries a certificate
            number: never replaced, nor mixed with another run's files), is not a
            certificate, or ``<stem>.pdf`` is there without its HTML (whether it is issued
            cannot be told).
    """
    html, pdf_path = out_dir / f'{stem}.html', out_dir / f'{stem}.pdf'
    away = (f'give another {flag} DIR, or move {html.name} and {pdf_path.name} out of '
            f'{out_dir} first')
    if not html.exists():
        if pdf_path.exists():
            raise ConfigError(f'{pdf_path} is there without its {html.name}, so whether it is '
                              f'an issued certificate cannot be told; {away}.')
        return []
    try:
        number = number_cell(html.read_text(encoding='utf-8', errors='replace'))
    except OSError as exc:
        raise ConfigError(f'{html} cannot be read ({exc.strerror}); {away}.') from None
    if number is None:
        raise ConfigError(f'{html} is not a certificate of gyro_calib (it has no certificate-'
                          f'number cell) and is not replaced; {away}.')
    if not number.startswith('none'):
        raise ConfigError(f'{html} is the issued certificate {number}: an issued certificate '
                          f'is never replaced nor mixed with another run\'s files; {away}.')
    lines = [f'replaced the draft {html} of an earlier run']
    if pdf_path.exists():
        lines.append(f'replaced its {pdf_path}' if pdf else
                     f'removed its {pdf_path} (--no-pdf: it would not match the new HTML)')
    return lines


def with_issue(cert: Certificate, issue: Issue) -> Certificate:
    """``cert`` issued under ``issue`` (its number, customer and date of issue)."""
    return dataclasses.replace(cert, issue=issue, customer=issue.customer,
                               issued_utc=issue.issued_utc)


def render_html(cert: Certificate) -> str:
    """The certificate as one self-contained HTML document (no external resource)."""
    return str(_template().render(c=cert))


@functools.cache
def _template() -> Any:
    """The certificate's Jinja template, compiled once per process.

    A batch worker renders one certificate per gyro; compiling the template took about a
    tenth of a second of each.
    """
    import jinja2

    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    env.filters['css'] = _css_string
    return env.from_string(
        resources.files('gyro_calib.report').joinpath(TEMPLATE).read_text('utf-8'))


def _css_string(text: Any) -> Any:
    """Text for a CSS string in the page's ``<style>`` (no HTML escaping applies there)."""
    import markupsafe

    return markupsafe.Markup(''.join(c if c.isalnum() or c in ' .,:;/_-—()' else
                                     f'\\{ord(c):x} ' for c in str(text)))


def render_pdf(html: str) -> bytes:
    """The certificate's PDF (WeasyPrint; A4 from the page CSS)."""
    import logging

    from weasyprint import HTML

    logging.getLogger('weasyprint').setLevel(logging.ERROR)
    logging.getLogger('fontTools').setLevel(logging.ERROR)
    return bytes(HTML(string=html).write_pdf())


def write_certificate(cert: Certificate, out_dir: Path, *, pdf: bool = True) -> list[Path]:
    """Write ``<out_dir>/<stem>.html`` (and ``.pdf``): both, or neither.

    Both documents are rendered, then written whole beside their targets, before either is
    put in place (:func:`~gyro_calib.outputs.write_all_or_none`): a disk that fills at the
    PDF leaves no HTML carrying a certificate number said to be unused (issue 35 §3).
    ``out_dir``, when this call creates it, goes again if a write fails before anything is
    in it.
    """
    html = render_html(cert)
    documents = [(out_dir / f'{cert.file_stem}.html', html.encode('utf-8'))]
    if pdf:
        documents.append((out_dir / f'{cert.file_stem}.pdf', render_pdf(html)))
    created = not out_dir.exists()
    out_dir.mkdir(exist_ok=True)  # checked before any work; parents are never created
    try:
        written = write_all_or_none(documents)
    except BaseException:
        if created and not any(out_dir.iterdir()):
            out_dir.rmdir()
        raise
    stale = out_dir / f'{cert.file_stem}.pdf'
    if not pdf and stale.exists():  # a draft's (see :func:`replacing`): it would not match
        stale.unlink()
    return written


def certificate_record(cert: Certificate) -> dict[str, Any]:
    """The certificate's quantities as plain data (the fleet files are made of these)."""
    return {
        'gyro_id': cert.gyro_id, 'overall': cert.overall, 'rule': cert.rule, 'item': cert.item,
        'certificate_number': cert.issue.number if cert.issue else None,
        'complete': cert.complete,
        'quantities': [{'key': r.key, 'method': r.method, 'unit': r.unit,
                        'value': r.value_si * r.factor, 'std': r.std_si * r.factor,
                        'k': r.k_value, 'U': (None if r.expanded_si is None
                                              else r.expanded_si * r.factor),
                        'interval': None if r.interval is None else list(r.interval),
                        'n': r.n, 'dof': r.dof, 'limit': r.limit, 'verdict': r.verdict,
                        'value_si': r.value_si, 'std_si': r.std_si, 'in_handoff': r.in_handoff,
                        'U_si': r.expanded_si, 'n_value': r.n_value, 'dof_value': r.dof_value,
                        **({'channel': r.channel, 'column': r.column, 'group': r.group}
                           if r.channel or r.group else {})}
                       for r in cert.rows],
        'not_measured': list(cert.spec_missing),
    }
