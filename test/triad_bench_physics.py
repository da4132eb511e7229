"""A gyro triad on the two-axis bench, written for the tests from the kinematics (no sim_nodes).

Frames (docs/methods.md §F.1): East-North-Up → position-table base (heading h about Up) →
position table (angle χ about Up) → tilted by α about its y → rate table (angle β about the
new z) = T; the body B = F·T. The body rate relative to ENU, in T, is β̇·e_z + χ̇·u_T(β) with
u_T(β) = R_z(β)ᵀ·R_y(α)ᵀ·e_z, composed here from the rotations (not from eq. (1)). The Earth
rate ω_E = Ω_e·(0, cos φ, sin φ) enters through the full orientation.

Gyro i (unit sense axis s_i in B, scale factor K_i rad/pulse, bias b_i rad/s along s_i, white
rate noise of angle random walk N rad/√s) counts floor((∫ s_i·ω_B dt + b_i·t)/K_i + phase_i),
sampled at 1 kHz. Only one table turns at a time, so the table part of ∫ s_i·ω_B dt is summed
exactly from the angle increments; the Earth part is integrated on the sample grid.

The procedure: P inner-axis pairs (m revolutions each way at the inner rate, with ramps), then
at each rate-table station ψ_k the position table turns n revolutions each way (plus margins
so two zero-index events lie in the cruise). Encoder at 250 Hz (angle, rate); zero-index
events where the table passes its mark (linear interpolation of the cruise: exact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

EARTH_RATE_RAD_S = 15.041 * math.pi / 180.0 / 3600.0
"""Earth rotation rate (15.041 °/h), rad/s — as gyro_calib.units."""
ARCSEC = math.pi / 180.0 / 3600.0

Array = npt.NDArray[np.float64]


def rot_z(a: float | Array) -> Array:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.moveaxis(np.array([[c, -s, z], [s, c, z], [z, z, o]]), (0, 1), (-2, -1))


def rot_y(a: float) -> Array:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class Triad:
    """Three gyros: K_i (rad/pulse), sense axes (unit rows, body), biases (rad/s), ARW."""

    scale_factor_rad_per_pulse: Array
    sense_axes: Array
    bias_rad_s: Array = field(default_factory=lambda: np.zeros(3))
    arw_rad_sqrt_s: float = 0.0

    @property
    def rows(self) -> Array:
        """R with rows r_i = s_i/K_i (pulses/rad)."""
        return self.sense_axes / self.scale_factor_rad_per_pulse[:, None]


def random_triad(rng: np.random.Generator, *, max_misalignment_rad: float = 5e-3,
                 k_range_arcsec: tuple[float, float] = (0.5, 5.0),
                 bias_deg_h: float = 0.02, arw_rad_sqrt_s: float = 0.0) -> Triad:
    """Sense axes within ±max of the body axes, K_i uniform in the range (″/pulse)."""
    axes = np.eye(3) + rng.uniform(-max_misalignment_rad, max_misalignment_rad, (3, 3)) * (
        1 - np.eye(3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    k = rng.uniform(*k_range_arcsec, 3) * ARCSEC
    bias = rng.uniform(-bias_deg_h, bias_deg_h, 3) * math.radians(1) / 3600
    return Triad(k, axes, bias, arw_rad_sqrt_s)


@dataclass
class Bench:
    """The two-axis bench and its procedure."""

    tilt_rad: float = math.radians(45.0)
    stations_rad: tuple[float, ...] = (0.0, math.pi / 2, math.pi, 3 * math.pi / 2)
    position_turns: int = 1
    outer_margin_turns: float = 1.3
    """Cruise beyond the n turns (1.3: one or two windows each way; 0.6: exactly one)."""
    inner_pairs: int = 3
    inner_turns: int = 2
    inner_rate_rad_s: float = math.radians(150.0)
    inner_accel_rad_s2: float = math.radians(300.0)
    outer_rate_rad_s: float = math.radians(60.0)
    outer_accel_rad_s2: float = math.radians(60.0)
    latitude_deg: float = 40.0
    heading_deg: float = 20.0
    fixture: Array = field(default_factory=lambda: np.eye(3))
    rate_mark_rad: float = 0.3
    position_mark_rad: float = 1.1
    pulse_hz: float = 1000.0
    encoder_hz: float = 250.0
    index_jitter_s: float = 0.0
    encoder_counts_per_rev: int = 0
    """Encoder resolution (angle quantised to whole counts); 0 = exact angles."""
    with_position_table: bool = True
    remount_axis: str = ''


@dataclass
class Recording:
    """What the bench publishes (stamps int ns)."""

    pulse_t: npt.NDArray[np.int64]
    counts: Array  # (n, 3)
    rate_t: npt.NDArray[np.int64]
    rate: Array  # (n, 2): angle, rate
    rate_index: npt.NDArray[np.int64]
    position_t: npt.NDArray[np.int64]
    position: Array
    position_index: npt.NDArray[np.int64]
    unrounded: Array | None = None
    """(n, 3): the counts before rounding to whole pulses (the truth a window count estimates)."""


def _trapezoid(delta: float, rate: float, accel: float) -> tuple[float, float]:
    """(ramp time, cruise time) of a move by |delta| at ``rate`` with ``accel``."""
    d = abs(delta)
    t_ramp = rate / accel
    if accel * t_ramp ** 2 >= d:
        return math.sqrt(d / accel), 0.0
    return t_ramp, (d - accel * t_ramp ** 2) / rate


def _profile(t: Array, t0: float, delta: float, rate: float, accel: float) -> tuple[Array, Array]:
    """Angle travelled and rate at times t of a trapezoidal move starting at t0."""
    tr, tc = _trapezoid(delta, rate, accel)
    sign = math.copysign(1.0, delta)
    w = accel * tr
    x = np.clip(t - t0, 0.0, 2 * tr + tc)
    a1 = np.minimum(x, tr)
    ang = 0.5 * accel * a1 ** 2
    rt = accel * a1
    c = np.clip(x - tr, 0.0, tc)
    ang = ang + w * c
    d = np.clip(x - tr - tc, 0.0, tr)
    ang = ang + w * d - 0.5 * accel * d ** 2
    rt = np.where(x > tr, w, rt)
    rt = np.where(x > tr + tc, w - accel * d, rt)
    rt = np.where(x >= 2 * tr + tc, 0.0, rt)
    return sign * ang, sign * rt


def procedure(bench: Bench) -> list[tuple[str, float, float, float, float]]:
    """The moves: (table, start s, delta rad, rate, accel), with 0.5 s dwells."""
    moves: list[tuple[str, float, float, float, float]] = []
    t = 1.0
    beta = 0.0
    two_pi = 2 * math.pi
    dwell = 0.5

    def add(table: str, delta: float, rate: float, accel: float) -> None:
        nonlocal t
        moves.append((table, t, delta, rate, accel))
        tr, tc = _trapezoid(delta, rate, accel)
        t += 2 * tr + tc + dwell

    ramp_r = bench.inner_rate_rad_s ** 2 / bench.inner_accel_rad_s2 / two_pi
    for _ in range(bench.inner_pairs):
        turns = bench.inner_turns + 1.3 + ramp_r
        add('rate', turns * two_pi, bench.inner_rate_rad_s, bench.inner_accel_rad_s2)
        add('rate', -turns * two_pi, bench.inner_rate_rad_s, bench.inner_accel_rad_s2)
    if bench.with_position_table and not bench.remount_axis:
        ramp_p = bench.outer_rate_rad_s ** 2 / bench.outer_accel_rad_s2 / two_pi
        for psi in bench.stations_rad:
            delta = (psi - beta + math.pi) % two_pi - math.pi
            if abs(delta) > 1e-12:
                add('rate', delta, math.radians(20.0), math.radians(40.0))
            beta += delta
            turns = bench.position_turns + bench.outer_margin_turns + ramp_p
            add('position', turns * two_pi, bench.outer_rate_rad_s, bench.outer_accel_rad_s2)
            add('position', -turns * two_pi, bench.outer_rate_rad_s, bench.outer_accel_rad_s2)
    moves.append(('end', t + 0.5, 0.0, 0.0, 0.0))
    return moves


def _angles(t: Array, moves: list[tuple[str, float, float, float, float]],
            table: str) -> tuple[Array, Array]:
    angle = np.zeros_like(t)
    rate = np.zeros_like(t)
    for name, t0, delta, w, a in moves:
        if name == table:
            ang, rt = _profile(t, t0, delta, w, a)
            angle += ang
            rate += rt
    return angle, rate


def _index(t: Array, angle: Array, mark: float) -> Array:
    """Times the angle crosses mark + 2πk (either direction), linear between samples."""
    k = np.floor((angle - mark) / (2 * math.pi))
    cross = np.nonzero(np.diff(k) != 0)[0]
    out = []
    for i in cross:
        level = mark + 2 * math.pi * max(k[i], k[i + 1])
        a0, a1 = angle[i], angle[i + 1]
        out.append(t[i] + (level - a0) / (a1 - a0) * (t[i + 1] - t[i]))
    return np.array(out)


REMOUNT_F = {'+x': np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float),
             '-x': np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]], float),
             '+y': np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float),
             '-y': np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float),
             '+z': np.eye(3), '-z': np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], float)}
"""Fixture of each remount: F·e_z = the body axis that points up the table axis."""


def record(bench: Bench, triad: Triad, rng: np.random.Generator) -> Recording:
    """Simulate the procedure; pulses at ``pulse_hz``, encoders at ``encoder_hz``."""
    moves = procedure(bench)
    t_end = moves[-1][1]
    dt = 1.0 / bench.pulse_hz
    t = np.arange(0.0, t_end, dt)
    beta, beta_rate = _angles(t, moves, 'rate')
    chi, chi_rate = _angles(t, moves, 'position')
    fixture = REMOUNT_F[bench.remount_axis] if bench.remount_axis else bench.fixture
    tilt = 0.0 if bench.remount_axis else bench.tilt_rad
    # table part of ∫ω_B dt: increments of β about F·e_z, of χ about F·u_T(β)
    d_beta = np.diff(beta, prepend=0.0)
    d_chi = np.diff(chi, prepend=0.0)
    r_y = rot_y(tilt)
    r_tp = np.einsum('ij,njk->nik', r_y, rot_z(beta))  # position table ← T
    u_t = np.einsum('nji,j->ni', r_tp, np.array([0.0, 0.0, 1.0]))  # ON in T
    theta_t = d_beta[:, None] * np.array([0.0, 0.0, 1.0]) + d_chi[:, None] * u_t
    # Earth rate in T: R_{ENU←T}ᵀ ω_E with R_{ENU←T} = R_z(h + χ)·R_y(α)·R_z(β)
    lat = math.radians(bench.latitude_deg)
    w_e = EARTH_RATE_RAD_S * np.array([0.0, math.cos(lat), math.sin(lat)])
    r_enu_t = np.einsum('nij,njk->nik', rot_z(math.radians(bench.heading_deg) + chi), r_tp)
    earth_t = np.einsum('nji,j->ni', r_enu_t, w_e)
    earth_inc = np.zeros_like(earth_t)
    earth_inc[1:] = 0.5 * (earth_t[1:] + earth_t[:-1]) * dt
    theta_b = (theta_t + earth_inc) @ fixture.T
    angle_b = np.cumsum(theta_b, axis=0)
    sensed = angle_b @ triad.sense_axes.T + t[:, None] * triad.bias_rad_s
    if triad.arw_rad_sqrt_s > 0:
        sensed += np.cumsum(rng.normal(0.0, triad.arw_rad_sqrt_s * math.sqrt(dt),
                                       sensed.shape), axis=0)
    unrounded = sensed / triad.scale_factor_rad_per_pulse + rng.uniform(0, 1, 3)
    counts = np.floor(unrounded)
    enc_stride = int(round(bench.pulse_hz / bench.encoder_hz))
    te = t[::enc_stride]
    base = 1_700_000_000 * 10 ** 9

    def ns(x: Array) -> npt.NDArray[np.int64]:
        return (base + np.round(x * 1e9)).astype(np.int64)

    def jitter(x: Array) -> Array:
        if bench.index_jitter_s > 0:
            return x + rng.normal(0.0, bench.index_jitter_s, len(x))
        return x

    rate_index = jitter(_index(t, beta, bench.rate_mark_rad))
    pos_index = jitter(_index(t, chi, bench.position_mark_rad))
    with_pos = bench.with_position_table and not bench.remount_axis
    def encoder(angle: Array) -> Array:
        if bench.encoder_counts_per_rev > 0:
            step = 2 * math.pi / bench.encoder_counts_per_rev
            return np.round(angle / step) * step
        return angle

    return Recording(
        ns(t), counts, ns(te),
        np.column_stack((encoder(beta[::enc_stride]), beta_rate[::enc_stride])),
        ns(rate_index),
        ns(te) if with_pos else np.zeros(0, np.int64),
        np.column_stack((encoder(chi[::enc_stride]), chi_rate[::enc_stride])) if with_pos
        else np.zeros((0, 2)),
        ns(pos_index) if with_pos else np.zeros(0, np.int64), unrounded)
