"""Single-axis angular vibration table (pure physics): rate A·cos(Ω_z·t + p), its encoder.

The table axis is aligned with one case axis of the gyro (``'z'`` or ``'y'``, published as
the joint_states frame_id). Error sources, each switched off by 0: a second harmonic of
the rate (drive distortion), the encoder's finite resolution and its read-out latency
(the reading stamped t was taken at t − latency). The table has no random error source,
so it needs no seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.dither.kinematics import Sinusoids

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class VibrationTableConfig:
    """Angular vibration table parameters (METHODS §C set-up)."""

    axis: str = 'z'
    """Case axis the table axis is aligned with: ``'z'`` or ``'y'`` (joint_states frame_id)."""
    rate_amplitude_rad_s: float = 5.0
    """A: amplitude of the table rate, rad/s."""
    frequency_hz: float = 27.6
    """Ω_z/2π: vibration frequency, Hz. The default is not a divisor of the usual pulse sample
    rates (1, 2, 4, 5, 10, 20 kHz): a table frequency that divides the sample rate (20 Hz at
    2 kHz) locks the pulse quantisation to the table phase, and the estimator then widens its
    uncertainty 2× (docs/guide/dither.md)."""
    phase_rad: float = 0.0
    """Phase p of the rate A·cos(Ω_z·t + p) at t = 0, rad."""
    harmonic_fraction: float = 0.0
    """Second-harmonic rate amplitude relative to A (drive distortion; 0 = off)."""
    harmonic_phase_rad: float = 0.0
    """Phase of the second harmonic relative to twice the fundamental's, rad."""
    encoder_counts_per_rev: int = 2**23
    """Encoder resolution, counts per revolution (0 = unquantised)."""
    encoder_latency_s: float = 0.0
    """Read-out latency: the angle stamped t is the angle at t − latency, s (0 = off)."""

    def __post_init__(self) -> None:
        """Reject an unknown axis, a non-positive frequency or negative amplitudes."""
        if self.axis not in ('z', 'y'):
            raise ValueError(f"axis must be 'z' or 'y', got {self.axis!r}")
        if not self.frequency_hz > 0:
            raise ValueError('frequency_hz must be positive')
        if self.rate_amplitude_rad_s < 0 or self.harmonic_fraction < 0:
            raise ValueError('rate_amplitude_rad_s and harmonic_fraction must be >= 0')

    @property
    def motion(self) -> Sinusoids:
        """The exact table angle θ_T(t) as a sum of sinusoids (θ_T(0) set by the phase)."""
        w = 2.0 * math.pi * self.frequency_hz
        amps = [self.rate_amplitude_rad_s / w]
        freqs = [w]
        phases = [self.phase_rad]  # rate A·cos(wt + p) ⇔ angle (A/w)·sin(wt + p)
        if self.harmonic_fraction:
            amps.append(self.harmonic_fraction * self.rate_amplitude_rad_s / (2 * w))
            freqs.append(2 * w)
            phases.append(2 * self.phase_rad + self.harmonic_phase_rad)
        return Sinusoids(tuple(amps), tuple(freqs), tuple(phases))

    def encoder(self, t_s: npt.NDArray[np.float64]) -> tuple[
            npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(angle, rate) the table publishes at stamps ``t_s``: quantised, latent; rad, rad/s."""
        motion = self.motion
        t_read = t_s - self.encoder_latency_s
        angle = motion.angle_rad(t_read)
        if self.encoder_counts_per_rev:
            res = 2.0 * math.pi / self.encoder_counts_per_rev
            angle = np.round(angle / res) * res
        return angle, motion.rate_rad_s(t_read)
