"""Rate-bias turntable simulator (pure physics, streamed in chunks).

Models (METHODS §A.6): constant-rate segments of a configurable number of
revolutions each way, finite acceleration at reversal, optional rate ripple,
optical angle encoder with finite resolution, one zero-index (reference mark)
event per revolution crossing in either direction, with timing jitter.

Every call to :meth:`RateTableSimulator.step` continues exactly where the last
one stopped, and the random draws are consumed in time order, so the samples do
not depend on how the run is cut into chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from gyro_calib.units import NS_PER_S, RAD_PER_ARCSEC
from sim_nodes.motion import MotionProfile, RateRipple, rate_bias_profile

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class RateTableConfig:
    """Rate-bias turntable parameters; defaults are the paper's bench (seed 000).

    Every error source is switched off by setting it to zero.
    """

    rate_deg_s: float = 150.0
    """Constant table rate, °/s (τ_R = 2.4 s)."""
    revolutions_per_segment: float = 6.0
    """Whole revolutions at constant rate between reversals (m + 1, so an m = 5 window fits)."""
    acceleration_deg_s2: float = 1000.0
    """Angular acceleration during reversals, °/s²."""
    settle_s: float = 0.0
    """Rest at zero rate in the middle of each reversal, s (0 = reverse straight through)."""
    rate_ripple_fraction: float = 0.0
    """Rate ripple amplitude relative to the nominal rate (0 = off)."""
    rate_ripple_hz: float = 5.0
    """Rate ripple frequency, Hz."""
    encoder_counts_per_rev: int = 2**23
    """Encoder resolution, counts per revolution (0 = unquantised)."""
    zero_index_angle_deg: float = 37.0
    """Angle of the reference mark on the grating ring, °."""
    zero_index_jitter_arcsec: float = 0.1
    """Standard deviation of the table angle at which the index event is stamped, ″."""
    sample_rate_hz: float = 1000.0
    """Rate of the true-motion samples the gyro integrates, Hz."""
    joint_state_decimation: int = 5
    """Publish every n-th sample on joint_states (1 kHz / 5 = 200 Hz)."""
    duration_s: float = 3600.0
    """Length of the run, s."""
    start_time_ns: int = 0
    """Stamp of the first sample, ns."""
    seed: int = 1
    """Seed of the table's random stream (index jitter)."""

    @property
    def sample_period_ns(self) -> int:
        """Sample period, integer ns."""
        period = NS_PER_S / self.sample_rate_hz
        if abs(period - round(period)) > 1e-6:
            raise ValueError('sample_rate_hz must divide 1e9 ns exactly')
        return int(round(period))


@dataclass(frozen=True, slots=True)
class TableChunk:
    """One chunk of table output.

    Attributes:
        t_ns: sample stamps, int64 ns.
        true_angle_rad: exact unwrapped table angle at each stamp, rad (sim-only).
        true_rate_rad_s: exact table rate, rad/s (sim-only).
        encoder_angle_rad: encoder reading (quantised, unwrapped), rad.
        encoder_rate_rad_s: rate reported with the encoder reading, rad/s.
        zero_index_ns: stamps of reference-mark events inside this chunk, int64 ns.
    """

    t_ns: npt.NDArray[np.int64]
    true_angle_rad: npt.NDArray[np.float64]
    true_rate_rad_s: npt.NDArray[np.float64]
    encoder_angle_rad: npt.NDArray[np.float64]
    encoder_rate_rad_s: npt.NDArray[np.float64]
    zero_index_ns: npt.NDArray[np.int64]


class RateTableSimulator:
    """Streams samples and zero-index events of a rate-bias turntable."""

    def __init__(self, config: RateTableConfig, profile: MotionProfile | None = None) -> None:
        """Create the simulator; ``profile`` overrides the rate-bias motion."""
        self.config = config
        rate = math.radians(config.rate_deg_s)
        self.profile = profile or rate_bias_profile(
            rate_rad_s=rate,
            acceleration_rad_s2=math.radians(config.acceleration_deg_s2),
            revolutions_per_segment=config.revolutions_per_segment,
            duration_s=config.duration_s,
            settle_s=config.settle_s,
            ripple=RateRipple(config.rate_ripple_fraction, config.rate_ripple_hz, rate),
        )
        self._period_ns = config.sample_period_ns
        self._next_index = 0
        self._last_t_s: float | None = None
        self._rng = np.random.default_rng(np.random.SeedSequence(config.seed).spawn(1)[0])
        self.n_samples_total = int(config.duration_s * config.sample_rate_hz) + 1

    @property
    def finished(self) -> bool:
        """True once the whole run has been streamed."""
        return self._next_index >= self.n_samples_total

    def _mark_cycles(self, angle_rad: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        zero_rad = math.radians(self.config.zero_index_angle_deg)
        return np.floor((angle_rad - zero_rad) / (2 * math.pi))

    def _crossings(self, t_prev_s: float, t_s: npt.NDArray[np.float64]) -> list[float]:
        """Exact instants (s) where the table angle passes the reference mark."""
        grid = np.concatenate(([t_prev_s], t_s))
        cycles = self._mark_cycles(self.profile.angle_rad(grid))
        jumps = np.nonzero(np.diff(cycles))[0]
        ref = math.radians(self.config.zero_index_angle_deg)
        out = []
        for j in jumps:
            k = max(cycles[j], cycles[j + 1])
            target = ref + 2 * math.pi * k
            f = lambda t: float(self.profile.angle_rad(np.array([t]))[0]) - target  # noqa: E731
            out.append(brentq(f, grid[j], grid[j + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps))
        return out

    def step(self, n_samples: int) -> TableChunk:
        """Advance by up to ``n_samples`` samples and return what the table emitted."""
        cfg = self.config
        n = min(n_samples, self.n_samples_total - self._next_index)
        k = np.arange(self._next_index, self._next_index + n, dtype=np.int64)
        self._next_index += n
        t_rel_ns = k * self._period_ns
        t_s = t_rel_ns / NS_PER_S
        angle = self.profile.angle_rad(t_s)
        rate = self.profile.rate_rad_s(t_s)
        if cfg.encoder_counts_per_rev:
            res = 2 * math.pi / cfg.encoder_counts_per_rev
            encoder = np.round(angle / res) * res
        else:
            encoder = angle.copy()
        index_ns: list[int] = []
        if n:
            prev_s = self._last_t_s if self._last_t_s is not None else float(t_s[0])
            sigma_rad = cfg.zero_index_jitter_arcsec * RAD_PER_ARCSEC
            for t_cross in self._crossings(prev_s, t_s):
                jitter_s = 0.0
                if sigma_rad:
                    speed = abs(float(self.profile.rate_rad_s(np.array([t_cross]))[0]))
                    jitter_s = self._rng.normal() * sigma_rad / max(speed, 1e-6)
                index_ns.append(cfg.start_time_ns + int(round((t_cross + jitter_s) * NS_PER_S)))
            self._last_t_s = float(t_s[-1])
        return TableChunk(
            t_ns=cfg.start_time_ns + t_rel_ns,
            true_angle_rad=angle,
            true_rate_rad_s=rate,
            encoder_angle_rad=encoder,
            encoder_rate_rad_s=rate,
            zero_index_ns=np.asarray(index_ns, dtype=np.int64),
        )
