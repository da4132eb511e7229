"""The simulated rate-bias bench run offline: table and gyro streamed into arrays.

The sim nodes publish exactly these chunks over DDS, so an offline run with the
same configuration and chunk size gives bit-identical samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator
from sim_nodes.rbrlg.procedure import (
    ThetaProcedureConfig,
    full_procedure_profiles,
    theta_procedure_profiles,
)
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig, TwoAxisGyroSimulator
from sim_nodes.two_axis_procedure import two_axis_simulators

if TYPE_CHECKING:
    import numpy.typing as npt

CHUNK_SAMPLES = 200
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


@dataclass(frozen=True, slots=True)
class TwoAxisRecording:
    """What the calibration node receives from the two-axis bench.

    Attributes:
        pulse_t_ns, pulse_counts: gyro samples (stamps int64 ns, cumulative pulses).
        rate_table: joint_states of the rate table (t_ns, angle rad, rate rad/s).
        rate_zero_index_ns: the rate table's zero-index stamps, int64 ns.
        position_table: joint_states of the position table (t_ns, angle rad, rate rad/s).
        position_zero_index_ns: the position table's zero-index stamps, int64 ns.
        stations_s: (start, end) of each θ station, s from the start (truth, for tests).
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    rate_table: tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]
    rate_zero_index_ns: npt.NDArray[np.int64]
    position_table: tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                          npt.NDArray[np.float64]]
    position_zero_index_ns: npt.NDArray[np.int64]
    stations_s: list[tuple[float, float]]


ThetaRecording = TwoAxisRecording


def simulate_two_axis_bench(
    rate_profile: MotionProfile, position_profile: MotionProfile,
    stations_s: list[tuple[float, float]], table: RateTableConfig,
    gyro: RingLaserGyroConfig, mount: TiltedMountConfig, *, chunk_samples: int = CHUNK_SAMPLES,
    position_index_jitter_arcsec: float = -1.0,
) -> TwoAxisRecording:
    """Run both tables along their profiles and the gyro on the composed motion."""
    rate_sim, position_sim = two_axis_simulators(rate_profile, position_profile, table,
                                                 position_index_jitter_arcsec)
    gyro_sim = TwoAxisGyroSimulator(gyro, mount)
    out: dict[str, list[npt.NDArray[Any]]] = {k: [] for k in (  # int64 stamps, float64 values
        'pt', 'pn', 'rt', 'ra', 'rr', 'ri', 'qt', 'qa', 'qr', 'qi')}
    dec, n_done = table.joint_state_decimation, 0
    while not rate_sim.finished:
        r = rate_sim.step(chunk_samples)
        q = position_sim.step(chunk_samples)
        still = np.abs(r.true_rate_rad_s) < 1e-9
        out['pt'].append(r.t_ns)
        out['pn'].append(gyro_sim.step(r.t_ns, q.true_angle_rad, r.true_angle_rad, still))
        keep = (np.arange(n_done, n_done + len(r.t_ns)) % dec) == 0
        n_done += len(r.t_ns)
        for prefix, chunk in (('r', r), ('q', q)):
            out[prefix + 't'].append(chunk.t_ns[keep])
            out[prefix + 'a'].append(chunk.encoder_angle_rad[keep])
            out[prefix + 'r'].append(chunk.encoder_rate_rad_s[keep])
            out[prefix + 'i'].append(chunk.zero_index_ns)
    cat = {k: np.concatenate(v) for k, v in out.items()}
    return TwoAxisRecording(
        pulse_t_ns=cat['pt'].astype(np.int64), pulse_counts=cat['pn'],
        rate_table=(cat['rt'].astype(np.int64), cat['ra'], cat['rr']),
        rate_zero_index_ns=cat['ri'].astype(np.int64),
        position_table=(cat['qt'].astype(np.int64), cat['qa'], cat['qr']),
        position_zero_index_ns=cat['qi'].astype(np.int64),
        stations_s=stations_s,
    )


def simulate_theta_procedure(
    procedure: ThetaProcedureConfig, table: RateTableConfig, gyro: RingLaserGyroConfig,
    mount: TiltedMountConfig, *, chunk_samples: int = CHUNK_SAMPLES,
) -> TwoAxisRecording:
    """The θ procedure alone on the two-axis bench (METHODS §A.3)."""
    rate, position, stations = theta_procedure_profiles(procedure)
    return simulate_two_axis_bench(
        rate, position, stations, table, gyro, mount, chunk_samples=chunk_samples,
        position_index_jitter_arcsec=procedure.position_table_index_jitter_arcsec)


def simulate_full_procedure(
    procedure: ThetaProcedureConfig, table: RateTableConfig, gyro: RingLaserGyroConfig,
    mount: TiltedMountConfig, *, k_tilde_pairs: int = 4, chunk_samples: int = CHUNK_SAMPLES,
) -> TwoAxisRecording:
    """The whole calibration: K̃ phase on the tilted mount, then the θ procedure."""
    rate, position, stations = full_procedure_profiles(
        procedure, k_tilde_pairs=k_tilde_pairs, rate_deg_s=table.rate_deg_s,
        acceleration_deg_s2=table.acceleration_deg_s2,
        revolutions_per_segment=table.revolutions_per_segment)
    return simulate_two_axis_bench(
        rate, position, stations, table, gyro, mount, chunk_samples=chunk_samples,
        position_index_jitter_arcsec=procedure.position_table_index_jitter_arcsec)
