"""Error budgets of the RBRLG calibration (METHODS §A.2 eq. 5, §A.4 eq. 21).

Both are worst-case bounds (sums of magnitudes), as the paper writes them.
"""

from __future__ import annotations

import math

from gyro_calib.units import ARCSEC_PER_RAD, ARCSEC_PER_REV, RAD_PER_ARCSEC


def scale_factor_relative_error_bound(
    *, sync_and_drift_arcsec: float, revolutions_per_window: int,
    fix_error_angle_arcsec: float, fix_error_angle_error_arcsec: float,
) -> float:
    """Bound on |ΔK/K| by eq. (5): (P⁺ − P⁻)/(2592000·m) + |sin θ·Δθ| (dimensionless).

    Args:
        sync_and_drift_arcsec: P⁺ − P⁻, zero-index synchronisation error plus bias drift
            within the windows, ″.
        revolutions_per_window: m.
        fix_error_angle_arcsec: θ, ″.
        fix_error_angle_error_arcsec: Δθ, ″.
    """
    window = 2 * ARCSEC_PER_REV * revolutions_per_window
    theta = fix_error_angle_arcsec * RAD_PER_ARCSEC
    return (abs(sync_and_drift_arcsec) / window
            + abs(math.sin(theta) * fix_error_angle_error_arcsec * RAD_PER_ARCSEC))


def fix_error_angle_error_bound_arcsec(
    *, position_error_arcsec: float, position_table_revolutions: int, wobble_arcsec: float,
    station_error_arcsec: float, fix_error_angle_arcsec: float,
    mount_change_arcsec: float,
) -> float:
    """Bound on dθ by eq. (21), ″.

    dθ ≤ √2·(|Δφ_ON/(1296000·n)| + |Δα| + |sin θ·Δβ| + |Δθ|)

    From eqs. (19)–(20) with cot α = 1. The first term is a ratio of angles, i.e. a
    value in radians; it is turned into ″ here (the paper's 2″ at n = 1 gives 0.32″),
    which with the paper's figures (θ = 300″, Δφ_ON = 2″, Δθ = 1″, Δβ = 100″, Δα = 0.5″)
    gives 2.78″ < 4″ as the paper states.

    Args:
        position_error_arcsec: Δφ_ON, position-table positioning/synchronisation error, ″.
        position_table_revolutions: n.
        wobble_arcsec: Δα, wobble of the position-table axis, ″.
        station_error_arcsec: Δβ, rate-table station positioning error, ″.
        fix_error_angle_arcsec: θ, ″.
        mount_change_arcsec: Δθ, random change of θ while the rate table turns, ″.
    """
    theta = fix_error_angle_arcsec * RAD_PER_ARCSEC
    position_term_arcsec = (abs(position_error_arcsec)
                            / (ARCSEC_PER_REV * position_table_revolutions) * ARCSEC_PER_RAD)
    return math.sqrt(2) * (position_term_arcsec
                           + abs(wobble_arcsec)
                           + abs(math.sin(theta) * station_error_arcsec)
                           + abs(mount_change_arcsec))
