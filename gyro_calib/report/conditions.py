"""The conditions and dates a certificate states (ISO/IEC 17025:2017 7.8.2.1 i, 7.8.4.1 b).

The environmental conditions are what the bags record: the gyro's temperature sensors
(``/gyro/temperature``), when recorded, and the site latitude the methods used (the Earth
rate a bias rests on). The date of calibration is when the data were taken — the bags'
recording span (or the data span the hand-off file records) — when their clock is UTC wall
time; a simulated or monotonic clock (stamps before 2000) is named as such, with the date the
results were calculated.
"""

from __future__ import annotations

import datetime
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gyro_calib.report.evidence import BagInput

WALL_CLOCK_FROM_NS = 946_684_800 * 10**9
"""2000-01-01T00:00:00Z: stamps before it are not taken for UTC wall time."""


def _utc_date(t_ns: int) -> str:
    return datetime.datetime.fromtimestamp(t_ns / 1e9, datetime.UTC).strftime('%Y-%m-%d')


def calibration_date(spans_ns: Sequence[tuple[int, int]], calculated: str,
                     what: str = 'the bags\' recording') -> str:
    """The date(s) the data were taken, from their spans (first, last stamp in ns)."""
    if not spans_ns:
        return f'not known from the data; results calculated {calculated}'
    start, end = min(s for s, _ in spans_ns), max(e for _, e in spans_ns)
    if start < WALL_CLOCK_FROM_NS:
        return (f'not known: {what} runs on a simulated or monotonic clock (starting at '
                f't = {start / 1e9:.3f} s), not UTC; results calculated {calculated}')
    first, last = _utc_date(start), _utc_date(end)
    return f'{first}{"" if first == last else " … " + last} (UTC, {what})'


def temperature_text(bags: Sequence[BagInput], bags_given: bool) -> str:
    """The gyro temperatures the bags record, per sensor, over all bags."""
    if not bags_given:
        return 'not known: no bag was given to the report'
    per: dict[str, list[tuple[float, float, float, int]]] = {}
    for bag in bags:
        for name, low, mean, high, count in bag.temperature:
            per.setdefault(name, []).append((low, mean, high, count))
    if not per:
        return 'not recorded in the bags (no /gyro/temperature)'
    parts = []
    for name, rows in per.items():
        n = sum(r[3] for r in rows)
        mean = sum(r[1] * r[3] for r in rows) / n
        parts.append(f'{name} {min(r[0] for r in rows):.2f} °C … {max(r[2] for r in rows):.2f} '
                     f'°C (mean {mean:.2f} °C, {n} readings)')
    return '; '.join(parts) + ' — recorded on /gyro/temperature'
