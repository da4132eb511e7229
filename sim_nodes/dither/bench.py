"""The dither-misalignment bench: vibration table + dithered RLG, streamed in chunks.

Pulses are sampled at ``sample_rate_hz`` on an integer-nanosecond grid; the table's
joint_states at every ``table_decimation``-th pulse stamp. :meth:`DitherBenchSimulator.step`
continues exactly where the last call stopped, so chunked output is bit-identical to a
one-shot run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S
from sim_nodes.dither.gyro import DitheredGyroConfig, DitheredGyroSimulator
from sim_nodes.dither.vibration_table import VibrationTableConfig

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class DitherBenchConfig:
    """Sampling and length of one bench run."""

    sample_rate_hz: float = 2000.0
    """Rate of /gyro/pulses samples, Hz (must resolve the dither and its sidebands)."""
    table_decimation: int = 2
    """joint_states at every n-th pulse stamp (2 kHz / 2 = 1 kHz)."""
    duration_s: float = 300.0
    """Length of the run, s."""
    start_time_ns: int = 0
    """Stamp of the first sample, ns."""

    def __post_init__(self) -> None:
        """The sample period must be a whole number of nanoseconds."""
        period = NS_PER_S / self.sample_rate_hz
        if abs(period - round(period)) > 1e-6:
            raise ValueError('sample_rate_hz must divide 1e9 ns exactly')
        if self.table_decimation < 1 or self.duration_s <= 0:
            raise ValueError('table_decimation must be >= 1 and duration_s > 0')

    @property
    def sample_period_ns(self) -> int:
        """Pulse sample period, integer ns."""
        return int(round(NS_PER_S / self.sample_rate_hz))

    @property
    def n_samples(self) -> int:
        """Pulse samples in the run (both ends included)."""
        return int(round(self.duration_s * self.sample_rate_hz)) + 1


@dataclass(frozen=True, slots=True)
class DitherChunk:
    """One chunk of bench output.

    Attributes:
        pulse_t_ns: pulse stamps, int64 ns.
        counts: cumulative pulse counts (whole pulses, or the phase if not quantised).
        table_t_ns: joint_states stamps, int64 ns.
        table_angle_rad: encoder angle, rad.
        table_rate_rad_s: table rate, rad/s.
    """

    pulse_t_ns: npt.NDArray[np.int64]
    counts: npt.NDArray[np.float64]
    table_t_ns: npt.NDArray[np.int64]
    table_angle_rad: npt.NDArray[np.float64]
    table_rate_rad_s: npt.NDArray[np.float64]


class DitherBenchSimulator:
    """Streams /gyro/pulses and /vibration_table/joint_states of one orientation."""

    def __init__(self, gyro: DitheredGyroConfig, table: VibrationTableConfig,
                 bench: DitherBenchConfig) -> None:
        """Create table and gyro at the start of the run."""
        self.gyro_config, self.table_config, self.bench = gyro, table, bench
        self.gyro = DitheredGyroSimulator(gyro, table.motion, table.axis, bench.start_time_ns)
        self._next = 0

    @property
    def finished(self) -> bool:
        """True once the whole run has been streamed."""
        return self._next >= self.bench.n_samples

    def step(self, n_samples: int) -> DitherChunk:
        """Advance by up to ``n_samples`` pulse samples; return what the bench published."""
        bench = self.bench
        n = min(n_samples, bench.n_samples - self._next)
        k = np.arange(self._next, self._next + n, dtype=np.int64)
        self._next += n
        t_ns = bench.start_time_ns + k * bench.sample_period_ns
        counts = self.gyro.step(t_ns)
        on_table = k % bench.table_decimation == 0
        table_t = t_ns[on_table]
        angle, rate = self.table_config.encoder((table_t - bench.start_time_ns) / NS_PER_S)
        return DitherChunk(t_ns, counts, table_t, angle, rate)
