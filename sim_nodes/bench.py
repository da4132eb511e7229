"""The simulated rate-bias bench run offline: table and gyro streamed into arrays.

The sim nodes publish exactly these chunks over DDS, so an offline run with the
same configuration and chunk size gives bit-identical samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.rate_table import RateTableConfig, RateTableSimulator
from sim_nodes.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator

if TYPE_CHECKING:
    import numpy.typing as npt

CHUNK_SAMPLES = 50
"""Samples per simulation chunk (one true-motion message), shared by nodes and offline runs."""


@dataclass(frozen=True, slots=True)
class BenchRecording:
    """Everything the calibration node would receive from one simulated run.

    Attributes:
        pulse_t_ns: gyro sample stamps, int64 ns.
        pulse_counts: cumulative pulse counts (integers in float64).
        table_t_ns: joint_states stamps, int64 ns.
        table_angle_rad: encoder angle, rad (unwrapped).
        table_rate_rad_s: table rate, rad/s.
        zero_index_ns: zero-index event stamps, int64 ns.
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    table_t_ns: npt.NDArray[np.int64]
    table_angle_rad: npt.NDArray[np.float64]
    table_rate_rad_s: npt.NDArray[np.float64]
    zero_index_ns: npt.NDArray[np.int64]


def true_k_tilde_arcsec_per_pulse(gyro: RingLaserGyroConfig) -> float:
    """The K̃ the bench should measure: K / cos θ (METHODS §A.2 eq. 4), ″/pulse."""
    import math

    from gyro_calib.units import RAD_PER_ARCSEC

    return gyro.scale_factor_arcsec_per_pulse / math.cos(
        gyro.fix_error_angle_arcsec * RAD_PER_ARCSEC
    )


def simulate_rate_bias_bench(
    table: RateTableConfig, gyro: RingLaserGyroConfig, *, chunk_samples: int = CHUNK_SAMPLES
) -> BenchRecording:
    """Run the table and the gyro for the table's whole duration, chunk by chunk."""
    table_sim = RateTableSimulator(table)
    gyro_sim = RingLaserGyroSimulator(gyro)
    pulses_t, pulses_n, js_t, js_a, js_r, idx = [], [], [], [], [], []
    dec = table.joint_state_decimation
    n_done = 0
    while not table_sim.finished:
        chunk = table_sim.step(chunk_samples)
        pulses_t.append(chunk.t_ns)
        pulses_n.append(gyro_sim.step(chunk.t_ns, chunk.true_angle_rad))
        keep = (np.arange(n_done, n_done + len(chunk.t_ns)) % dec) == 0
        n_done += len(chunk.t_ns)
        js_t.append(chunk.t_ns[keep])
        js_a.append(chunk.encoder_angle_rad[keep])
        js_r.append(chunk.encoder_rate_rad_s[keep])
        idx.append(chunk.zero_index_ns)
    return BenchRecording(
        pulse_t_ns=np.concatenate(pulses_t),
        pulse_counts=np.concatenate(pulses_n),
        table_t_ns=np.concatenate(js_t),
        table_angle_rad=np.concatenate(js_a),
        table_rate_rad_s=np.concatenate(js_r),
        zero_index_ns=np.concatenate(idx),
    )
