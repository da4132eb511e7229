"""The fleet files: ``fleet.csv``, ``fleet.parquet``, ``fleet.jsonl`` and ``fleet.html``.

One row per gyro and quantity (value, std, k, U in the quoted unit, n, ν, limits, verdict,
the gyro's overall verdict and input hashes) in CSV and Parquet; one JSON record per gyro
(limits, verdicts, inputs, settings, status and reason), as production test records are kept
for MES/SPC; and an HTML page with each quantity's distribution across the fleet against its
limits, yield, mean, spread (sample standard deviation), Cpk = min(USL − μ, μ − LSL)/(3σ) and
outliers (more than 3.5 robust standard deviations, 1.4826·MAD, from the median) linked to
their certificates. A failed gyro has one row with its reason.
"""

from __future__ import annotations

import csv
import hashlib
import html
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

COLUMNS = ('gyro_id', 'status', 'overall', 'key', 'method', 'unit', 'value', 'std', 'k', 'U',
           'n', 'dof', 'limit', 'verdict', 'in_handoff', 'inputs_sha256', 'reason')
"""The columns of fleet.csv and fleet.parquet."""

OUTLIER_ROBUST_Z = 3.5
OUTLIER_MIN_N = 5
"""Outliers are named only among at least this many gyros."""


def inputs_digest(record: dict[str, Any]) -> str:
    """One SHA-256 over every input file's hash of a gyro (the full list is in fleet.jsonl)."""
    items = sorted((bag, name, digest) for bag, files in record.get('inputs', {}).items()
                   for name, digest in files)
    return hashlib.sha256(json.dumps(items).encode()).hexdigest() if items else ''


def fleet_rows(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of fleet.csv / fleet.parquet."""
    rows = []
    for rec in records:
        cert = rec.get('certificate') or {}
        common = {'gyro_id': rec['gyro_id'], 'status': rec.get('status', ''),
                  'overall': cert.get('overall', ''), 'inputs_sha256': inputs_digest(rec),
                  'reason': rec.get('reason', '')}
        quantities = cert.get('quantities') or []
        if not quantities:
            rows.append({c: common.get(c) for c in COLUMNS})
        for q in quantities:
            rows.append({**{c: common.get(c) for c in COLUMNS},
                         **{c: q.get(c) for c in ('key', 'method', 'unit', 'value', 'std', 'k',
                                                   'U', 'n', 'dof', 'limit', 'verdict',
                                                   'in_handoff')}})
    return rows


def _atomic_write(path: Path, data: bytes) -> None:
    from gyro_calib.report.certificate import write_bytes_atomically

    write_bytes_atomically(path, data)


def write_fleet(records: Sequence[dict[str, Any]], out_dir: Path, *,
                spec_limits: dict[str, Any] | None = None) -> list[Path]:
    """Write the four fleet files into ``out_dir``; return their paths."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = fleet_rows(records)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator='\n')
    writer.writeheader()
    writer.writerows(rows)
    paths = [out_dir / 'fleet.csv', out_dir / 'fleet.parquet', out_dir / 'fleet.jsonl',
             out_dir / 'fleet.html']
    _atomic_write(paths[0], text.getvalue().encode('utf-8'))
    schema = pa.schema([(c, pa.float64() if c in ('value', 'std', 'k', 'U')
                         else pa.bool_() if c == 'in_handoff' else pa.string())
                        for c in COLUMNS])
    table = pa.Table.from_pylist(
        [{c: (None if r[c] is None else r[c] if c in ('value', 'std', 'k', 'U', 'in_handoff')
              else str(r[c])) for c in COLUMNS} for r in rows], schema=schema)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    _atomic_write(paths[1], sink.getvalue().to_pybytes())
    lines = [json.dumps({k: v for k, v in rec.items()}, sort_keys=True, allow_nan=False,
                        default=str) for rec in records]
    _atomic_write(paths[2], ('\n'.join(lines) + '\n').encode('utf-8'))
    _atomic_write(paths[3], fleet_html(records, spec_limits or {}).encode('utf-8'))
    return paths


def quantity_stats(values: np.ndarray, low: float | None, high: float | None) -> dict[str, Any]:
    """Mean, sample std, Cpk (None without a limit or spread) of one quantity's values."""
    n = int(values.size)
    mean = float(np.mean(values)) if n else math.nan
    sd = float(np.std(values, ddof=1)) if n > 1 else math.nan
    sides = [x for x in ((high - mean) if high is not None else None,
                         (mean - low) if low is not None else None) if x is not None]
    cpk = min(sides) / (3 * sd) if sides and n > 1 and sd > 0 else None
    med = float(np.median(values)) if n else math.nan
    mad = 1.4826 * float(np.median(np.abs(values - med))) if n else math.nan
    out = (np.abs(values - med) > OUTLIER_ROBUST_Z * mad) if n >= OUTLIER_MIN_N and mad > 0 \
        else np.zeros(n, bool)
    return {'n': n, 'mean': mean, 'std': sd, 'cpk': cpk, 'outliers': out}


def _svg_strip(values: np.ndarray, ids: list[str], low: float | None, high: float | None,
               unit: str, outliers: np.ndarray) -> str:
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
                     f'fill-opacity="0.7"><title>{html.escape(gid)}: {v:.6g} {html.escape(unit)}'
                     '</title></circle>')
    parts.append(f'<text x="{pad}" y="68" font-size="9">{lo:.4g}</text><text x="{width - pad}" '
                 f'y="68" font-size="9" text-anchor="end">{hi:.4g} {html.escape(unit)}</text>'
                 '</svg>')
    return ''.join(parts)


def fleet_html(records: Sequence[dict[str, Any]], spec_limits: dict[str, Any]) -> str:
    """The fleet page: one section per quantity, then every gyro with its status."""
    esc = html.escape
    by_key: dict[str, list[tuple[str, str, dict[str, Any]]]] = {}
    for rec in records:
        cert = rec.get('certificate') or {}
        for q in cert.get('quantities') or []:
            if q.get('value') is not None and math.isfinite(q['value']):
                by_key.setdefault(q['key'], []).append((rec['gyro_id'], rec.get('stem', ''), q))
    n_ok = sum(r.get('status') == 'ok' for r in records)
    overall = [(r.get('certificate') or {}).get('overall', '') for r in records]
    judged = [o for o in overall if o]
    partly = sum(r.get('status') == 'partial' for r in records)
    failed = sum(r.get('status') == 'failed' for r in records)
    body = [f'<h1>Fleet: {len(records)} gyros</h1>',
            f'<p>calibrated: {n_ok}; partly: {partly}; failed: {failed}.']
    if judged:
        body.append(f' Units PASS: {judged.count("PASS")}, CONDITIONAL: '
                    f'{judged.count("CONDITIONAL")}, FAIL: {judged.count("FAIL")}; yield '
                    f'(PASS of judged) {100.0 * judged.count("PASS") / len(judged):.1f} %.')
    else:
        body.append(' No specification given: no verdicts.')
    body.append('</p>')
    body.append(_gyro_table(records))
    body.append('<h2>Quantities</h2>')
    for key in sorted(by_key):
        entries = by_key[key]
        unit = entries[0][2].get('unit', '')
        values = np.array([e[2]['value'] for e in entries])
        lim = spec_limits.get(key)
        low = getattr(lim, 'low', None)
        high = getattr(lim, 'high', None)
        stats = quantity_stats(values, low, high)
        verdicts = [e[2].get('verdict') for e in entries if e[2].get('verdict')]
        yield_text = (f'{100.0 * verdicts.count("PASS") / len(verdicts):.1f} % PASS '
                      f'({verdicts.count("CONDITIONAL")} conditional, {verdicts.count("FAIL")} '
                      'fail)' if verdicts else 'no limits')
        cpk = '—' if stats['cpk'] is None else f'{stats["cpk"]:.2f}'
        spread = (f'{stats["std"]:.3g}' if math.isfinite(stats['std'])
                  else '— (one unit)')
        outliers = [e for e, o in zip(entries, stats['outliers']) if o]
        links = ', '.join(f'<a href="{esc(s)}/{esc(s)}.html">{esc(g)}</a> ({q["value"]:.6g})'
                          for g, s, q in outliers) or 'none'
        body.append(
            f'<section class="quantity" data-key="{esc(key)}"><h3>{esc(key)} '
            f'<span class="unit">[{esc(unit)}]</span></h3>'
            + _svg_strip(values, [e[0] for e in entries], low, high, unit, stats['outliers'])
            + f'<table><tr><th>n</th><th>mean</th><th>spread (σ)</th><th>limits</th>'
            f'<th>yield</th><th>Cpk</th><th>outliers</th></tr><tr><td>{stats["n"]}</td>'
            f'<td>{stats["mean"]:.6g}</td><td>{spread}</td>'
            f'<td>{esc(lim.text()) if lim is not None else "—"}</td><td>{yield_text}</td>'
            f'<td>{cpk}</td><td class="outliers">{links}</td></tr></table></section>')
    style = ('body{font-family:"DejaVu Sans",Arial,sans-serif;font-size:10pt;max-width:1000px;'
             'margin:auto;background:#fff}table{border-collapse:collapse;margin:4px 0 10px}'
             'th,td{border:1px solid #bbb;padding:2px 5px;text-align:left}th{background:#eee}'
             'tr.failed td{background:#fde}tr.partial td{background:#fff3d6}'
             'h3{margin:14px 0 2px;font-family:monospace}.unit{font-weight:normal}')
    return ('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>gyro_calib fleet'
            f'</title><style>{style}</style></head><body>' + ''.join(body) + '</body></html>')


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
                    f'<td>{cert_link}</td><td>{esc(rec.get("reason", ""))}</td></tr>')
    body.append('</table>')
    return ''.join(body)
