"""The drift a triad calibration removes, through the real pipeline, against the user's way.

Issue 41 §1: the baseline is what a user does without this tool.

Run (from the repository root, niced: two cores are shared):

    PYTHONPATH=$PWD nice python benchmarks/navigation_benefit.py --seeds 50 --plot docs/figures
    PYTHONPATH=$PWD nice python benchmarks/navigation_benefit.py --seeds 2 --static-s 600  # quick

Per seed, one triad is drawn: K_i within the datasheet tolerance (±200 ppm) of the datasheet
values, sense axes within ±60″ of the body axes, biases ±0.02 °/h, ARW N (0.0005 or
0.002 °/√h) and a navigation-grade bias instability (a rate random walk of 0.002 °/h/√h).

(a) Its two-axis bench run (two inner pairs of 5 turns at 150 °/s, four stations with one
    position-table turn each way, 200 Hz pulses) is simulated by ``sim_nodes`` (the
    ``triad_two_axis_bench`` scenario with this triad) or by :func:`bench_record`, a generator
    written here from the kinematics (angle increments about e_z and u_T(β), Earth rate at the
    midpoint), alternating by seed, so one simulator's conventions cannot hide an error in both.
(b) ``gyro-calib calibrate BAG --method triad --out H.yaml`` (the real CLI; the ARW measured
    from the record), then a 4-hour noise run of the same sensor at rest (1 Hz)
    (``gyro-calib noise REST --topic /imu/pulses --calibration H.yaml --out H.yaml``); where
    it resolves the ARW, the triad again with that ARW stated (``--config`` with
    ``angle_random_walk_deg_sqrt_h``, ``--replace``), then ``gyro-calib export H.yaml
    --format gtsam``.
(c) A separate trajectory of the same sensor (same K_i, axes, b, noise) — static for 1 h, or
    60 s at rest then 15 min of manoeuvres — is turned into pulses and navigated (attitude
    strapdown in North-East-Down, Earth and transport rate removed; the body rates of the
    trajectory from ``inu.mech_inv``) with four streams:

    - truth: the ideal body rates (the reference the errors are taken against);
    - calibrated: imu_corrector's maths, ω = M̂·ṅ − b̂, with M̂, b̂ read from the hand-off by
      :func:`gyro_calib.imu_body_rate.triad_rate_model`;
    - baseline (what a user does without this tool): ω = diag(K_datasheet)·ṅ on nominal axes,
      less the bias averaged over the first 60 s at rest with the Earth rate removed at the
      known latitude and attitude;
    - raw (extra column): diag(K_datasheet)·ṅ, bias never removed.

Printed per trajectory and ARW: rms and 95th percentile over seeds of the heading and tilt
error at the end, and the NEES of the calibrated attitude error at the end with the
calibration's own stated covariance: C_M and u(b) of the hand-off propagated through the same
mechanisation (finite differences), plus the exported GTSAM terms (gyroscope_covariance·t,
bias_omega_covariance·t³/3).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
ARCSEC = math.pi / 180.0 / 3600.0
DEG_H = ARCSEC  # rad/s per °/h (1 °/h = 1 ″/s)
EARTH_RATE = 7.292115e-5
LATITUDE_DEG = 45.0
K_DATASHEET_ARCSEC = np.array([0.84279066, 1.1034519, 0.9571233])
K_TOLERANCE = 200e-6
MISALIGNMENT_ARCSEC = 60.0
BIAS_DEG_H = 0.02
RRW_DEG_H_SQRT_H = 0.002
ARWS = (0.0005, 0.002)
CHANNELS = ('x', 'y', 'z')
REST_S = 60.0
BENCH_HZ = 200.0
"""Pulse and joint-state rate of the bench runs (the committed bag: 500/250 Hz; for time)."""


# -- the sensor --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sensor:
    """One triad: K_i (rad/pulse), unit sense axes (rows, body), bias along s_i, noise."""

    k: Array
    axes: Array
    bias_along_s: Array  # rad/s
    arw: float  # rad/√s
    rrw: float  # rad/s/√s

    @property
    def rows(self) -> Array:
        """R = S/K (pulses/rad): ṅ = R·ω_B + bias counts."""
        return np.asarray(self.axes / self.k[:, None], dtype=np.float64)

    @property
    def m(self) -> Array:
        """M = R⁻¹ (rad/pulse)."""
        return np.asarray(np.linalg.inv(self.rows), dtype=np.float64)


def draw_sensor(seed: int, arw_deg_sqrt_h: float) -> Sensor:
    """K within the datasheet tolerance, axes within ±60″, biases ±0.02 °/h."""
    rng = np.random.default_rng(seed)
    k = K_DATASHEET_ARCSEC * ARCSEC * (1 + rng.uniform(-K_TOLERANCE, K_TOLERANCE, 3))
    axes = np.eye(3) + rng.uniform(-1, 1, (3, 3)) * MISALIGNMENT_ARCSEC * ARCSEC * (1 - np.eye(3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    bias = rng.uniform(-BIAS_DEG_H, BIAS_DEG_H, 3) * DEG_H
    return Sensor(k, axes, bias, math.radians(arw_deg_sqrt_h) / 60.0,
                  RRW_DEG_H_SQRT_H * DEG_H / 60.0)


def counts_of(sensor: Sensor, angle_body: Array, dt: float, rng: np.random.Generator,
              bias_walk_start: Array | None = None) -> tuple[Array, Array]:
    """Cumulative whole pulses of the body angle increments (n, 3), and the bias walk's end.

    Along s_i: s_i·Δθ + (b_i + β_i(t))·dt + N·√dt·w, divided by K_i, floored from a random
    phase; β_i a random walk of strength ``rrw``.
    """
    n = len(angle_body)
    walk0 = np.zeros(3) if bias_walk_start is None else bias_walk_start
    walk = walk0 + np.cumsum(rng.normal(0.0, sensor.rrw * math.sqrt(dt), (n, 3)), axis=0)
    sensed = angle_body @ sensor.axes.T + (sensor.bias_along_s + walk) * dt \
        + rng.normal(0.0, sensor.arw * math.sqrt(dt), (n, 3))
    phase = np.cumsum(sensed / sensor.k, axis=0) + rng.uniform(0, 1, 3)
    return np.floor(phase), walk[-1]


# -- (a) the bench, written here ---------------------------------------------------------------

def _trapezoid(t: Array, t0: float, delta: float, rate: float, accel: float) -> Array:
    """Angle travelled at t by a trapezoidal move of ``delta`` rad starting at t0."""
    d, tr = abs(delta), rate / accel
    if accel * tr * tr >= d:
        tr, tc = math.sqrt(d / accel), 0.0
    else:
        tc = (d - accel * tr * tr) / rate
    w = accel * tr
    x = np.clip(t - t0, 0.0, 2 * tr + tc)
    a1 = np.minimum(x, tr)
    c = np.clip(x - tr, 0.0, tc)
    e = np.clip(x - tr - tc, 0.0, tr)
    return np.asarray(math.copysign(1.0, delta) * (0.5 * accel * a1 ** 2 + w * c + w * e
                                                   - 0.5 * accel * e ** 2), dtype=np.float64)


def _duration(delta: float, rate: float, accel: float) -> float:
    d, tr = abs(delta), rate / accel
    if accel * tr * tr >= d:
        return 2 * math.sqrt(d / accel)
    return 2 * tr + (d - accel * tr * tr) / rate


@dataclass(frozen=True)
class BenchPlan:
    """The paper's plan: inner pairs of m turns, stations with n position-table turns."""

    tilt_deg: float = 45.0
    inner_pairs: int = 2
    inner_turns: int = 5
    stations_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    position_turns: int = 1
    inner_rate_deg_s: float = 150.0
    outer_rate_deg_s: float = 90.0
    accel_deg_s2: float = 400.0
    sample_hz: float = 200.0
    encoder_decimation: int = 1
    rate_mark_deg: float = 37.0
    position_mark_deg: float = 11.0
    heading_deg: float = 0.0


def bench_record(sensor: Sensor, plan: BenchPlan, rng: np.random.Generator) -> Any:
    """The two-axis bench run of ``sensor`` as a ``sim_nodes.triad.bench.TriadChunk``.

    Written here from the kinematics (frames of METHODS §F.1, identity fixture): over each
    sample the body turns by Δβ·e_z (rate table) plus Δχ·u_T(β), u_T = R_z(β)ᵀ·R_y(α)ᵀ·e_z
    (position table), and the Earth rate ω_E = Ω·(0, cos φ, sin φ) (East-North-Up) is taken
    into the body at the sample's midpoint through R_z(h + χ)·R_y(α)·R_z(β).
    """
    from sim_nodes.triad.bench import TriadChunk

    rad = math.radians
    moves: list[tuple[str, float, float, float]] = []  # (table, start, delta, rate)
    t = 1.0
    accel = rad(plan.accel_deg_s2)

    def add(table: str, delta: float, rate: float) -> None:
        nonlocal t
        moves.append((table, t, delta, rate))
        t += _duration(delta, rate, accel) + 0.5

    ramp = rad(plan.inner_rate_deg_s) ** 2 / accel / (2 * math.pi)
    for _ in range(plan.inner_pairs):
        turns = (plan.inner_turns + 1 + ramp + 0.3) * 2 * math.pi
        add('rate', turns, rad(plan.inner_rate_deg_s))
        add('rate', -turns, rad(plan.inner_rate_deg_s))
    beta = 0.0
    ramp = rad(plan.outer_rate_deg_s) ** 2 / accel / (2 * math.pi)
    for st in plan.stations_deg:
        delta = (rad(st) - beta + math.pi) % (2 * math.pi) - math.pi
        if abs(delta) > 1e-12:
            add('rate', delta, rad(20.0))
        beta += delta
        turns = (plan.position_turns + 1 + ramp + 0.3) * 2 * math.pi
        add('position', turns, rad(plan.outer_rate_deg_s))
        add('position', -turns, rad(plan.outer_rate_deg_s))
    dt = 1.0 / plan.sample_hz
    ts = np.arange(0.0, t + 0.5, dt)
    b_ang = sum((_trapezoid(ts, t0, d, w, accel) for tb, t0, d, w in moves if tb == 'rate'),
                np.zeros_like(ts)) + 0.3 * rng.uniform()
    c_ang = sum((_trapezoid(ts, t0, d, w, accel) for tb, t0, d, w in moves
                 if tb == 'position'), np.zeros_like(ts))
    alpha, lat = rad(plan.tilt_deg), rad(LATITUDE_DEG)
    d_b, d_c = np.diff(b_ang, prepend=b_ang[0]), np.diff(c_ang, prepend=c_ang[0])
    b_mid = b_ang - 0.5 * d_b
    c_mid = c_ang - 0.5 * d_c
    u_t = np.column_stack((-math.sin(alpha) * np.cos(b_mid), math.sin(alpha) * np.sin(b_mid),
                           np.full_like(b_mid, math.cos(alpha))))
    inc = d_c[:, None] * u_t
    inc[:, 2] += d_b
    w_e = EARTH_RATE * np.array([0.0, math.cos(lat), math.sin(lat)])
    # R_{ENU←T} = R_z(h + χ)·R_y(α)·R_z(β); the body (= T) sees R_{ENU←T}ᵀ·ω_E
    h = rad(plan.heading_deg) + c_mid
    e1 = np.cos(h) * w_e[0] + np.sin(h) * w_e[1]  # R_z(h)ᵀ ω_E
    e2 = -np.sin(h) * w_e[0] + np.cos(h) * w_e[1]
    e3 = np.full_like(h, w_e[2])
    f1 = math.cos(alpha) * e1 - math.sin(alpha) * e3  # R_y(α)ᵀ
    f3 = math.sin(alpha) * e1 + math.cos(alpha) * e3
    earth = np.column_stack((np.cos(b_mid) * f1 + np.sin(b_mid) * e2,
                             -np.sin(b_mid) * f1 + np.cos(b_mid) * e2, f3))
    counts, _ = counts_of(sensor, inc + earth * dt, dt, rng)
    base = 1_700_000_000 * 10 ** 9
    t_ns = (base + np.round(ts * 1e9)).astype(np.int64)
    keep = slice(None, None, plan.encoder_decimation)

    def index(angle: Array, mark_deg: float) -> npt.NDArray[np.int64]:
        k = np.floor((angle - rad(mark_deg)) / (2 * math.pi))
        out = []
        for i in np.nonzero(np.diff(k) != 0)[0]:
            level = rad(mark_deg) + 2 * math.pi * max(k[i], k[i + 1])
            frac = (level - angle[i]) / (angle[i + 1] - angle[i])
            out.append(ts[i] + frac * dt)
        return (base + np.round(np.array(out) * 1e9)).astype(np.int64)

    rate_b = np.gradient(b_ang, dt)
    rate_c = np.gradient(c_ang, dt)
    return TriadChunk(t_ns, counts, (t_ns[keep], b_ang[keep], rate_b[keep]),
                      index(b_ang, plan.rate_mark_deg),
                      (t_ns[keep], c_ang[keep], rate_c[keep]),
                      index(c_ang, plan.position_mark_deg))


def plan_settings(plan: BenchPlan) -> dict[str, Any]:
    """The bench settings stored with the bag (issue 26 contract)."""
    return {'latitude_deg': LATITUDE_DEG, 'heading_deg': plan.heading_deg,
            'tilt_deg': plan.tilt_deg, 'tilt_std_arcsec': 60.0, 'station_offset_deg': 0.0,
            'fixture_rotation': [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            'position_table_revolutions': plan.position_turns,
            'revolutions_per_window': plan.inner_turns}


def write_bench_bag(path: Path, sensor: Sensor, seed: int, generator: str,
                    plan: BenchPlan | None = None) -> None:
    """The bench bag of ``sensor`` by ``generator`` ('sim_nodes' or 'written here')."""
    from gyro_calib.bagio import JOINT_STATE, write_bag
    from sim_nodes.triad.scenarios import IMU_PULSES, SCENARIOS, stream_messages

    if generator == 'sim_nodes':
        sc = SCENARIOS['triad_two_axis_bench']
        bias_deg_h = sensor.bias_along_s / DEG_H
        arw = math.degrees(sensor.arw) * 60.0
        sc = dataclasses.replace(
            sc, table=dataclasses.replace(sc.table, seed=seed, sample_rate_hz=BENCH_HZ,
                                          joint_state_decimation=1),
            gyros=dataclasses.replace(
                sc.gyros, seed=seed,
                scale_factor_arcsec_per_pulse=tuple(float(k) for k in sensor.k / ARCSEC),
                sense_axes=tuple(tuple(float(v) for v in row) for row in sensor.axes),
                bias_deg_h=tuple(float(b) for b in bias_deg_h),
                angle_random_walk_deg_sqrt_h=(arw, arw, arw), latitude_deg=LATITUDE_DEG),
            mount=dataclasses.replace(sc.mount, tilt_error_arcsec=0.0),
            procedure=dataclasses.replace(sc.procedure, seed=seed))
        rec = sc.bench().record()
        write_bag(path, stream_messages(rec, CHANNELS), types={IMU_PULSES: JOINT_STATE},
                  scenario={'name': 'navigation_benefit', 'kind': 'triad_two_axis',
                            'bench': sc.bench_settings()})
        return
    plan = plan or BenchPlan()
    rec = bench_record(sensor, plan, np.random.default_rng(seed + 7_000_000))
    write_bag(path, stream_messages(rec, CHANNELS), types={IMU_PULSES: JOINT_STATE},
              scenario={'name': 'navigation_benefit', 'kind': 'triad_two_axis',
                        'bench': plan_settings(plan)})


def write_rest_bag(path: Path, sensor: Sensor, seed: int, seconds: float = 4 * 3600.0,
                   rate_hz: float = 1.0) -> None:
    """The noise run: the sensor at rest, level, heading North (Earth rate along s_i)."""
    from gyro_calib import topics
    from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag

    rng = np.random.default_rng(seed + 9_000_000)
    n = int(seconds * rate_hz)
    dt = 1.0 / rate_hz
    lat = math.radians(LATITUDE_DEG)
    earth = EARTH_RATE * np.array([math.cos(lat), 0.0, -math.sin(lat)])  # NED body
    counts, _ = counts_of(sensor, np.tile(earth * dt, (n, 1)), dt, rng)
    t = (10 ** 9 + np.arange(n) * int(1e9 / rate_hz)).astype(np.int64)
    cdr = ContractMessages()
    write_bag(path, [BagMessage(topics.IMU_PULSES, ti, cdr.joints_state(ti, CHANNELS, c))
                     for ti, c in zip(t.tolist(), counts.tolist(), strict=True)])


# -- (b) the real pipeline ------------------------------------------------------------------

@dataclass(frozen=True)
class Calibrated:
    """What the pipeline hands on: M̂, its covariance, b̂, u(b), the exported GTSAM terms."""

    m: Array
    m_cov: Array
    bias: Array
    bias_std: Array
    gyroscope_covariance: Array  # rad²/s
    bias_omega_covariance: Array  # rad²/s³
    k_dof: Array
    exported: bool  # the noise run resolved the ARW and the GTSAM export was written


def calibrate(sensor: Sensor, seed: int, generator: str, workdir: Path,
              plan: BenchPlan | None = None) -> Calibrated:
    """Bench bag → ``calibrate --method triad`` → noise run → ``export --format gtsam``."""
    from gyro_calib.cli import main as gyro_calib
    from gyro_calib.export.gtsam import gtsam_matrices
    from gyro_calib.imu_body_rate import load_imu_calibration, triad_rate_model

    bag, rest = workdir / f'bench{seed}', workdir / f'rest{seed}'
    handoff, gtsam_file = workdir / f'imu{seed}.yaml', workdir / f'imu{seed}.gtsam.yaml'
    write_bench_bag(bag, sensor, seed, generator, plan)
    write_rest_bag(rest, sensor, seed)
    import contextlib
    import io

    said = io.StringIO()
    with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
        status = [gyro_calib(['calibrate', str(bag), '--method', 'triad', '--out', str(handoff),
                              '--no-progress']),
                  gyro_calib(['noise', str(rest), '--topic', '/imu/pulses', '--calibration',
                              str(handoff), '--out', str(handoff), '--no-progress'])]
        # exit 1: no term resolved (ARW 0.0005 °/√h under 1″ pulses in 4 h): no export then
        noise = load_imu_calibration(handoff).noise if status[1] == 0 else {}
        arw = [noise.get(c, {}).get('angle_random_walk_rad_per_sqrt_s') for c in CHANNELS]
        if all(n is not None for n in arw):  # the triad again, the noise run's ARW stated
            config = workdir / f'triad{seed}.yaml'
            config.write_text('angle_random_walk_deg_sqrt_h: [' + ', '.join(
                f'{math.degrees(float(n)) * 60.0:.6g}' for n in arw if n is not None) + ']\n',
                encoding='utf-8')
            status.append(gyro_calib(['calibrate', str(bag), '--method', 'triad', '--config',
                                      str(config), '--out', str(handoff), '--replace',
                                      '--no-progress']))
        exported = status[1] == 0 and gyro_calib(['export', str(handoff), '--format', 'gtsam',
                                                  '--out', str(gtsam_file)]) == 0
    if status[0] != 0 or status[1] not in (0, 1) or any(status[2:]):
        raise RuntimeError(f'pipeline failed ({status}) for seed {seed}, {generator}:\n'
                           + said.getvalue()[-3000:])
    cal = load_imu_calibration(handoff)
    model = triad_rate_model(cal, source=str(handoff))  # imu_corrector's reader
    g = gtsam_matrices(gtsam_file.read_text(encoding='utf-8')) if exported else {}
    assert cal.scale_factor_rad_per_pulse_dof is not None
    return Calibrated(model.m, model.m_covariance, model.bias_rad_s, model.bias_std,
                      np.asarray(g.get('gyroscope_covariance', np.zeros((3, 3)))),
                      np.asarray(g.get('bias_omega_covariance', np.zeros((3, 3)))),
                      np.asarray(cal.scale_factor_rad_per_pulse_dof), exported)


# -- (c) navigation -------------------------------------------------------------------------

def trajectory(kind: str, duration_s: float, dt: float) -> tuple[Array, Array]:
    """(llh, rpy) rows: at rest REST_S, then static (heading 30°) or manoeuvring."""
    n = int(round(duration_s / dt))
    t = np.arange(n) * dt
    llh = np.tile([math.radians(LATITUDE_DEG), 0.0, 100.0], (n, 1))
    rpy = np.zeros((n, 3))
    rpy[:, 2] = math.radians(30.0)
    if kind == 'manoeuvring':
        tm = np.clip(t - REST_S, 0.0, None)
        ramp = np.clip(tm / 20.0, 0.0, 1.0)
        llh[:, 0] += 5.0 * tm / 6.371e6  # 5 m/s north once moving
        rpy[:, 0] = ramp * math.radians(20.0) * np.sin(2 * math.pi * tm / 37.0)
        rpy[:, 1] = ramp * math.radians(10.0) * np.sin(2 * math.pi * tm / 53.0)
        rpy[:, 2] += ramp * math.radians(120.0) * np.sin(2 * math.pi * tm / 120.0) \
            + math.radians(3.0) * tm
    return llh, rpy


def _skew_exp(v: Array) -> Array:
    """Batched exp([v]×) (…, 3) → (…, 3, 3) (Rodrigues)."""
    th = np.linalg.norm(v, axis=-1)[..., None, None]
    k = np.zeros(v.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    small = th < 1e-8
    a = np.where(small, 1.0, np.sin(th) / np.where(small, 1.0, th))
    b = np.where(small, 0.5, (1 - np.cos(th)) / np.where(small, 1.0, th) ** 2)
    return np.asarray(np.eye(3) + a * k + b * (k @ k), dtype=np.float64)


def dcm_nb(rpy: Array) -> Array:
    """C_n←b of roll, pitch, yaw (NED, z-y-x)."""
    r, p, y = rpy[..., 0], rpy[..., 1], rpy[..., 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack([np.stack([cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy], -1),
                     np.stack([cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy], -1),
                     np.stack([-sp, sr * cp, cr * cp], -1)], -2)


def nav_rate(llh: Array, dt: float) -> Array:
    """ω_in^n = ω_ie^n + ω_en^n per sample (NED), rad/s."""
    lat, h = llh[:, 0], llh[:, 2]
    v_n = np.gradient(llh[:, 0], dt) * (6.371e6 + h)
    return np.column_stack((EARTH_RATE * np.cos(lat), -v_n / (6.371e6 + h),
                            -EARTH_RATE * np.sin(lat)))


def strapdown(c0: Array, omega_b: Array, omega_in: Array, dt: float) -> Array:
    """C_n←b at the end of each stream: C ← exp(−[ω_in dt])·C·exp([ω_b dt]).

    ``omega_b`` (S, n, 3): S streams of body rates; ``omega_in`` (n, 3). Returns (S, 3, 3)
    at the end and the (S, 3, 3) history every ``every`` steps is not kept (memory).
    """
    c = np.broadcast_to(c0, (omega_b.shape[0], 3, 3)).copy()
    for k in range(omega_b.shape[1]):
        c = _skew_exp(-omega_in[k] * dt) @ c @ _skew_exp(omega_b[:, k] * dt)
    return c


def attitude_error(c_est: Array, c_true: Array) -> Array:
    """ψ (…, 3), rad, with C_est = exp([ψ]×)·C_true (NED: ψ_D is the heading error)."""
    d = c_est @ np.swapaxes(c_true, -1, -2)
    return 0.5 * np.stack([d[..., 2, 1] - d[..., 1, 2], d[..., 0, 2] - d[..., 2, 0],
                           d[..., 1, 0] - d[..., 0, 1]], -1)


@dataclass
class NavRun:
    """Errors at the end per seed: stream → (heading, tilt) in deg; and the NEES."""

    heading_deg: dict[str, list[float]]
    tilt_deg: dict[str, list[float]]
    nees: list[float]


STREAMS = ('calibrated', 'baseline', 'raw')


def navigate(kind: str, duration_s: float, dt: float, sensors: list[Sensor],
             cals: list[Calibrated], seeds: list[int]) -> NavRun:
    """Navigate the trajectory with every seed's sensor and streams; errors at the end."""
    import inu

    llh, rpy = trajectory(kind, duration_s, dt)
    _, wbbi = inu.mech_inv(llh, rpy, dt)  # ideal ω_ib^b (Earth rate included), rad/s
    wbbi = np.asarray(wbbi, dtype=np.float64)
    n = len(wbbi)
    w_in = nav_rate(llh, dt)
    c0 = dcm_nb(rpy[0])
    out = NavRun({s: [] for s in STREAMS}, {s: [] for s in STREAMS}, [])
    k_ds = K_DATASHEET_ARCSEC * ARCSEC
    rest = int(round(REST_S / dt))
    earth_b0 = c0.T @ (EARTH_RATE * np.array([math.cos(llh[0, 0]), 0.0,
                                              -math.sin(llh[0, 0])]))
    eps_b, eps_m = 1e-9, 1e-12
    members = []
    for sensor, cal, seed in zip(sensors, cals, seeds, strict=True):
        rng = np.random.default_rng(seed + 5_000_000 + (0 if kind == 'static' else 1))
        counts, _ = counts_of(sensor, wbbi * dt, dt, rng)
        n_dot = np.diff(counts, axis=0, prepend=counts[:1]) / dt
        n_dot[0] = n_dot[1]
        n_ideal = (sensor.rows @ wbbi.T).T  # noise-free count rate (for the Jacobians)
        raw = n_dot * k_ds
        base_bias = raw[:rest].mean(axis=0) - earth_b0
        streams = {'calibrated': n_dot @ cal.m.T - cal.bias, 'baseline': raw - base_bias,
                   'raw': raw}
        # Jacobians of the end attitude on b and on vec(M) (row-major), finite differences
        perturbed = [wbbi + eps_b * np.eye(3)[j] for j in range(3)]
        for i in range(3):
            for j in range(3):
                e = np.zeros((3, 3))
                e[i, j] = eps_m
                perturbed.append(wbbi + n_ideal @ e.T)
        members.append(np.stack([wbbi, *streams.values(), *perturbed]))
    per = 1 + len(STREAMS) + 12
    c_all = strapdown(c0, np.concatenate(members), w_in, dt)  # all seeds at once
    t_end = n * dt
    for k, cal in enumerate(cals):
        c_end = c_all[k * per:(k + 1) * per]
        psi = attitude_error(c_end[1:], c_end[0])
        for name, e in zip(STREAMS, psi[:3], strict=True):
            out.heading_deg[name].append(math.degrees(float(e[2])))
            out.tilt_deg[name].append(math.degrees(math.hypot(float(e[0]), float(e[1]))))
        jac_b = psi[3:6].T / eps_b  # ψ per unit of ω error (b̂ − b enters as −δb)
        jac_m = psi[6:15].T / eps_m
        p = (jac_b @ np.diag(cal.bias_std ** 2) @ jac_b.T + jac_m @ cal.m_cov @ jac_m.T
             + cal.gyroscope_covariance * t_end + cal.bias_omega_covariance * t_end ** 3 / 3)
        e = psi[0]
        out.nees.append(float(e @ np.linalg.solve(p, e)) / 3.0)
    return out


# -- main ---------------------------------------------------------------------------------------

def run(seeds: list[int], arw: float, static_s: float, manoeuvre_s: float,
        generators: tuple[str, ...] = ('sim_nodes', 'written here'),
        log: Any = None, keep: Path | None = None,
        done: list[tuple[int, Sensor, Calibrated, str]] | None = None) -> dict[str, Any]:
    """Calibrate every seed's sensor through the pipeline, then navigate both trajectories.

    ``keep``: pickle (seed, sensor, calibration, generator) there after each seed; ``done``:
    such calibrations already made (their seeds are navigated, not calibrated again).
    """
    import pickle

    done = list(done or [])
    sensors = [d[1] for d in done]
    cals = [d[2] for d in done]
    gens = [d[3] for d in done]
    if done:
        seeds = [d[0] for d in done]
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds if not sensors else []:
            gen = generators[seed % len(generators)]
            sensor = draw_sensor(seed, arw)
            cals.append(calibrate(sensor, seed, gen, Path(tmp)))
            sensors.append(sensor)
            gens.append(gen)
            for f in Path(tmp).iterdir():  # bags are large: keep only this seed's outputs
                if f.is_dir():
                    import shutil

                    shutil.rmtree(f)
            if keep is not None:
                done.append((seed, sensor, cals[-1], gen))
                keep.write_bytes(pickle.dumps(done))
            if log is not None:
                log(f'  seed {seed} ({gen}) calibrated')
    k_err = np.array([[abs(np.linalg.norm(np.linalg.inv(c.m)[i]) ** -1 / s.k[i] - 1)
                       for i in range(3)] for c, s in zip(cals, sensors, strict=True)])
    static = navigate('static', static_s, 1.0, sensors, cals, seeds)
    man = navigate('manoeuvring', manoeuvre_s, 0.1, sensors, cals, seeds)
    return {'static': static, 'manoeuvring': man, 'generators': gens, 'k_error': k_err,
            'seeds': list(seeds), 'arw': arw, 'exported': [c.exported for c in cals]}


def table(result: dict[str, Any], kind: str, label: str) -> list[str]:
    """Markdown rows: rms and 95th percentile of heading and tilt error at the end."""
    nav: NavRun = result[kind]
    lines = [f'{label}, ARW {result["arw"]:g} °/√h, {len(result["seeds"])} seeds',
             '', '| error at the end | calibrated | baseline (no tool) | raw (bias never '
             'removed) |', '|---|---|---|---|']
    for what, data in (('heading', nav.heading_deg), ('tilt', nav.tilt_deg)):
        for stat in ('rms', '95th pct'):
            cells = []
            for s in STREAMS:
                v = np.abs(np.array(data[s]))
                x = math.sqrt(float(np.mean(v ** 2))) if stat == 'rms' else float(
                    np.percentile(v, 95))
                cells.append(f'{x:.4f}°' if x >= 1e-3 else f'{x:.2e}°')
            lines.append(f'| {what} {stat} | ' + ' | '.join(cells) + ' |')
    nees = np.array(nav.nees)
    lines.append(f'| NEES (calibrated, stated covariance; 1 expected) | mean {nees.mean():.2f}, '
                 f'median {np.median(nees):.2f}, {100 * np.mean(nees * 3 < 7.815):.0f} % < '
                 'χ²₃(95 %)/3 | | |')
    return lines


def merged(parts: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Runs of the same ARW (seed ranges run apart) joined, in ARW order."""
    by_arw: dict[float, dict[str, Any]] = {}
    for r in parts:
        have = by_arw.get(r['arw'])
        if have is None:
            by_arw[r['arw']] = r
            continue
        for kind in ('static', 'manoeuvring'):
            for attr in ('heading_deg', 'tilt_deg'):
                for s in STREAMS:
                    getattr(have[kind], attr)[s] += getattr(r[kind], attr)[s]
            have[kind].nees += r[kind].nees
        have['generators'] += r['generators']
        have['seeds'] += r['seeds']
        have['exported'] += r['exported']
        have['k_error'] = np.vstack((have['k_error'], r['k_error']))
    return [by_arw[k] for k in sorted(by_arw)]


def report(r: dict[str, Any], static_s: float, manoeuvre_s: float) -> list[str]:
    """The tables of one ARW, with the per-generator split and the K precision."""
    lines = [''] + table(r, 'static', f'static {static_s:g} s') + [''] + table(
        r, 'manoeuvring', f'60 s at rest, then manoeuvring to {manoeuvre_s:g} s')
    gens = np.array(r['generators'])
    lines.append('')
    for gen in sorted(set(gens)):
        sel = gens == gen
        h = {s: np.array(r['manoeuvring'].heading_deg[s])[sel] for s in STREAMS}
        lines.append(f'{gen} bench ({int(sel.sum())} seeds): manoeuvring heading rms '
                     + ', '.join(f'{s} {math.sqrt(float(np.mean(h[s] ** 2))):.4f}°'
                                 for s in STREAMS)
                     + '; calibrated NEES mean '
                     f'{np.mean(np.array(r["manoeuvring"].nees)[sel]):.2f} (manoeuvring), '
                     f'{np.mean(np.array(r["static"].nees)[sel]):.2f} (static)')
    q = np.percentile(r['k_error'], 95, axis=0)
    lines.append(f'|ΔK/K| of the calibration, 95th percentile over seeds: K_x {q[0]:.2e}, '
                 f'K_y {q[1]:.2e}, K_z {q[2]:.2e}')
    n_exp = int(np.sum(r['exported']))
    lines.append(f'noise run resolved the ARW (GTSAM export written) for {n_exp} of '
                 f'{len(r["seeds"])} seeds' + ('' if n_exp == len(r['seeds']) else
                                               '; without it the NEES has no ARW term'))
    return lines


def main(argv: list[str] | None = None) -> int:
    """Print the tables (and the figure with --plot); --save/--merge for split runs."""
    import pickle

    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seeds', type=int, default=50)
    p.add_argument('--first-seed', type=int, default=0)
    p.add_argument('--arw', nargs='+', type=float, default=list(ARWS))
    p.add_argument('--static-s', type=float, default=3600.0)
    p.add_argument('--manoeuvre-s', type=float, default=960.0)
    p.add_argument('--plot', type=Path, metavar='DIR')
    p.add_argument('--save', type=Path, metavar='FILE', help='pickle the runs (to --merge)')
    p.add_argument('--merge', type=Path, nargs='+', metavar='FILE',
                   help='print the tables of saved runs together instead of running')
    p.add_argument('--from-calibrations', type=Path, nargs='+', metavar='FILE',
                   help='navigate the calibrations --save kept (FILE.calibrations), one ARW')
    a = p.parse_args(argv)
    started = time.time()

    def log(text: str) -> None:
        print(f'{text} ({time.time() - started:.0f} s)', file=sys.stderr, flush=True)

    if a.merge:
        results = merged([r for f in a.merge for r in pickle.loads(f.read_bytes())])
    elif a.from_calibrations:
        by_seed = {d[0]: d for f in a.from_calibrations for d in pickle.loads(f.read_bytes())}
        done = [by_seed[k] for k in sorted(by_seed)]  # a seed calibrated twice counts once
        arw = round(math.degrees(done[0][1].arw) * 60.0, 6)
        results = [run([], arw, a.static_s, a.manoeuvre_s, log=log, done=done)]
        if a.save is not None:
            a.save.write_bytes(pickle.dumps(results))
    else:
        seeds = list(range(a.first_seed, a.first_seed + a.seeds))
        results = []
        for arw in a.arw:
            log(f'ARW {arw:g} °/√h')
            keep = None if a.save is None else a.save.with_suffix(f'.{arw:g}.calibrations')
            results.append(run(seeds, arw, a.static_s, a.manoeuvre_s, log=log, keep=keep))
        if a.save is not None:
            a.save.write_bytes(pickle.dumps(results))
    for r in results:
        print('\n'.join(report(r, a.static_s, a.manoeuvre_s)), flush=True)
    if a.plot is not None:
        plot(results, a.plot)
    return 0


def plot(results: list[dict[str, Any]], out_dir: Path) -> None:
    """Bars: rms heading and tilt error at the end per stream, trajectory and ARW."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, kind in zip(axes, ('static', 'manoeuvring'), strict=True):
        labels, width = [], 0.25
        for i, s in enumerate(STREAMS):
            vals = []
            for r in results:
                for what in ('heading_deg', 'tilt_deg'):
                    v = np.array(getattr(r[kind], what)[s])
                    vals.append(math.sqrt(float(np.mean(v ** 2))))
            x = np.arange(len(vals))
            ax.bar(x + (i - 1) * width, vals, width, label=s)
        for r in results:
            for what in ('heading', 'tilt'):
                labels.append(f'{what}\nARW {r["arw"]:g}')
        ax.set_xticks(np.arange(len(labels)), labels, fontsize=8)
        ax.set_yscale('log')
        ax.set_ylabel('rms error at the end (deg)')
        ax.set_title(f'{kind}, {len(results[0]["seeds"])} seeds each')
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / 'navigation_benefit.png', dpi=100)
    print(f'figure: {out_dir / "navigation_benefit.png"}', file=sys.stderr)


if __name__ == '__main__':
    sys.exit(main())
