"""The two-axis bench's procedure as motion profiles of both tables (METHODS §A.3, §F).

Shared by the RBRLG bench (sim_nodes/rbrlg) and the triad bench (sim_nodes/triad);
``sim_nodes.rbrlg.procedure`` re-exports it under its old name.

At each station the rate table moves to ψ_i (a trapezoidal move) and holds; the
position table then turns n whole revolutions forward and n back (plus one margin
revolution each way, so whole-revolution windows fit between its index marks), and
stops. A rate-table station error Δβ offsets where the table actually stops; the
encoder reads the true angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyro_calib.units import RAD_PER_ARCSEC
from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator


@dataclass(frozen=True, slots=True)
class ThetaProcedureConfig:
    """Stations and position-table motion of the θ procedure."""

    stations_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    """Commanded rate-table angles of the stations, ° (paper: 4, or 80 at 10° steps)."""
    position_table_revolutions: int = 1
    """n: whole position-table revolutions each way per station."""
    position_table_rate_deg_s: float = 30.0
    """Position-table rate, °/s."""
    acceleration_deg_s2: float = 100.0
    """Acceleration of both tables when they start, stop or reverse, °/s²."""
    settle_s: float = 1.0
    """Hold before and after each position-table run, s."""
    position_table_index_jitter_arcsec: float = -1.0
    """Δφ_ON: std of the position table's zero-index sync error, ″ (−1: as the rate table)."""
    station_error_arcsec: float = 0.0
    """Δβ: std of the rate-table positioning error at each station, ″."""
    seed: int = 1
    """Seed of the station errors."""


def _move(delta: float, accel: float, max_rate: float) -> tuple[list[float], list[float]]:
    """Pieces of a rest-to-rest trapezoidal move by ``delta`` rad."""
    if delta == 0.0:
        return [], []
    sign = math.copysign(1.0, delta)
    t_acc = min(max_rate / accel, math.sqrt(abs(delta) / accel))
    cruise = (abs(delta) - accel * t_acc**2) / (accel * t_acc) if t_acc else 0.0
    durations = [t_acc, cruise, t_acc] if cruise > 1e-12 else [t_acc, t_acc]
    accels = [sign * accel, 0.0, -sign * accel] if cruise > 1e-12 else [sign * accel,
                                                                       -sign * accel]
    return durations, accels


def theta_procedure_profiles(cfg: ThetaProcedureConfig) -> tuple[MotionProfile, MotionProfile,
                                                                  list[tuple[float, float]]]:
    """Rate-table and position-table profiles, and each station's (start, end) time in s."""
    rng = np.random.default_rng(np.random.SeedSequence(cfg.seed).spawn(4)[3])
    acc = math.radians(cfg.acceleration_deg_s2)
    w = math.radians(cfg.position_table_rate_deg_s)
    revs = cfg.position_table_revolutions + 1
    t_const = revs * 2 * math.pi / w
    pos_run = ([cfg.settle_s, w / acc, t_const, 2 * w / acc, t_const, w / acc, cfg.settle_s],
               [0.0, acc, 0.0, -acc, 0.0, acc, 0.0])
    run_s = sum(pos_run[0])
    rate_d: list[float] = []
    rate_a: list[float] = []
    pos_d: list[float] = []
    pos_a: list[float] = []
    stations: list[tuple[float, float]] = []
    psi, t = 0.0, 0.0
    for station_deg in cfg.stations_deg:
        target = (math.radians(station_deg)
                  + rng.normal() * cfg.station_error_arcsec * RAD_PER_ARCSEC)
        d, a = _move(target - psi, acc, math.radians(60.0))
        rate_d += d
        rate_a += a
        pos_d.append(sum(d) if d else 1e-3)
        pos_a.append(0.0)
        if not d:
            rate_d.append(1e-3)
            rate_a.append(0.0)
        t += sum(d) if d else 1e-3
        psi = target
        rate_d.append(run_s)
        rate_a.append(0.0)
        pos_d += pos_run[0]
        pos_a += pos_run[1]
        stations.append((t, t + run_s))
        t += run_s
    rate = MotionProfile(rate_d, rate_a)
    position = MotionProfile(pos_d, pos_a)
    return rate, position, stations


def rate_bias_pieces(rate: float, accel: float, revolutions: float,
                     pairs: int) -> tuple[list[float], list[float]]:
    """From rest: ``pairs`` forward+reverse constant-rate segments, then back to rest."""
    t_const = revolutions * 2 * math.pi / rate
    durations, accels = [rate / accel], [accel]
    for k in range(2 * pairs):
        direction = 1.0 if k % 2 == 0 else -1.0
        durations.append(t_const)
        accels.append(0.0)
        last = k == 2 * pairs - 1
        durations.append(rate / accel if last else 2 * rate / accel)
        accels.append(-direction * accel)
    return durations, accels


def full_procedure_profiles(
    procedure: ThetaProcedureConfig, *, k_tilde_pairs: int, rate_deg_s: float = 150.0,
    acceleration_deg_s2: float = 1000.0, revolutions_per_segment: float = 6.0,
) -> tuple[MotionProfile, MotionProfile, list[tuple[float, float]]]:
    """The whole calibration: K̃ phase, then the θ phase.

    The whole calibration: K̃ phase (rate table spinning ``k_tilde_pairs`` times each
    way, position table still), then the θ phase of ``procedure``. Returns the rate-table
    and position-table profiles and the θ stations' (start, end) times, s.
    """
    rate_k = rate_bias_pieces(math.radians(rate_deg_s), math.radians(acceleration_deg_s2),
                               revolutions_per_segment, k_tilde_pairs)
    k_phase_s = sum(rate_k[0])
    rate_t, position_t, stations = theta_procedure_profiles(procedure)
    rate = MotionProfile(rate_k[0] + [1.0] + rate_t.pieces[0],
                         rate_k[1] + [0.0] + rate_t.pieces[1])
    position = MotionProfile([k_phase_s + 1.0] + position_t.pieces[0],
                             [0.0] + position_t.pieces[1])
    offset = k_phase_s + 1.0
    return rate, position, [(a + offset, b + offset) for a, b in stations]


_rate_bias_pieces = rate_bias_pieces  # the old private name


def two_axis_simulators(rate_profile: MotionProfile, position_profile: MotionProfile,
                        table: RateTableConfig, position_index_jitter_arcsec: float = -1.0,
                        ) -> tuple[RateTableSimulator, RateTableSimulator]:
    """Both tables of the two-axis bench on one clock.

    Both tables of the two-axis bench on one clock; they share ``table``'s encoder and
    sample settings. The position table's index jitter (its Δφ_ON) is
    ``position_index_jitter_arcsec``, or the rate table's when negative.
    """
    import dataclasses

    cfg = dataclasses.replace(table, duration_s=position_profile.duration_s)
    jitter = (position_index_jitter_arcsec if position_index_jitter_arcsec >= 0
              else cfg.zero_index_jitter_arcsec)
    return (RateTableSimulator(cfg, profile=rate_profile),
            RateTableSimulator(dataclasses.replace(cfg, seed=cfg.seed + 1000,
                                                   zero_index_jitter_arcsec=jitter),
                               profile=position_profile))
