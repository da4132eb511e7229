"""The Allan figure of a certificate drawn from the hand-off file alone (no bag given).

A noise run keeps its curves in the hand-off file (``methods.<name>.deviations``,
:data:`gyro_calib.handoff.DEVIATION_FIELDS`): per axis the averaging times and the ADEV,
MDEV, HDEV and TOTDEV with their standard uncertainties. Without the bag a certificate
cannot redraw the method's own figure (the fit and each term's τ range live in the session),
but it can show the measured curves the terms rest on: one log-log panel per axis, the ADEV
with its ±1σ bars and the other deviations as markers.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

CAPTION = ('Allan (ADEV, ±1σ from its EDF), modified (MDEV), Hadamard (HDEV) and total '
           '(TOTDEV) deviation per τ, as stored in the hand-off file (METHODS §E); no bag was '
           'given, so the fitted terms and the τ range each rests on are not drawn')
"""The figure's caption."""

_MARKERS = {'mdev': ('v', 'tab:blue'), 'hdev': ('^', 'tab:green'),
            'totdev': ('s', '0.35')}


def _column(table: Mapping[str, Any], name: str) -> np.ndarray:
    values = table.get(name)
    if not isinstance(values, list):
        return np.full(len(table['tau_s']), np.nan)
    return np.array([math.nan if v is None else float(v) for v in values])


def deviation_figure_png(tables: Mapping[str, Mapping[str, Any]]) -> bytes:
    """PNG bytes of one log-log panel per axis of ``tables`` (empty bytes: nothing to draw).

    Args:
        tables: ``methods.noise.deviations`` of a hand-off file, axis → table.
    """
    axes = [(axis, t) for axis, t in tables.items() if isinstance(t.get('tau_s'), list)
            and len(t['tau_s'])]
    if not axes:
        return b''
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    cols = min(3, len(axes))
    rows = math.ceil(len(axes) / cols)
    fig, grid = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), squeeze=False)
    try:
        for k, (axis, table) in enumerate(axes):
            ax = grid[k // cols][k % cols]
            tau = _column(table, 'tau_s')
            adev, std = _column(table, 'adev'), _column(table, 'adev_std')
            ok = np.isfinite(adev) & (adev > 0)
            ax.errorbar(tau[ok], adev[ok], yerr=np.nan_to_num(std[ok]), fmt='o', ms=3,
                        color='black', elinewidth=0.7, capsize=0, label='ADEV')
            for name, (marker, colour) in _MARKERS.items():
                dev = _column(table, name)
                shown = np.isfinite(dev) & (dev > 0)
                if np.any(shown):
                    ax.plot(tau[shown], dev[shown], marker, ms=3, mfc='none', color=colour,
                            label=name.upper())
            ax.set_xscale('log')
            ax.set_yscale('log')
            ax.set_xlabel('τ (s)')
            ax.set_ylabel(f'deviation ({table.get("unit", "")})')
            ax.set_title(axis)
            ax.grid(True, which='both', lw=0.3, alpha=0.5)
            ax.legend(fontsize=7)
        for k in range(len(axes), rows * cols):
            grid[k // cols][k % cols].set_visible(False)
        fig.tight_layout()
        buffer = io.BytesIO()
        fig.savefig(buffer, format='png', dpi=110)
        return buffer.getvalue()
    finally:
        plt.close(fig)
