"""Coning drift caused by the dither-axis misalignment (METHODS §C, eq. 24, and beyond).

The misalignment tilts the cavity's principal axes, so the dither torque rocks the cavity
transversely at Ω_d: θ_xz(t) = θ_xz,max·sin Ω_d·t about case Y and θ_xy(t) =
θ_xy,max·sin(Ω_d·t + φ) about case Z. Two same-frequency rotations with a phase offset cone:

    ε₂₄ = ½·Ω_d·θ_xz,max·θ_xy,max·sin φ                                     (24)

The exact kinematics shows a second term of the same order (METHODS §C): the dither itself
(about DI ≈ X, amplitude θ_d) and θ_xy cone about case Y at ½·Ω_d·θ_d·θ_xy,max·sin φ, and
the gyro sees that drift's projection on IA, whose Y component is a·sin ψ₀ — the component
the table along Z measures:

    ε_dr = ½·Ω_d·θ_d·θ_xy,max·sin φ·a·|sin ψ₀|

(checked against the mean drift of the exact composed rotation in
``test/test_dither_coning.py``; the two terms add or cancel with the unknown sense of the
rocking, so the total here is their worst-case sum |ε₂₄| + |ε_dr|).

Rocking models: ``'proportional'`` (the paper's): θ_xz,max = θ_xy,max = k·a, ε₂₄ ∝ a²;
``'components'`` (physical): θ_xz,max = k·a·|cos ψ₀| (from the XZ-plane tilt, which the table
along Y measures), θ_xy,max = k·a·|sin ψ₀|, so ε₂₄ ∝ a²·|sin 2ψ₀|/2, at most half of the
proportional figure. k defaults to the paper's 1″ at 35′.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

PAPER_ROCKING_PER_MISALIGNMENT = 1.0 / 2100.0
"""k: 1″ of rocking at a = 35′ (paper, METHODS §C), rad per rad."""


@dataclass(frozen=True, slots=True)
class ConingDrift:
    """Coning drift of one gyro, rad/s (magnitudes; worst case unless φ was given).

    Attributes:
        eq24_rad_s: ½·Ω_d·θ_xz,max·θ_xy,max·|sin φ|.
        dither_rocking_rad_s: ½·Ω_d·θ_d·θ_xy,max·|sin φ|·a·|sin ψ₀| (NaN without θ_d in rad).
        rocking_xz_rad: θ_xz,max used.
        rocking_xy_rad: θ_xy,max used.
        sin_phi: |sin φ| used (1 = worst case).
    """

    eq24_rad_s: float
    dither_rocking_rad_s: float
    rocking_xz_rad: float
    rocking_xy_rad: float
    sin_phi: float

    @property
    def total_rad_s(self) -> float:
        """|ε₂₄| + |ε_dr|, the worst-case sum, rad/s (NaN if ε_dr is unknown)."""
        return self.eq24_rad_s + self.dither_rocking_rad_s


def rocking_amplitudes_rad(misalignment_z_rad: float, misalignment_y_rad: float, *,
                           rocking_per_misalignment: float = PAPER_ROCKING_PER_MISALIGNMENT,
                           model: str = 'proportional') -> tuple[float, float]:
    """(θ_xz,max, θ_xy,max) from the two components a·|sin ψ₀| (Z) and a·|cos ψ₀| (Y), rad."""
    k = rocking_per_misalignment
    if model == 'proportional':
        a = math.hypot(misalignment_z_rad, misalignment_y_rad)
        return k * a, k * a
    if model == 'components':
        return k * abs(misalignment_y_rad), k * abs(misalignment_z_rad)
    raise ValueError(f"model must be 'proportional' or 'components', got {model!r}")


def coning_drift(misalignment_z_rad: float, misalignment_y_rad: float, *,
                 dither_frequency_hz: float, dither_amplitude_rad: float = math.nan,
                 rocking_per_misalignment: float = PAPER_ROCKING_PER_MISALIGNMENT,
                 rocking_phase_rad: float = math.nan,
                 model: str = 'proportional') -> ConingDrift:
    """Eq. (24) and the dither × rocking coning from the measured components (module doc).

    Args:
        misalignment_z_rad: a·|sin ψ₀|, rad.
        misalignment_y_rad: a·|cos ψ₀|, rad.
        dither_frequency_hz: Ω_d/2π, Hz.
        dither_amplitude_rad: θ_d, rad (NaN: the dither × rocking term is NaN).
        rocking_per_misalignment: k, rad per rad.
        rocking_phase_rad: φ, rad (NaN: worst case sin φ = 1).
        model: ``'proportional'`` or ``'components'``.
    """
    u, w = rocking_amplitudes_rad(misalignment_z_rad, misalignment_y_rad,
                                  rocking_per_misalignment=rocking_per_misalignment, model=model)
    sin_phi = 1.0 if math.isnan(rocking_phase_rad) else abs(math.sin(rocking_phase_rad))
    wd = 2 * math.pi * dither_frequency_hz
    eq24 = 0.5 * wd * u * w * sin_phi
    dr = 0.5 * wd * dither_amplitude_rad * w * sin_phi * abs(misalignment_z_rad)
    return ConingDrift(eq24, dr, u, w, sin_phi)


def coning_eq24_from_misalignment_rad_s(misalignment_rad: float, *, dither_frequency_hz: float,
                                        rocking_per_misalignment: float =
                                        PAPER_ROCKING_PER_MISALIGNMENT,
                                        rocking_phase_rad: float = math.pi / 2) -> float:
    """ε of eq. (24) under the paper's proportional model: ½·Ω_d·(k·a)²·|sin φ|, rad/s."""
    ka = rocking_per_misalignment * misalignment_rad
    return 0.5 * 2 * math.pi * dither_frequency_hz * ka * ka * abs(math.sin(rocking_phase_rad))
