"""Figure of a triad calibration (``gyro-calib calibrate --method triad --plot DIR``), Agg.

* ``triad_pairs.png``: for each channel, every forward/reverse pair's residual of eq. (8),
  ΔN_i − 2φ·(u·r_i) with u corrected by the fitted tilt α, in units of its predicted
  standard uncertainty u(ΔN_i), against the pair's order, one marker per direction (inner
  axis, each station); pairs rejected for a channel are listed in its title (METHODS §F).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.triad.kinematics import TILT

if TYPE_CHECKING:
    from gyro_calib.triad.records import TriadPair, TriadResult

FIGURE_NAME = 'triad_pairs.png'


def plot_triad(result: TriadResult | None, pairs: list[tuple[TriadPair, str]],
               out_dir: Path) -> list[Path]:
    """Write the triad figure when the rows are solved into ``out_dir``; return its path."""
    if result is None or not pairs or all(c.row_pulse_per_rad is None for c in result.channels):
        return []
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    tilt = result.parameters.get(TILT)
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True)
    labels = sorted({label for _, label in pairs}, key=[lb for _, lb in pairs].index)
    for c, (ax, channel) in enumerate(zip(axes, result.channels, strict=True)):
        ax.axhline(0.0, color='k', lw=0.8)
        ax.grid(alpha=0.3)
        ax.set_ylabel(f'{channel.name}: residual / u(ΔN)')
        if channel.row_pulse_per_rad is None:
            ax.set_title(f'channel {channel.name}: not measurable ({channel.not_measurable})',
                         fontsize=8)
            continue
        row = np.array([e.value for e in channel.row_pulse_per_rad])
        for m, label in enumerate(labels):
            index, residual = [], []
            for k, (pair, lab) in enumerate(pairs):
                if lab != label or pair.rejected[c]:
                    continue
                u = pair.direction
                if tilt is not None and pair.direction_sensitivity is not None:
                    u = u + pair.direction_sensitivity[:, 0] * tilt.value
                    u = u / np.linalg.norm(u)
                predicted = 2 * pair.swept_angle_rad * float(u @ row)
                index.append(k)
                residual.append((pair.count_difference[c] - predicted)
                                / pair.count_difference_std[c])
            if index:
                ax.plot(index, residual, 'os^vD<>ph*'[m % 10], label=label)
        rejected = sum(1 for pair, _ in pairs if pair.rejected[c])
        k_i = channel.scale_factor_rad_per_pulse
        head = (f'channel {channel.name}: K = {k_i.value:.9e} ± {k_i.std_uncertainty:.1e} '
                'rad/pulse' if k_i is not None else f'channel {channel.name}')
        ax.set_title(head + (f'; {rejected} pair(s) rejected' if rejected else ''), fontsize=8)
        ax.legend(fontsize=7, loc='best')
    axes[-1].set_xlabel('pair, in the order recorded')
    fig.suptitle(f'triad: residuals of each pair (docs/methods.md §F eq. (8)); Birge ratio '
                 f'{result.birge_ratio:.2f}', fontsize=9)
    fig.tight_layout()
    path = out_dir / FIGURE_NAME
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
