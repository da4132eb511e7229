"""A recording of test/triad_bench_physics.py through the real triad session, and z-scores.

Shared by test/test_triad_coverage.py and benchmarks/triad_coverage.py (one feeding, one
scoring): the recording in 20 s batches of every topic, as a bag reader gives them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from triad_bench_physics import Bench, Recording

from gyro_calib import topics
from gyro_calib.bagio import JOINT_STATE, SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.session import CalibrationOptions
from gyro_calib.triad.records import TriadResult
from gyro_calib.triad.session import TriadSession

HEADER = 'std_msgs/msg/Header'


def batches(rec: Recording, chunk_s: float = 20.0) -> list[SampleBatch]:
    """The recording in time slices, every topic in each (as a bag reader gives)."""
    def cols(topic: str, msgtype: str, t: np.ndarray, values: dict[str, np.ndarray]
             ) -> TopicColumns:
        return TopicColumns(topic, msgtype, t, t, FrameIds(np.zeros(len(t), np.int32), ('',)),
                            values)

    t0, t1 = int(rec.pulse_t[0]), int(rec.pulse_t[-1])
    step = int(chunk_s * 1e9)
    streams = [(topics.IMU_PULSES, JOINT_STATE, rec.pulse_t,
                {'position': rec.counts, 'velocity': np.full(len(rec.pulse_t), np.nan)}),
               (topics.RATE_TABLE_JOINT_STATES, JOINT_STATE, rec.rate_t,
                {'position': rec.rate[:, 0], 'velocity': rec.rate[:, 1]}),
               (topics.RATE_TABLE_ZERO_INDEX, HEADER, rec.rate_index, {}),
               (topics.POSITION_TABLE_JOINT_STATES, JOINT_STATE, rec.position_t,
                {'position': rec.position[:, 0], 'velocity': rec.position[:, 1]}),
               (topics.POSITION_TABLE_ZERO_INDEX, HEADER, rec.position_index, {})]
    out = []
    for lo in range(t0, t1 + 1, step):
        got = {}
        for topic, msgtype, t, values in streams:
            sel = (t >= lo) & (t < lo + step)
            if np.any(sel):
                got[topic] = cols(topic, msgtype, t[sel], {k: v[sel] for k, v in values.items()})
        out.append(SampleBatch(got, sum(len(c) for c in got.values()), lo + step))
    return out


def bench_settings(bench: Bench) -> dict[str, Any]:
    """What the operator states about the physics bench (issue 26 contract)."""
    return {'latitude_deg': bench.latitude_deg, 'heading_deg': bench.heading_deg,
            'tilt_deg': math.degrees(bench.tilt_rad), 'tilt_std_arcsec': 60.0,
            'position_table_revolutions': bench.position_turns,
            'revolutions_per_window': bench.inner_turns}


def run_session(rec: Recording, stated: dict[str, Any],
                settings: dict[str, Any] | None = None) -> TriadSession:
    """The session fed ``rec`` in batches (bench settings ``stated``), processed to the end."""
    session = TriadSession(CalibrationOptions(
        latitude_deg=stated['latitude_deg'], heading_deg=stated['heading_deg'],
        scenario={'bench': stated}, settings=dict(settings or {})))
    for b in batches(rec):
        session.feed(b)
        session.process()
    session.process(flush=True)
    return session


def session_of(bench: Bench, rec: Recording) -> TriadSession:
    """The session of a physics-bench recording."""
    return run_session(rec, bench_settings(bench))


def z_scores(result: TriadResult, k_true: np.ndarray, s_true: np.ndarray) -> list[float]:
    """The z = error/u of K_x, s_x·e_y, s_x·e_z, K_y, s_y·e_x, s_y·e_z, K_z, s_z·e_x, s_z·e_y."""
    return scores(result, k_true, s_true)[0]


def scores(result: TriadResult, k_true: np.ndarray, s_true: np.ndarray
           ) -> tuple[list[float], list[float]]:
    """(z of the nine parameters as :func:`z_scores`, ΔK_i/K_i); NaN where not solved."""
    z, rel = [], []
    for i, ch in enumerate(result.channels):
        k, axis = ch.scale_factor_rad_per_pulse, ch.sense_axis
        if k is None or axis is None:
            return [math.nan] * 9, [math.nan] * 3
        z.append((k.value - k_true[i]) / k.std_uncertainty)
        rel.append(k.value / k_true[i] - 1.0)
        for j in range(3):
            if j != i:
                z.append((axis[j].value - s_true[i, j]) / axis[j].std_uncertainty)
    return z, rel


def stated_dofs(result: TriadResult) -> list[float]:
    """ν each of the nine parameters states (order of :func:`z_scores`); NaN where not solved."""
    out: list[float] = []
    for i, ch in enumerate(result.channels):
        k, axis = ch.scale_factor_rad_per_pulse, ch.sense_axis
        if k is None or axis is None:
            return [math.nan] * 9
        out.append(float(k.dof))
        out.extend(float(axis[j].dof) for j in range(3) if j != i)
    return out


def t_statistic(z: np.ndarray, dof: np.ndarray) -> np.ndarray:
    """T = t_ν·error/u: what the claim (u, ν) says is Student-t(ν) distributed.

    The estimators widen the share of u that rests on ν degrees of freedom by t_ν
    (docs/methods.md §A eq. (3d): u = t_ν·s, ±u covers 68.27 %), so the claim is
    error = u·T_ν/t_ν, and |z| ≤ 1 is the t(ν) interval at 68.27 %. ν ≤ 0 or ∞: normal.
    """
    from scipy.stats import t as student

    finite = np.isfinite(dof) & (dof >= 1)
    factor = np.where(finite, student.ppf(0.8413447460685429, np.where(finite, dof, 1.0)), 1.0)
    return np.asarray(z * factor, dtype=np.float64)


def t_equivalent_scores(z: np.ndarray, dof: np.ndarray) -> np.ndarray:
    """z_t = Φ⁻¹(F_t(ν)(t_ν·error/u)): the normal score of each error under its own (u, ν)."""
    from scipy.stats import norm
    from scipy.stats import t as student

    tt = t_statistic(z, dof)
    finite = np.isfinite(dof) & (dof >= 1)
    nu = np.where(finite, dof, 1.0)
    # the upper tail for positive T keeps Φ⁻¹ exact far out (|z_t| up to ~37)
    upper = norm.isf(student.sf(np.abs(tt), nu))
    return np.asarray(np.where(finite, np.sign(tt) * upper, z), dtype=np.float64)
