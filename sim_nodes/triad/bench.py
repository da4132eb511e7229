"""The triad benches as motion profiles, streamed chunk by chunk (METHODS §A.3, §F.1).

- Two-axis bench (``two_axis``): the inner-axis phase first (rate table turning
  ``inner_pairs`` forward/reverse segments of m + 1 revolutions at its rate, position table
  still: the K̃-style windows about e_z), then at each station of ``procedure`` the rate
  table holds while the position table turns n + 1 revolutions each way (§A.3's θ phase:
  windows about u(β)). The profiles are the RBRLG bench's own
  (:func:`~sim_nodes.two_axis_procedure.full_procedure_profiles`).
- Single-axis table, remounted (``remount``): the rate table alone turning ``inner_pairs``
  forward/reverse segments, the body axis ``mount.mount_axis`` up; no position table.

Both tables are :class:`~sim_nodes.rate_table.RateTableSimulator` (encoder quantisation,
zero-index events with jitter); the triad integrates their true angles
(:class:`~sim_nodes.triad.gyros.TriadGyroSimulator`). The node publishes exactly these
chunks, so a live run and an offline one give bit-identical samples.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator
from sim_nodes.triad.gyros import TriadConfig, TriadGyroSimulator, TriadMountConfig
from sim_nodes.two_axis_procedure import (
    ThetaProcedureConfig,
    full_procedure_profiles,
    rate_bias_pieces,
    two_axis_simulators,
)

if TYPE_CHECKING:
    import numpy.typing as npt

CHUNK_SAMPLES = 200
"""Samples per simulation chunk, shared by the node and offline runs."""

KINDS = ('two_axis', 'remount')

JointStates = tuple['npt.NDArray[np.int64]', 'npt.NDArray[np.float64]',
                    'npt.NDArray[np.float64]']


@dataclass(frozen=True, slots=True)
class TriadChunk:
    """What the bench publishes over one chunk.

    Attributes:
        pulse_t_ns: /imu/pulses stamps, int64 ns.
        pulse_counts: cumulative counts (n, 3), one column per channel.
        rate_table: rate-table joint states (t_ns, encoder angle rad, rate rad/s), decimated.
        rate_zero_index_ns: rate-table zero-index stamps.
        position_table: position-table joint states, or None (single-axis table).
        position_zero_index_ns: position-table zero-index stamps, or None.
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    rate_table: JointStates
    rate_zero_index_ns: npt.NDArray[np.int64]
    position_table: JointStates | None
    position_zero_index_ns: npt.NDArray[np.int64] | None


@dataclass(frozen=True, slots=True)
class TriadBench:
    """One triad bench run: tables, procedure, gyros and mount (all seeded)."""

    kind: str
    table: RateTableConfig
    gyros: TriadConfig
    mount: TriadMountConfig
    procedure: ThetaProcedureConfig = ThetaProcedureConfig()
    inner_pairs: int = 2
    """Forward/reverse pairs of rate-table segments (m + 1 revolutions each)."""

    def profiles(self) -> tuple[MotionProfile, MotionProfile | None]:
        """(rate-table profile, position-table profile or None)."""
        if self.kind == 'two_axis':
            rate, position, _ = full_procedure_profiles(
                self.procedure, k_tilde_pairs=self.inner_pairs, rate_deg_s=self.table.rate_deg_s,
                acceleration_deg_s2=self.table.acceleration_deg_s2,
                revolutions_per_segment=self.table.revolutions_per_segment)
            return rate, position
        if self.kind == 'remount':
            if self.mount.mount_axis == '':
                raise ValueError('a remount bench needs mount.mount_axis (+x … -z).')
            d, a = rate_bias_pieces(math.radians(self.table.rate_deg_s),
                                     math.radians(self.table.acceleration_deg_s2),
                                     self.table.revolutions_per_segment, self.inner_pairs)
            return MotionProfile(d + [1.0], a + [0.0]), None
        raise ValueError(f'triad bench kind {self.kind!r} is not one of {KINDS}')

    def simulators(self) -> tuple[RateTableSimulator, RateTableSimulator | None]:
        """The rate table and (two-axis) the position table, on one clock."""
        rate, position = self.profiles()
        if position is None:
            cfg = dataclasses.replace(self.table, duration_s=rate.duration_s)
            return RateTableSimulator(cfg, profile=rate), None
        return two_axis_simulators(
            rate, position, self.table,
            position_index_jitter_arcsec=self.procedure.position_table_index_jitter_arcsec)

    def chunks(self, chunk_samples: int = CHUNK_SAMPLES) -> Iterator[TriadChunk]:
        """The run, chunk by chunk, in time order."""
        rate_sim, pos_sim = self.simulators()
        gyro = TriadGyroSimulator(self.gyros, self.mount)
        dec = self.table.joint_state_decimation
        n_done = 0
        while not rate_sim.finished:
            r = rate_sim.step(chunk_samples)
            q = pos_sim.step(chunk_samples) if pos_sim is not None else None
            chi = q.true_angle_rad if q is not None else np.zeros_like(r.true_angle_rad)
            counts = gyro.step(r.t_ns, chi, r.true_angle_rad)
            keep = (np.arange(n_done, n_done + len(r.t_ns)) % dec) == 0
            n_done += len(r.t_ns)
            yield TriadChunk(
                pulse_t_ns=r.t_ns, pulse_counts=counts,
                rate_table=(r.t_ns[keep], r.encoder_angle_rad[keep], r.encoder_rate_rad_s[keep]),
                rate_zero_index_ns=r.zero_index_ns,
                position_table=(None if q is None else
                                (q.t_ns[keep], q.encoder_angle_rad[keep],
                                 q.encoder_rate_rad_s[keep])),
                position_zero_index_ns=None if q is None else q.zero_index_ns)

    def record(self, chunk_samples: int = CHUNK_SAMPLES) -> TriadChunk:
        """The whole run as one chunk (offline runs, bags, tests)."""
        parts = list(self.chunks(chunk_samples))

        def tables(which: list[JointStates]) -> JointStates:
            return (np.concatenate([w[0] for w in which]).astype(np.int64),
                    np.concatenate([w[1] for w in which]), np.concatenate([w[2] for w in which]))

        position = [p.position_table for p in parts if p.position_table is not None]
        position_index = [p.position_zero_index_ns for p in parts
                          if p.position_zero_index_ns is not None]
        return TriadChunk(
            pulse_t_ns=np.concatenate([p.pulse_t_ns for p in parts]).astype(np.int64),
            pulse_counts=np.concatenate([p.pulse_counts for p in parts]),
            rate_table=tables([p.rate_table for p in parts]),
            rate_zero_index_ns=np.concatenate([p.rate_zero_index_ns for p in parts]
                                              ).astype(np.int64),
            position_table=tables(position) if position else None,
            position_zero_index_ns=(np.concatenate(position_index).astype(np.int64)
                                    if position_index else None))
