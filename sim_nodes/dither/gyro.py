"""Mechanically dithered RLG with a dither-axis misalignment (pure physics, METHODS §C).

The cavity is dithered about DI by φ(t) = θ_d·sin(Ω_d·t + φ₀); IA sits at the misalignment
a from DI at azimuth ψ₀; DI is tilted from case X by b₀. The misalignment makes the
cavity's principal axes differ from the case axes, so the dither torque also rocks the
cavity transversely at Ω_d (inertia product J_xz ≈ a₁·J_z1z1, METHODS §C):

    θ_xz(t) = θ_xz,max·sin(Ω_d·t + φ₀)          about case Y, in phase with the dither
    θ_xy(t) = θ_xy,max·sin(Ω_d·t + φ₀ + φ)      about case Z, phase offset φ

Rocking models (``rocking_model``): ``'proportional'`` (the paper's, used for eq. (24)):
θ_xz,max = θ_xy,max = k·a; ``'components'`` (the physical one, METHODS §C last paragraph):
θ_xz,max = k·a·cos ψ₀ (the XZ-plane tilt drives the rocking about Y) and
θ_xy,max = k·a·sin ψ₀, signed, so eq. (24) scales as a²·|sin 2ψ₀|/2. k defaults to the
paper's 1″ at 35′.

The sensed angle over each output step is ∫ω_b·IA dt on the exact composed rotation
(:mod:`sim_nodes.dither.kinematics`), plus Earth rate, bias and angle random walk; the output
is whole pulses of K rad with the fraction carried. Every error source is switched off by
0 (``quantise=False`` emits the fractional phase). Random draws are consumed in sample order,
so chunked output is bit-identical to one-shot output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import EARTH_RATE_DEG_H, NS_PER_S, RAD_PER_ARCSEC
from sim_nodes.dither.kinematics import (
    CavityGeometry,
    CavityMotion,
    Sinusoids,
    earth_rate_enu_rad_s,
    gauss_legendre_increments,
    mount_rotation,
    periodic_mean_sensed_rate_rad_s,
)

if TYPE_CHECKING:
    import numpy.typing as npt

RAD_PER_ARCMIN = math.pi / 180.0 / 60.0
ROCKING_MODELS = ('proportional', 'components')


@dataclass(frozen=True, slots=True)
class DitheredGyroConfig:
    """Dithered RLG and site parameters; every error source switches off at 0."""

    scale_factor_rad_per_pulse: float = RAD_PER_ARCSEC
    """K: angle per output pulse, rad/pulse (default 1″)."""
    misalignment_arcmin: float = 10.0
    """a: dither-axis misalignment (angle DI–IA), arcmin."""
    ia_azimuth_deg: float = 30.0
    """ψ₀: azimuth of IA about DI from ẑ' toward Y, °."""
    dither_axis_tilt_arcmin: float = 10.0
    """b₀: static tilt of DI from case X in the XZ plane, arcmin."""
    dither_amplitude_arcmin: float = 6.0
    """θ_d: dither angle amplitude, arcmin."""
    dither_frequency_hz: float = 407.3172
    """Ω_d/2π: dither frequency, Hz (a mechanical resonance: not a round number. A dither
    frequency commensurate with the sample rate and the vibration frequency — 407.3 Hz with
    20 Hz and 2 kHz repeat every 10 s — makes the pulse quantisation periodic and coherent
    with the sidebands, and the error stops averaging down; see benchmarks/dither_floor_*.)"""
    dither_phase_rad: float = 0.4
    """φ₀: dither phase at t = 0, rad."""
    rocking_model: str = 'proportional'
    """``'proportional'`` (θ_xz,max = θ_xy,max = k·a) or ``'components'``
    (k·a·cos ψ₀, k·a·sin ψ₀)."""
    rocking_arcsec_per_arcmin: float = 1.0 / 35.0
    """k: rocking amplitude per unit misalignment, ″ per ′ (paper: 1″ at 35′; 0 = no rocking).
    Taken as given at whatever θ_d is set (the paper's own θ_d is lost); physically the rocking
    is driven by the dither torque and would scale with θ_d."""
    rocking_phase_rad: float = 1.0
    """φ: phase of θ_xy ahead of θ_xz (and of the dither), rad."""
    latitude_deg: float = 39.9
    """Site latitude, °."""
    heading_deg: float = 0.0
    """Heading of case X, counter-clockwise from East about Up, ° (table axis vertical)."""
    earth_rate_deg_h: float = EARTH_RATE_DEG_H
    """Earth rotation rate, °/h (0 = off)."""
    bias_deg_h: float = 0.005
    """Constant gyro bias, °/h."""
    angle_random_walk_deg_sqrt_h: float = 0.0005
    """Angle random walk N, °/√h."""
    quantise: bool = True
    """Emit whole pulses (fraction carried); False emits the phase in pulses."""
    quadrature_nodes: int = 6
    """Gauss–Legendre nodes per output step (6 keeps the integration error < 1e-9 pulse)."""
    seed: int = 1
    """Seed of the gyro's random stream (initial fractional phase, ARW)."""

    def __post_init__(self) -> None:
        """Reject values the physics cannot take."""
        if self.rocking_model not in ROCKING_MODELS:
            raise ValueError(f'rocking_model must be one of {ROCKING_MODELS}, '
                             f'got {self.rocking_model!r}')
        if not self.scale_factor_rad_per_pulse > 0:
            raise ValueError('scale_factor_rad_per_pulse must be positive')
        if not self.dither_frequency_hz > 0:
            raise ValueError('dither_frequency_hz must be positive')
        if self.quadrature_nodes < 2:
            raise ValueError('quadrature_nodes must be at least 2')

    @property
    def geometry(self) -> CavityGeometry:
        """a, ψ₀, b₀ in rad."""
        return CavityGeometry(self.misalignment_arcmin * RAD_PER_ARCMIN,
                              math.radians(self.ia_azimuth_deg),
                              self.dither_axis_tilt_arcmin * RAD_PER_ARCMIN)

    @property
    def dither_amplitude_rad(self) -> float:
        """θ_d, rad."""
        return self.dither_amplitude_arcmin * RAD_PER_ARCMIN

    @property
    def dither_angular_frequency_rad_s(self) -> float:
        """Ω_d, rad/s."""
        return 2.0 * math.pi * self.dither_frequency_hz

    @property
    def rocking_per_misalignment(self) -> float:
        """The k as a ratio (rad of rocking per rad of misalignment)."""
        return self.rocking_arcsec_per_arcmin / 60.0

    def rocking_amplitudes_rad(self) -> tuple[float, float]:
        """(θ_xz,max, θ_xy,max), rad, signed under the components model."""
        geo = self.geometry
        ka = self.rocking_per_misalignment * geo.misalignment_rad
        if self.rocking_model == 'proportional':
            return ka, ka
        return ka * math.cos(geo.ia_azimuth_rad), ka * math.sin(geo.ia_azimuth_rad)

    def motion(self, table: Sinusoids, table_axis: str) -> CavityMotion:
        """The cavity motion on a table moving by ``table`` about case ``table_axis``."""
        wd, ph0 = self.dither_angular_frequency_rad_s, self.dither_phase_rad
        u, w = self.rocking_amplitudes_rad()
        earth = earth_rate_enu_rad_s(math.radians(self.earth_rate_deg_h) / 3600.0,
                                     math.radians(self.latitude_deg))
        return CavityMotion(
            table_axis=table_axis,
            table=table,
            dither=Sinusoids((self.dither_amplitude_rad,), (wd,), (ph0,)),
            rocking_y=Sinusoids((u,), (wd,), (ph0,)),
            rocking_z=Sinusoids((w,), (wd,), (ph0 + self.rocking_phase_rad,)),
            mount=mount_rotation(table_axis, math.radians(self.heading_deg)),
            earth_rate_lab_rad_s=earth,
        )

    def exact_coning_drift_rad_s(self) -> float:
        """Drift of the sensed angle with the table still and Earth rate off, rad/s.

        The mean of ω_b·IA over one dither period of the exact kinematics (all coning
        together: eq. (24), dither × rocking and higher orders).
        """
        still = self.motion(Sinusoids(), 'z')
        still = CavityMotion(still.table_axis, still.table, still.dither, still.rocking_y,
                             still.rocking_z, still.mount, np.zeros(3))
        return periodic_mean_sensed_rate_rad_s(
            still, self.geometry, 1.0 / self.dither_frequency_hz)


class DitheredGyroSimulator:
    """Cumulative pulse counts of the dithered RLG on a vibration table, streamed in order."""

    def __init__(self, config: DitheredGyroConfig, table: Sinusoids, table_axis: str,
                 start_time_ns: int = 0) -> None:
        """Create the gyro in its initial state (random initial fractional phase)."""
        self.config = config
        self._motion = config.motion(table, table_axis)
        self._geometry = config.geometry
        self._rng = np.random.default_rng(np.random.SeedSequence(config.seed).spawn(1)[0])
        self._phase_pulses = float(self._rng.uniform()) if config.quantise else 0.0
        self._start_ns = int(start_time_ns)
        self._last_ns: int | None = None
        self._bias_rad_s = math.radians(config.bias_deg_h) / 3600.0
        self._arw_rad_sqrt_s = math.radians(config.angle_random_walk_deg_sqrt_h) / 60.0

    def step(self, t_ns: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """Integrate up to each stamp in ``t_ns`` (strictly increasing); return counts.

        The first stamp ever given is the start of the sensed angle (its count is the
        initial whole pulse count, 0 or the floor of the random initial phase).
        """
        t_ns = np.asarray(t_ns, dtype=np.int64)
        if len(t_ns) == 0:
            return np.zeros(0)
        prev = np.concatenate(([self._last_ns if self._last_ns is not None else t_ns[0]],
                               t_ns[:-1]))
        if np.any(t_ns[1:] <= t_ns[:-1]) or (self._last_ns is not None
                                             and t_ns[0] <= self._last_ns):
            raise ValueError('sample stamps must increase strictly')
        t0 = (prev - self._start_ns) / NS_PER_S
        t1 = (t_ns - self._start_ns) / NS_PER_S
        increments = np.zeros(len(t_ns))
        moving = t1 > t0
        increments[moving] = gauss_legendre_increments(
            self._motion, self._geometry, t0[moving], t1[moving], self.config.quadrature_nodes)
        dt_s = t1 - t0
        increments += self._bias_rad_s * dt_s
        if self._arw_rad_sqrt_s:
            increments += self._arw_rad_sqrt_s * np.sqrt(dt_s) * self._rng.standard_normal(
                len(dt_s))
        self._last_ns = int(t_ns[-1])
        phase = np.cumsum(np.concatenate((
            [self._phase_pulses], increments / self.config.scale_factor_rad_per_pulse)))[1:]
        self._phase_pulses = float(phase[-1])
        return np.floor(phase) if self.config.quantise else phase
