"""Offline dither-misalignment runs: whole recordings of one or both orientations + truth.

``simulate_dither_run`` streams the bench in chunks and returns the two contract topics of
one orientation as arrays — ``/gyro/pulses`` (stamp, cumulative count) and
``/vibration_table/joint_states`` (stamp, table angle, rate, frame_id ``'z'``/``'y'``) —
with the truth of the gyro. ``simulate_dither_pair`` runs both orientations (separate
runs, separate noise seeds, the same gyro).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sim_nodes.dither.bench import DitherBenchConfig, DitherBenchSimulator
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.vibration_table import VibrationTableConfig

if TYPE_CHECKING:
    import numpy.typing as npt

@dataclass(frozen=True, slots=True)
class DitherRecording:
    """The contract topics of one orientation's run, and the truth behind them.

    Attributes:
        pulse_t_ns: /gyro/pulses stamps, int64 ns.
        pulse_counts: cumulative pulse counts.
        table_t_ns: /vibration_table/joint_states stamps, int64 ns.
        table_angle_rad: table encoder angle, rad.
        table_rate_rad_s: table rate, rad/s.
        frame_id: ``'z'`` or ``'y'``, the case axis the table axis is along.
        truth: see :func:`dither_truth`.
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    table_t_ns: npt.NDArray[np.int64]
    table_angle_rad: npt.NDArray[np.float64]
    table_rate_rad_s: npt.NDArray[np.float64]
    frame_id: str
    truth: dict[str, Any]


def dither_truth(gyro: DitheredGyroConfig, table: VibrationTableConfig) -> dict[str, Any]:
    """What a perfect measurement of this gyro would find (SI units, METHODS §C).

    Keys: ``misalignment_rad`` (a), ``ia_azimuth_rad`` (ψ₀), ``misalignment_z_rad`` and
    ``misalignment_y_rad`` (a·|sin ψ₀|, a·|cos ψ₀|: what the table along Z, along Y sees),
    ``effective_z_rad`` / ``effective_y_rad`` (the signed sideband coefficients the output
    carries once the in-phase rocking is added: s_z − θ_xz,max/θ_d and
    s_y − θ_xy,max·cos φ/θ_d, with s_z = sin a·cos b₀·sin ψ₀, s_y = sin a·cos ψ₀),
    ``quadrature_y_rad`` (θ_xy,max·sin φ/θ_d, the rocking out of phase with the dither,
    seen along Y), ``dither_amplitude_rad`` (θ_d), ``dither_amplitude_pulses``
    (θ_d·cos a/K, the line the output carries), ``dither_frequency_hz``, the rocking
    amplitudes, ``coning_eq24_rad_s`` (½·Ω_d·θ_xz,max·θ_xy,max·sin φ),
    ``coning_dither_rocking_rad_s`` (−½·Ω_d·θ_d·θ_xy,max·sin φ·IA_y: the dither and the
    rocking about Z cone about Y; the gyro sees its projection on IA), ``coning_exact_rad_s``
    (mean sensed rate over a dither period of the exact kinematics, table still) and the
    table's ``table_rate_amplitude_rad_s``, ``table_frequency_hz``.
    """
    geo = gyro.geometry
    a, psi, b0 = geo.misalignment_rad, geo.ia_azimuth_rad, geo.di_tilt_rad
    theta_d = gyro.dither_amplitude_rad
    wd = gyro.dither_angular_frequency_rad_s
    u, w = gyro.rocking_amplitudes_rad()
    phi = gyro.rocking_phase_rad

    def rock_ratio(angle_rad: float) -> float:
        return angle_rad / theta_d if theta_d else math.nan

    s_z = math.sin(a) * math.cos(b0) * math.sin(psi)
    s_y = math.sin(a) * math.cos(psi)
    ia_y = math.sin(a) * math.sin(psi)
    return {
        'misalignment_rad': a,
        'ia_azimuth_rad': psi,
        'dither_axis_tilt_rad': b0,
        'misalignment_z_rad': a * abs(math.sin(psi)),
        'misalignment_y_rad': a * abs(math.cos(psi)),
        'effective_z_rad': s_z - rock_ratio(u),
        'effective_y_rad': s_y - rock_ratio(w * math.cos(phi)),
        'quadrature_y_rad': rock_ratio(w * math.sin(phi)),
        'dither_amplitude_rad': theta_d,
        'dither_amplitude_pulses': theta_d * math.cos(a) / gyro.scale_factor_rad_per_pulse,
        'dither_frequency_hz': gyro.dither_frequency_hz,
        'scale_factor_rad_per_pulse': gyro.scale_factor_rad_per_pulse,
        'rocking_model': gyro.rocking_model,
        'rocking_per_misalignment': gyro.rocking_per_misalignment,
        'rocking_xz_rad': u,
        'rocking_xy_rad': w,
        'rocking_phase_rad': phi,
        'coning_eq24_rad_s': 0.5 * wd * u * w * math.sin(phi),
        'coning_dither_rocking_rad_s': -0.5 * wd * theta_d * w * math.sin(phi) * ia_y,
        'coning_exact_rad_s': gyro.exact_coning_drift_rad_s(),
        'table_rate_amplitude_rad_s': table.rate_amplitude_rad_s,
        'table_frequency_hz': table.frequency_hz,
        'table_axis': table.axis,
    }


def simulate_dither_run(gyro: DitheredGyroConfig, table: VibrationTableConfig,
                        bench: DitherBenchConfig, *,
                        chunk_samples: int = 20000) -> DitherRecording:
    """Run one orientation (``table.axis``) and return the whole recording with the truth."""
    sim = DitherBenchSimulator(gyro, table, bench)
    parts = []
    while not sim.finished:
        parts.append(sim.step(chunk_samples))
    return DitherRecording(
        pulse_t_ns=np.concatenate([p.pulse_t_ns for p in parts]),
        pulse_counts=np.concatenate([p.counts for p in parts]),
        table_t_ns=np.concatenate([p.table_t_ns for p in parts]),
        table_angle_rad=np.concatenate([p.table_angle_rad for p in parts]),
        table_rate_rad_s=np.concatenate([p.table_rate_rad_s for p in parts]),
        frame_id=table.axis,
        truth=dither_truth(gyro, table),
    )


def simulate_dither_pair(gyro: DitheredGyroConfig, table: VibrationTableConfig,
                         bench: DitherBenchConfig, *,
                         chunk_samples: int = 20000) -> dict[str, DitherRecording]:
    """Both orientations of the same gyro: ``{'z': run, 'y': run}``.

    The runs are separate recordings: the Y run uses gyro seed ``gyro.seed + 1`` (its own
    noise and initial phase) and starts where the Z run ended plus one second.
    """
    z = simulate_dither_run(gyro, dataclasses.replace(table, axis='z'), bench,
                            chunk_samples=chunk_samples)
    start_y = int(z.pulse_t_ns[-1]) + 1_000_000_000
    y = simulate_dither_run(dataclasses.replace(gyro, seed=gyro.seed + 1),
                            dataclasses.replace(table, axis='y'),
                            dataclasses.replace(bench, start_time_ns=start_y),
                            chunk_samples=chunk_samples)
    return {'z': z, 'y': y}
