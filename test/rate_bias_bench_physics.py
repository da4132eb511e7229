"""A rate-bias bench written for the tests from the physics alone (not from sim_nodes).

It shares no code and no assumption with the simulators: the table runs a settle /
accelerate / cruise / decelerate cycle with its own reversal geometry, the reference
mark can sit anywhere (inside an acceleration too), each stream has its own sample rate,
and the run may start anywhere in the cycle, in either direction. The gyro senses
cos θ·ψ(t) plus a constant Earth-rate + bias term along its axis and the horizontal Earth
rate that its tilt picks up as the table turns, with angle random walk and whole pulses.

Everything is closed form except that small tilt term (trapezoid on the pulse grid).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

ARCSEC_PER_RAD = 180 * 3600 / math.pi


@dataclass(frozen=True)
class Bench:
    """One bench: table cycle, reference mark, streams and gyro (angles in °, ″)."""

    rate_deg_s: float = 150.0
    accel_deg_s2: float = 600.0
    cruise_revolutions: float = 6.0
    settle_s: float = 0.5
    mark_deg: float = 0.0
    index_jitter_arcsec: float = 0.1
    pulse_rate_hz: float = 1000.0
    table_rate_hz: float = 1000.0
    first_direction: int = 1
    start_phase: float = 0.0
    """Where in the cycle the recording starts, as a fraction of one forward+reverse cycle."""
    duration_s: float = 100.0
    k_arcsec_per_pulse: float = 1.1
    theta_arcsec: float = 600.0
    earth_bias_arcsec_s: float = 7.0
    """Earth rate along the table axis plus bias, projected on the sense axis, ″/s (= °/h)."""
    horizontal_earth_arcsec_s: float = 13.0
    arw_arcsec_sqrt_s: float = 0.0
    encoder_counts_per_rev: int = 2**23
    seed: int = 0
    start_ns: int = 1_000_000_000_000

    @property
    def true_k_tilde(self) -> float:
        """K/cos θ, ″/pulse (METHODS §A.2 eq. 4)."""
        return self.k_arcsec_per_pulse / math.cos(self.theta_arcsec / ARCSEC_PER_RAD)


@dataclass
class Pieces:
    """Piecewise constant-acceleration motion: start time, angle, rate, accel per piece."""

    t0: np.ndarray
    psi0: np.ndarray
    w0: np.ndarray
    acc: np.ndarray
    cruise: list[tuple[float, float, int]] = field(default_factory=list)
    """(start s, end s, direction) of every constant-rate cruise."""


def _pieces(b: Bench) -> Pieces:
    w = math.radians(b.rate_deg_s)
    a = math.radians(b.accel_deg_s2)
    t_acc = w / a
    t_cruise = b.cruise_revolutions * 2 * math.pi / w
    cycle = 2 * (b.settle_s + 2 * t_acc + t_cruise)
    t = -b.start_phase * cycle - cycle  # one cycle of run-in before the recording
    t0, psi0, w0, acc, cruise = [], [], [], [], []
    psi, rate, d = 0.0, 0.0, b.first_direction
    while t < b.duration_s + cycle:
        for dur, ac in ((b.settle_s, 0.0), (t_acc, d * a), (t_cruise, 0.0), (t_acc, -d * a)):
            if dur <= 0:
                continue
            if ac == 0.0 and rate != 0.0:
                cruise.append((t, t + dur, d))
            t0.append(t), psi0.append(psi), w0.append(rate), acc.append(ac)
            psi += rate * dur + 0.5 * ac * dur * dur
            rate += ac * dur
            t += dur
        rate, d = 0.0, -d
    return Pieces(np.array(t0), np.array(psi0), np.array(w0), np.array(acc), cruise)


def _state(p: Pieces, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    i = np.clip(np.searchsorted(p.t0, t, side='right') - 1, 0, len(p.t0) - 1)
    s = t - p.t0[i]
    return p.psi0[i] + p.w0[i] * s + 0.5 * p.acc[i] * s * s, p.w0[i] + p.acc[i] * s


def _mark_crossings(p: Pieces, b: Bench, t_end: float) -> np.ndarray:
    """Exact instants the table angle passes the mark (+k·360°), solving each piece."""
    mark = math.radians(b.mark_deg)
    out = []
    t_ends = np.append(p.t0[1:], t_end)
    for t0, te, psi0, w0, ac in zip(p.t0, t_ends, p.psi0, p.w0, p.acc):
        if te <= 0 or t0 >= t_end:
            continue
        dur = te - t0
        psi1 = psi0 + w0 * dur + 0.5 * ac * dur * dur
        lo, hi = min(psi0, psi1), max(psi0, psi1)
        if ac != 0.0:  # the turning point may lie inside the piece
            s_turn = -w0 / ac
            if 0 < s_turn < dur:
                turn = psi0 + w0 * s_turn + 0.5 * ac * s_turn * s_turn
                lo, hi = min(lo, turn), max(hi, turn)
        for k in range(math.ceil((lo - mark) / (2 * math.pi)),
                       math.floor((hi - mark) / (2 * math.pi)) + 1):
            target = mark + 2 * math.pi * k - psi0
            if ac == 0.0:
                roots = [target / w0] if w0 else []
            else:
                disc = w0 * w0 + 2 * ac * target
                if disc <= 0:
                    continue  # touches the mark at the turning point: no crossing
                r = math.sqrt(disc)
                roots = [(-w0 + r) / ac, (-w0 - r) / ac]
            out += [t0 + s for s in roots if 0 <= s < dur]
    return np.sort(np.array(out))


@dataclass
class Recording:
    """The streams a calibration node would receive, and where the cruises were."""

    pulse_t_ns: np.ndarray
    pulse_counts: np.ndarray
    table_t_ns: np.ndarray
    table_angle_rad: np.ndarray
    table_rate_rad_s: np.ndarray
    zero_index_ns: np.ndarray
    cruises: list[tuple[int, int, int]]
    """(start ns, end ns, direction) of the constant-rate cruises inside the recording."""
    index_rates_rad_s: np.ndarray
    """True table rate at each zero-index event."""


def record(b: Bench) -> Recording:
    """Run the bench for ``duration_s`` and return its streams (stamps int64 ns)."""
    rng = np.random.default_rng(b.seed)
    p = _pieces(b)
    pulse_period = round(1e9 / b.pulse_rate_hz)
    table_period = round(1e9 / b.table_rate_hz)
    tp_ns = np.arange(0, int(b.duration_s * 1e9), pulse_period, dtype=np.int64)
    tt_ns = np.arange(int(rng.integers(0, table_period)), int(b.duration_s * 1e9), table_period,
                      dtype=np.int64)
    tp = tp_ns / 1e9
    psi, rate = _state(p, tp)
    theta = b.theta_arcsec / ARCSEC_PER_RAD
    tilt_term = math.sin(theta) * b.horizontal_earth_arcsec_s * np.cos(psi + 0.7)  # ″/s
    tilt_angle = np.concatenate(([0.0], np.cumsum(0.5 * (tilt_term[1:] + tilt_term[:-1])
                                                  * np.diff(tp))))
    sensed = (math.cos(theta) * psi * ARCSEC_PER_RAD + b.earth_bias_arcsec_s * tp + tilt_angle)
    if b.arw_arcsec_sqrt_s:
        steps = rng.normal(0.0, b.arw_arcsec_sqrt_s * math.sqrt(pulse_period / 1e9), len(tp))
        sensed = sensed + np.cumsum(steps)
    counts = np.floor(sensed / b.k_arcsec_per_pulse + rng.uniform())
    tt = tt_ns / 1e9
    angle, trate = _state(p, tt)
    if b.encoder_counts_per_rev:
        lsb = 2 * math.pi / b.encoder_counts_per_rev
        angle = np.round(angle / lsb) * lsb
    cross = _mark_crossings(p, b, b.duration_s)
    cross = cross[(cross > 0) & (cross < b.duration_s)]
    _, cross_rate = _state(p, cross)
    jitter_rad = rng.normal(0.0, b.index_jitter_arcsec / ARCSEC_PER_RAD, len(cross))
    stamps = cross + jitter_rad / np.maximum(np.abs(cross_rate), 1e-3)
    cruises = [(int(s * 1e9) + b.start_ns, int(e * 1e9) + b.start_ns, d)
               for s, e, d in p.cruise if e > 0 and s < b.duration_s]
    return Recording(
        pulse_t_ns=tp_ns + b.start_ns, pulse_counts=counts,
        table_t_ns=tt_ns + b.start_ns, table_angle_rad=angle, table_rate_rad_s=trate,
        zero_index_ns=np.round(stamps * 1e9).astype(np.int64) + b.start_ns,
        cruises=cruises, index_rates_rad_s=cross_rate)
