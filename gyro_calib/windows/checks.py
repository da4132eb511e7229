"""Why a window is rejected: the table not at constant rate, the pulse stream not trustworthy.

The rejection lines of a candidate window (METHODS §A.2 window rules): :func:`rate_problem`
checks joint_states over the window and its fit margins (gaps, reversal, rate excursion),
:func:`pulse_stream_problem` the pulse counts inside it (gaps, jumps). Each returns the
sentence for the rejection, '' when the window passes.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.windows.settings import WindowSettings


def span(t_ns: npt.NDArray[np.int64], lo_ns: int, hi_ns: int) -> slice:
    """The samples of sorted ``t_ns`` within [lo_ns, hi_ns]."""
    return slice(int(np.searchsorted(t_ns, lo_ns, 'left')),
                 int(np.searchsorted(t_ns, hi_ns, 'right')))


def rate_problem(
    table_t_ns: npt.NDArray[np.int64],
    rate: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    margins_ns: tuple[int, int],
    cfg: WindowSettings,
) -> str:
    """Why the table was not at constant rate over the window and its fit margins.

    '' if it was.
    """
    lo_ns, hi_ns = start_ns - margins_ns[0], end_ns + margins_ns[1]
    sl = span(table_t_ns, lo_ns, hi_ns)
    t, r = table_t_ns[sl], rate[sl]
    if len(t) < 2:
        return 'no joint_states inside the window.'
    edges = np.concatenate(([lo_ns], t, [hi_ns]))
    steps = np.diff(edges)
    worst = int(np.argmax(steps))
    gap = float(steps[worst]) / NS_PER_S
    if gap > cfg.max_table_gap_s:
        return (f'gap of {gap:.3f} s in joint_states inside the window, from '
                f'{format_stamp(int(edges[worst]))} (limit {cfg.max_table_gap_s:g} s): constant '
                'rate cannot be checked.')
    flips = np.nonzero(np.sign(r) != np.sign(r[0]))[0]
    if len(flips):
        return ('the table changed direction inside the window, at '
                f'{format_stamp(int(t[flips[0]]))}.')
    med = float(np.median(r))
    rel = np.abs(r - med) / abs(med)
    worst = int(np.argmax(rel))
    if rel[worst] > cfg.rate_tolerance:
        return (f'rate excursion: the table rate was {math.degrees(float(r[worst])):.3f} °/s at '
                f'{format_stamp(int(t[worst]))}, {rel[worst] * 100:.3f} % from its window median '
                f'{math.degrees(med):.3f} °/s (rate_tolerance {cfg.rate_tolerance * 100:g} %).')
    return ''


def pulse_stream_problem(
    pulse_t_ns: npt.NDArray[np.int64],
    counts: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    cfg: WindowSettings,
) -> str:
    """Why the pulse counts inside the window cannot be trusted ('' if they can)."""
    sl = span(pulse_t_ns, start_ns, end_ns)
    t, n = pulse_t_ns[sl], counts[sl]
    if len(t) < 2:
        return 'no pulse samples inside the window.'
    dt = np.diff(t).astype(np.float64) / NS_PER_S
    worst_gap = int(np.argmax(dt))
    gap = float(dt[worst_gap])
    if gap > cfg.max_pulse_gap_s:
        return (f'gap of {gap:.3f} s in the pulse stream inside the window, from '
                f'{format_stamp(int(t[worst_gap]))} (limit {cfg.max_pulse_gap_s:g} s).')
    dn = np.diff(n)
    rate = float(np.median(dn / dt))
    expected = rate * dt
    excess = np.abs(dn - expected) - (cfg.rate_tolerance * np.abs(expected)
                                      + cfg.pulse_jump_tolerance_pulses)
    worst = int(np.argmax(excess))
    if excess[worst] > 0:
        return (f'pulse count jumped by {dn[worst] - expected[worst]:+.0f} pulses against the '
                f'window rate at {format_stamp(int(t[worst + 1]))} (counts going backwards or a '
                f'glitch).')
    return ''

