"""The fleet files: ``fleet.csv``, ``fleet.parquet``, ``fleet.jsonl`` and ``fleet.html``.

One row per gyro and quantity in CSV and Parquet: value, std and U in SI under the SI unit of
the hand-off key (column ``unit``), the same in the certificate's unit beside them
(``display_*``), k, n and ν as numbers, the limits as printed and as numbers (SI and display),
the verdict, the gyro's overall verdict and input hashes; an IMU (a triad) has one row per
channel instead (:data:`IMU_COLUMNS`: K, misalignments, axis angle, non-orthogonality, bias and
ARW in SI with u, ν and verdicts; docs/certificates_imu.md). One JSON record per gyro (limits,
verdicts, inputs, settings, status and reason), as production test records are kept for
MES/SPC. An HTML page with each quantity's distribution across the fleet against its limits,
yield, mean, spread (sample standard deviation), Cpk = min(USL − μ, μ − LSL)/(3σ), each gyro's
deviation from the fleet mean and the outliers, linked to their certificates. A failed gyro has
one row with its reason; after an interrupted run every gyro that did not finish has one row
``not run (interrupted)`` and every file says the run was interrupted.
"""

from __future__ import annotations

import csv
import hashlib
import html
import io
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.report.imu import FLEET_COLUMNS
from gyro_calib.report.spec import limit_for

IMU_COLUMNS = ('channel', 'imu_non_orthogonality_with', *(
    f'imu_{q}{part}' for q in FLEET_COLUMNS for part in ('', '_std', '_dof', '_verdict')))
"""An IMU's channel row: the channel, then each quantity of
:data:`gyro_calib.report.imu.FLEET_COLUMNS` as ``imu_<quantity>`` (SI value), ``_std``,
``_dof`` (ν, integer) and ``_verdict``; ``imu_non_orthogonality_with`` names the channel the
row's non-orthogonality is to."""

COLUMNS = ('gyro_id', 'status', 'overall', 'key', 'method', 'unit', 'value', 'std', 'k', 'U',
           'n', 'dof', 'limit', 'verdict', 'in_handoff', 'inputs_sha256', 'reason',
           'lsl', 'usl', 'display_unit', 'display_value', 'display_std', 'display_U',
           'display_lsl', 'display_usl', 'fleet_run', 'replaces', *IMU_COLUMNS, 'this_run')
"""The columns of fleet.csv and fleet.parquet (new ones appended, old ones in place).

``replaces``: the number of the issued certificate this gyro's certificate replaced ('' none).
``this_run``: what this run did with the gyro (:func:`this_run`) — ``calibrated``,
``skipped (unchanged)``, ``failed: …``, ``refused: …`` or ``not run (interrupted)``; a gyro
this run left alone keeps the row of what its folder holds (``status`` … ``replaces`` as the
earlier run wrote them) and its ``this_run`` ends ``; earlier results kept``.
A gyro has one row per quantity (``key`` … ``display_usl``); an IMU one row per channel
(:data:`IMU_COLUMNS`; ``key`` empty, ``method`` triad), its quantities beyond those columns
(the other noise terms) in fleet.jsonl and on the fleet page.
"""

FLOAT_COLUMNS = frozenset({'value', 'std', 'k', 'U', 'lsl', 'usl', 'display_value',
                           'display_std', 'display_U', 'display_lsl', 'display_usl',
                           *(f'imu_{q}{part}' for q in FLEET_COLUMNS for part in ('', '_std'))})
INT_COLUMNS = frozenset({'n', 'dof', *(f'imu_{q}_dof' for q in FLEET_COLUMNS)})
QUANTITY_FIELDS = ('key', 'method', 'unit', 'value', 'std', 'U', 'k', 'n', 'dof', 'limit',
                   'lsl', 'usl', 'verdict', 'in_handoff', 'display_unit', 'display_value',
                   'display_std', 'display_U', 'display_lsl', 'display_usl')
"""A quantity as the fleet files keep it (fleet.jsonl, each gyro's record.json)."""

COMPLETE, INTERRUPTED = 'complete', 'interrupted'
"""The values of ``fleet_run``: the run finished, or was stopped with gyros not run."""

CALIBRATED, SKIPPED, KEPT = 'calibrated', 'skipped (unchanged)', '; earlier results kept'
"""``this_run`` of a gyro calibrated by this run, of one skipped as unchanged, and the ending
of the ``this_run`` of a gyro whose row is the earlier run's (its folder left as it was)."""

OUTLIER_ROBUST_Z = 3.5
OUTLIER_MIN_N = 5
"""Outliers are named only among at least this many gyros."""
OPEN_MAX = 12
"""Each gyro's values of a quantity are shown open on the page up to this many gyros."""
OUTLIER_OWN_K = 2.0
"""A value within this many of its own standard uncertainties of the median is no outlier."""


def inputs_digest(record: dict[str, Any]) -> str:
    """One SHA-256 over every input file's hash of a gyro (the full list is in fleet.jsonl)."""
    items = sorted((bag, name, digest) for bag, files in record.get('inputs', {}).items()
                   for name, digest in files)
    return hashlib.sha256(json.dumps(items).encode()).hexdigest() if items else ''


def _finite(x: Any) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) \
        and math.isfinite(x) else None


def _count(number: Any, text: Any) -> int | None:
    """A count (n, ν) as an integer: ν truncated (GUM G.6.4); None when unknown or infinite."""
    x = _finite(number)
    if x is None and number is None and isinstance(text, str):  # a record of an older run
        try:
            x = _finite(float(text))
        except ValueError:
            x = None
    return None if x is None else int(math.floor(x))


def spc_quantity(q: Mapping[str, Any], limit: Any = None) -> dict[str, Any]:
    """One certificate quantity as the fleet files keep it.

    ``value``/``std``/``U``/``lsl``/``usl`` in SI under ``unit`` (the hand-off key's SI
    unit), the same in the certificate's unit under ``display_*``, ``n`` and ``dof`` as
    integers (None: unknown; ``dof`` None with a k also means infinite), the limits as
    printed in ``limit``. ``value_si``/``std_si`` stay for readers of the older layout. A
    quantity already in this form is returned unchanged; one in the older form (``value``
    in the certificate's unit) is converted.

    Args:
        q: the quantity, as :func:`gyro_calib.report.certificate.certificate_record` gives
            it (or as an earlier run stored it).
        limit: the spec's :class:`~gyro_calib.report.spec.Limit` of the key (its bounds
            in the certificate's unit), or None.
    """
    if 'display_unit' in q:
        return dict(q)
    from gyro_calib.report.units import user_unit

    unit = user_unit(str(q['key']))
    f = unit.factor
    value = _finite(q.get('value_si'))
    value = value if value is not None or _finite(q.get('value')) is None \
        else float(q['value']) / f
    std = _finite(q.get('std_si'))
    std = std if std is not None or _finite(q.get('std')) is None else float(q['std']) / f
    big_u = _finite(q.get('U_si'))
    big_u = big_u if big_u is not None or _finite(q.get('U')) is None else float(q['U']) / f
    judged = limit is not None and bool(q.get('limit'))
    low = _finite(getattr(limit, 'low', None)) if judged else None
    high = _finite(getattr(limit, 'high', None)) if judged else None

    def shown(x: float | None) -> float | None:
        return None if x is None else x * f

    return {'key': q['key'], 'method': q.get('method'), 'unit': unit.si,
            'value': value, 'std': std, 'U': big_u, 'k': _finite(q.get('k')),
            'n': _count(q.get('n_value'), q.get('n')),
            'dof': _count(q.get('dof_value'), q.get('dof')),
            'limit': q.get('limit') or '',
            'lsl': None if low is None else low / f, 'usl': None if high is None else high / f,
            'verdict': q.get('verdict') or '', 'in_handoff': q.get('in_handoff'),
            'display_unit': unit.label or unit.si, 'display_value': shown(value),
            'display_std': shown(std), 'display_U': shown(big_u), 'display_lsl': low,
            'display_usl': high, 'value_si': value, 'std_si': std,
            **{k: q[k] for k in ('channel', 'column', 'group') if q.get(k)}}


def fleet_record(record: Mapping[str, Any], spec_limits: Mapping[str, Any] | None = None,
                 fleet_run: str = COMPLETE) -> dict[str, Any]:
    """A gyro's record with its certificate quantities in the fleet form (:func:`spc_quantity`)."""
    out = dict(record)
    cert = out.get('certificate')
    if cert:
        limits = spec_limits or {}
        out['certificate'] = {**cert, 'quantities': [
            spc_quantity(q, limit_for(limits, str(q.get('key'))))
            for q in cert.get('quantities') or []]}
    out['fleet_run'] = fleet_run
    return out


def fleet_rows(records: Sequence[dict[str, Any]], spec_limits: Mapping[str, Any] | None = None,
               fleet_run: str = COMPLETE) -> list[dict[str, Any]]:
    """The rows of fleet.csv / fleet.parquet."""
    rows = []
    for raw in records:
        rec = fleet_record(raw, spec_limits, fleet_run)
        cert = rec.get('certificate') or {}
        common = {'gyro_id': rec['gyro_id'], 'status': rec.get('status', ''),
                  'overall': cert.get('overall', ''), 'inputs_sha256': inputs_digest(rec),
                  'reason': rec.get('reason', ''), 'fleet_run': fleet_run,
                  'replaces': rec.get('replaces', ''), 'this_run': rec.get('this_run', '')}
        quantities = cert.get('quantities') or []
        if not quantities:
            rows.append({c: common.get(c) for c in COLUMNS})
        channels: dict[str, list[dict[str, Any]]] = {}
        for q in quantities:
            if q.get('channel'):
                channels.setdefault(q['channel'], []).append(q)
                continue
            rows.append({**{c: common.get(c) for c in COLUMNS},
                         **{c: q.get(c) for c in QUANTITY_FIELDS if c in COLUMNS}})
        rows.extend(channel_row(common, channel, qs) for channel, qs in channels.items())
    return rows


def channel_row(common: Mapping[str, Any], channel: str,
                quantities: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """An IMU's row of one channel (:data:`IMU_COLUMNS`), its quantities in SI."""
    row: dict[str, Any] = {**{c: common.get(c) for c in COLUMNS}, 'method': 'triad',
                           'channel': channel}
    for q in quantities:
        column = q.get('column')
        if column not in FLEET_COLUMNS:
            continue
        name = f'imu_{column}'
        row.update({name: q.get('value'), f'{name}_std': q.get('std'),
                    f'{name}_dof': q.get('dof'), f'{name}_verdict': q.get('verdict') or ''})
        if column == 'non_orthogonality_rad':  # imu.<a>-<b>.non_orthogonality_rad
            pair = str(q['key']).split('.')[1]
            row['imu_non_orthogonality_with'] = pair[len(channel) + 1:]
    return row


def _atomic_write(path: Path, data: bytes) -> None:
    from gyro_calib.outputs import write_bytes_atomically

    write_bytes_atomically(path, data)


def write_fleet(records: Sequence[dict[str, Any]], out_dir: Path, *,
                spec_limits: dict[str, Any] | None = None,
                interrupted: bool = False) -> list[Path]:
    """Write the four fleet files into ``out_dir``, all of them or none; return their paths.

    Every file is rendered first, then all are written together
    (:func:`~gyro_calib.outputs.write_all_or_none`): a failure leaves the earlier four as
    they were, never a mix of two runs.

    Args:
        records: every gyro's record, in manifest order (a gyro not run has one too).
        out_dir: the output directory.
        spec_limits: the spec's limits by key (None: no spec).
        interrupted: the run was stopped before every gyro finished.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    run = INTERRUPTED if interrupted else COMPLETE
    rows = fleet_rows(records, spec_limits, run)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator='\n')
    writer.writeheader()
    writer.writerows(rows)
    paths = [out_dir / 'fleet.csv', out_dir / 'fleet.parquet', out_dir / 'fleet.jsonl',
             out_dir / 'fleet.html']
    schema = pa.schema([(c, pa.float64() if c in FLOAT_COLUMNS else pa.int64()
                         if c in INT_COLUMNS else pa.bool_() if c == 'in_handoff'
                         else pa.string()) for c in COLUMNS],
                       metadata={'gyro_calib.fleet_run': run})
    table = pa.Table.from_pylist(
        [{c: (None if r[c] is None else r[c] if c in FLOAT_COLUMNS | INT_COLUMNS
              or c == 'in_handoff' else str(r[c])) for c in COLUMNS} for r in rows],
        schema=schema)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    lines = [json.dumps(fleet_record(rec, spec_limits, run), sort_keys=True, allow_nan=False,
                        default=str) for rec in records]
    page = fleet_html(records, spec_limits or {}, interrupted=interrupted)
    from gyro_calib.outputs import write_all_or_none

    write_all_or_none([(paths[0], text.getvalue().encode('utf-8')),
                       (paths[1], sink.getvalue().to_pybytes()),
                       (paths[2], ('\n'.join(lines) + '\n').encode('utf-8')),
                       (paths[3], page.encode('utf-8'))])
    return paths


def quantity_stats(values: np.ndarray, low: float | None, high: float | None,
                   stds: np.ndarray | None = None) -> dict[str, Any]:
    """Mean, sample std, Cpk (None without a limit or spread) and outliers of one quantity.

    An outlier lies more than 3.5 robust standard deviations (1.4826·MAD) from the fleet
    median, among at least 5 gyros, and more than 2 of its own standard uncertainties
    ``stds`` from it: a gyro whose own u covers its distance from the median is not one.
    """
    n = int(values.size)
    mean = float(np.mean(values)) if n else math.nan
    sd = float(np.std(values, ddof=1)) if n > 1 else math.nan
    sides = [x for x in ((high - mean) if high is not None else None,
                         (mean - low) if low is not None else None) if x is not None]
    cpk = min(sides) / (3 * sd) if sides and n > 1 and sd > 0 else None
    med = float(np.median(values)) if n else math.nan
    mad = 1.4826 * float(np.median(np.abs(values - med))) if n else math.nan
    dist = np.abs(values - med)
    out = (dist > OUTLIER_ROBUST_Z * mad) if n >= OUTLIER_MIN_N else np.zeros(n, bool)
    if stds is not None:
        own = np.where(np.isfinite(stds), stds, 0.0)  # an unknown u covers nothing
        out &= dist > OUTLIER_OWN_K * own
    return {'n': n, 'mean': mean, 'std': sd, 'cpk': cpk, 'outliers': out, 'median': med}


def _svg_strip(values: np.ndarray, ids: list[str], low: float | None, high: float | None,
               unit: str, outliers: np.ndarray, decimals: int = 6) -> str:
    """A dot strip of the fleet's values with the limits (inline SVG; no script)."""
    width, height, pad = 520, 70, 30
    pts = list(values) + [x for x in (low, high) if x is not None]
    lo, hi = min(pts), max(pts)
    if hi == lo:
        half = abs(lo) * 0.01 or 1.0
        lo, hi = lo - half, hi + half
    span = hi - lo
    lo, hi = lo - 0.05 * span, hi + 0.05 * span

    def x(v: float) -> float:
        return float(pad + (v - lo) / (hi - lo) * (width - 2 * pad))

    parts = [(f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'role="img"><line x1="{pad}" y1="40" x2="{width - pad}" y2="40" stroke="#999"/>')]
    for limit, name in ((low, 'min'), (high, 'max')):
        if limit is not None:
            parts.append(f'<line x1="{x(limit):.1f}" y1="10" x2="{x(limit):.1f}" y2="55" '
                         f'stroke="#b00" stroke-width="2"/><text x="{x(limit):.1f}" y="9" '
                         f'font-size="9" text-anchor="middle" fill="#b00">{name} {limit:g}</text>')
    for i, (v, gid) in enumerate(zip(values, ids)):
        color = '#d60' if outliers[i] else '#1565c0'
        parts.append(f'<circle cx="{x(v):.1f}" cy="{34 + (i % 3) * 6}" r="3.5" fill="{color}" '
                     f'fill-opacity="0.7"><title>{html.escape(gid)}: {v:.{decimals}f} '
                     f'{html.escape(unit)}</title></circle>')
    parts.append(f'<text x="{pad}" y="68" font-size="9">{lo:.4g}</text><text x="{width - pad}" '
                 f'y="68" font-size="9" text-anchor="end">{hi:.4g} {html.escape(unit)}</text>'
                 '</svg>')
    return ''.join(parts)


def yield_text(records: Sequence[dict[str, Any]]) -> str:
    """The fleet's yield and what it counts (plain text).

    Yield = units PASS / units judged or failed: a gyro that could not be calibrated counts
    as not passing; a gyro not run (interrupted) is not counted, and the text says how many.
    """
    overall = [(r.get('certificate') or {}).get('overall', '') for r in records]
    judged = [o for o in overall if o]
    failed = sum(r.get('status') == 'failed' and not o for r, o in zip(records, overall))
    not_run = sum(r.get('status') == 'not run' for r in records)
    skipped = f' {not_run} not run (interrupted): not counted.' if not_run else ''
    if not judged:
        return 'No specification given: no verdicts, no yield.' + skipped
    counted = len(judged) + failed
    passed = judged.count('PASS')
    others = ', '.join(f'{judged.count(v)} {v}' for v in dict.fromkeys(judged) if v != 'PASS')
    return (f'Yield {100.0 * passed / counted:.1f} % = {passed} PASS of {counted} gyros judged '
            f'or failed ({len(judged)} judged: {passed} PASS' + (f', {others}' if others else '')
            + f'; {failed} failed to calibrate, counted as not passing).' + skipped)


def _decimals_for(spread: float, stds: np.ndarray) -> int:
    """Decimal places that show ``spread`` (or the smallest u, if no spread) to two digits."""
    scale = [x for x in (spread, *np.asarray(stds, float).tolist())
             if math.isfinite(x) and x > 0]
    if not scale:
        return 6
    return int(min(max(1 - math.floor(math.log10(min(scale))), 0), 15))


RELATIVE_SUFFIXES = ('_rad_per_pulse', '_counts_per_rad')
"""Scale factors (K̃, K): their spread and deviations are shown in ppm of the fleet mean."""


def _relative(key: str, mean: float) -> bool:
    """Deviations read in ppm of the mean: a scale factor with a finite mean ≠ 0."""
    return key.endswith(RELATIVE_SUFFIXES) and mean != 0 and math.isfinite(mean)


def fleet_html(records: Sequence[dict[str, Any]], spec_limits: dict[str, Any], *,
               interrupted: bool = False) -> str:
    """The fleet page: totals and yield, every gyro with its status, then each quantity."""
    esc = html.escape
    recs = [fleet_record(r, spec_limits, INTERRUPTED if interrupted else COMPLETE)
            for r in records]
    by_key: dict[str, list[tuple[str, str, dict[str, Any]]]] = {}
    for rec in recs:
        cert = rec.get('certificate') or {}
        for q in cert.get('quantities') or []:
            if q.get('display_value') is not None:
                by_key.setdefault(q['key'], []).append((rec['gyro_id'], rec.get('stem', ''), q))
    count = {s: sum(r.get('status') == s for r in recs)
             for s in ('ok', 'partial', 'failed', 'not run')}
    title = f'Fleet: {len(recs)} gyros'
    body = []
    if interrupted:
        title += f' — run interrupted, {count["not run"]} not run'
        body.append(f'<p class="interrupted" id="interrupted"><b>This run was interrupted</b>: '
                    f'{count["not run"]} of {len(recs)} gyros did not run (rows “not run '
                    '(interrupted)”); this is not a complete fleet. Run the same command '
                    'again to finish it (finished gyros are skipped).</p>')
    body.insert(0, f'<h1>{esc(title)}</h1>')
    body.append(f'<p id="totals">calibrated: {count["ok"]}; partly: {count["partial"]}; '
                f'failed: {count["failed"]}; not run: {count["not run"]}. '
                f'<span id="yield">{esc(yield_text(recs))}</span></p>')
    body.append(_gyro_table(recs))
    body.append('<h2>Quantities</h2>')
    for key in sorted(by_key):
        body.append(_quantity_section(key, by_key[key], limit_for(spec_limits, key)))
    style = ('body{font-family:"DejaVu Sans",Arial,sans-serif;font-size:10pt;max-width:1000px;'
             'margin:auto;background:#fff}table{border-collapse:collapse;margin:4px 0 10px}'
             'th,td{border:1px solid #bbb;padding:2px 5px;text-align:left}th{background:#eee}'
             'td.num{text-align:right;font-family:monospace}'
             'tr.failed td{background:#fde}tr.partial td{background:#fff3d6}'
             'tr.not.run td{color:#777}tr.outlier td{background:#ffe0c0}'
             '.interrupted{background:#fde;border:2px solid #b00;padding:6px}'
             'h3{margin:14px 0 2px;font-family:monospace}.unit{font-weight:normal}')
    return ('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>gyro_calib fleet'
            + (' (interrupted)' if interrupted else '')
            + f'</title><style>{style}</style></head><body>' + ''.join(body) + '</body></html>')


def _quantity_section(key: str, entries: list[tuple[str, str, dict[str, Any]]],
                      lim: Any) -> str:
    """One quantity across the fleet: strip, statistics, and each gyro's value and deviation."""
    esc = html.escape
    unit = entries[0][2].get('display_unit', '')
    values = np.array([e[2]['display_value'] for e in entries], float)
    stds = np.array([math.nan if e[2].get('display_std') is None else e[2]['display_std']
                     for e in entries], float)
    low = getattr(lim, 'low', None)
    high = getattr(lim, 'high', None)
    stats = quantity_stats(values, low, high, stds)
    verdicts = [e[2].get('verdict') for e in entries if e[2].get('verdict')]
    yield_q = (f'{100.0 * verdicts.count("PASS") / len(verdicts):.1f} % PASS of the '
               f'{len(verdicts)} judged on it ({verdicts.count("CONDITIONAL")} conditional, '
               f'{verdicts.count("FAIL")} fail)' if verdicts else 'no limits')
    cpk = '—' if stats['cpk'] is None else f'{stats["cpk"]:.2f}'
    d = _decimals_for(stats['std'], stds)
    relative = _relative(key, stats['mean'])
    ppm = 1e6 / abs(stats['mean']) if relative else math.nan
    d_ppm = _decimals_for(stats['std'] * ppm, stds * ppm) if relative else d
    spread = f'{stats["std"]:.{d}f}' if math.isfinite(stats['std']) else '— (one unit)'
    if relative and math.isfinite(stats['std']):
        spread += f' ({stats["std"] * ppm:.{d_ppm}f} ppm of the mean)'
    outliers = [e for e, o in zip(entries, stats['outliers']) if o]
    links = ', '.join(f'<a href="{esc(s)}/{esc(s)}.html">{esc(g)}</a> '
                      f'({q["display_value"]:.{d}f})' for g, s, q in outliers) or 'none'
    dev_head = 'deviation from the mean (ppm)' if relative else f'deviation from the mean ({unit})'
    rows = []
    for (gid, stem, q), v, u, out in zip(entries, values, stds, stats['outliers']):
        dev = v - stats['mean']
        dev_text = f'{dev * ppm:+.{d_ppm}f}' if relative else f'{dev:+.{d}f}'
        rows.append(f'<tr class="{"outlier" if out else ""}"><td><a href="{esc(stem)}/'
                    f'{esc(stem)}.html">{esc(gid)}</a></td><td class="num">{v:.{d}f}</td>'
                    f'<td class="num">{"—" if not math.isfinite(u) else f"{u:.2g}"}</td>'
                    f'<td class="num">{dev_text}</td><td>{esc(q.get("verdict") or "—")}</td>'
                    f'<td>{"yes" if out else ""}</td></tr>')
    return (f'<section class="quantity" data-key="{esc(key)}"><h3>{esc(key)} '
            f'<span class="unit">[{esc(unit)}]</span></h3>'
            + _svg_strip(values, [e[0] for e in entries], low, high, unit, stats['outliers'], d)
            + f'<table><tr><th>n</th><th>mean</th><th>spread (σ)</th><th>limits</th>'
            f'<th>yield</th><th>Cpk</th><th>outliers (beyond 3.5 robust σ of the median and '
            f'beyond 2u of their own)</th></tr><tr><td>{stats["n"]}</td>'
            f'<td class="num">{stats["mean"]:.{d}f}</td><td>{spread}</td>'
            f'<td>{esc(lim.text()) if lim is not None else "—"}</td><td>{yield_q}</td>'
            f'<td>{cpk}</td><td class="outliers">{links}</td></tr></table>'
            f'<details{" open" if stats["n"] <= OPEN_MAX else ""}><summary>each gyro '
            f'({stats["n"]})</summary><table class="values">'
            f'<tr><th>gyro</th><th>value ({esc(unit)})</th><th>u</th><th>{esc(dev_head)}</th>'
            f'<th>verdict</th><th>outlier</th></tr>' + ''.join(rows)
            + '</table></details></section>')


def _gyro_table(records: Sequence[dict[str, Any]]) -> str:
    """Every gyro with its status, verdict, certificate link and reason."""
    esc = html.escape
    body = [('<h2>Gyros</h2><table id="gyros"><tr><th>gyro</th><th>status</th>'
            '<th>verdict</th><th>certificate</th><th>reason</th></tr>')]
    for rec in records:
        stem = rec.get('stem', '')
        cert_link = (f'<a href="{esc(stem)}/{esc(stem)}.html">{esc(stem)}.html</a>'
                     if rec.get('certificate') else '—')
        body.append(f'<tr class="{esc(rec.get("status", ""))}"><td>{esc(rec["gyro_id"])}</td>'
                    f'<td>{esc(rec.get("status", ""))}</td>'
                    f'<td>{esc((rec.get("certificate") or {}).get("overall", "") or "—")}</td>'
                    f'<td>{cert_link}</td><td>{esc(rec.get("reason", ""))}'
                    + (f' (replaces the issued certificate {esc(rec["replaces"])})'
                       if rec.get('replaces') else '')
                    + (f' — this run: {esc(rec["this_run"])}' if rec.get('this_run')
                       and rec['this_run'] != CALIBRATED else '') + '</td></tr>')
    body.append('</table>')
    return ''.join(body)
