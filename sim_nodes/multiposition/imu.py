"""A MEMS IMU turned by hand between static poses, simulated from the physics.

The IMU rests in a sequence of poses (gravity along each body axis both ways, then along
the edges between them, each with its own heading) and is turned by hand from one to the
next: a minimum-jerk angle profile about the fixed body axis of the relative rotation, so the
body rate is closed form and the next pose is exactly the previous one composed with that
rotation. The accelerometer senses the specific force (gravity's reaction in the body, plus
the tangential and centripetal terms of its lever arm during a turn), the gyro the body rate
plus the Earth rate. Each sensor reads

    raw = (T·diag(s))⁻¹·true + b + white noise, rounded to the LSB            (§G eq. (3))

with T as the multiposition method writes it (accelerometer: three angles yz, zy, zx; gyro:
six, yz, zy, zx, xz, xy, yx), s the scales and b the biases in the raw unit (the IMU reports
m/s² and rad/s nominally: s ≈ 1). Local g is the WGS 84 normal gravity at the site (no
anomaly). Nothing here imports the method: the simulator is its own account of the physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

Array = npt.NDArray[np.float64]

EARTH_RATE_RAD_S = 7.2921150e-5
"""The Earth's rotation rate, rad/s."""


def normal_gravity_m_s2(latitude_deg: float, height_m: float = 0.0) -> float:
    """WGS 84 normal gravity (Somigliana, free-air gradient to second order), m/s²."""
    a, f, m = 6378137.0, 1 / 298.257223563, 0.00344978650684
    gamma_e, k, e2 = 9.7803253359, 0.00193185265241, 6.69437999013e-3
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    g0 = gamma_e * (1 + k * s2) / math.sqrt(1 - e2 * s2)
    return g0 * (1 - 2 / a * (1 + f + m - 2 * f * s2) * height_m + 3 / a ** 2 * height_m ** 2)


def misalignment_matrix(angles: tuple[float, ...]) -> Array:
    """T of §G eq. (3) from 3 (accelerometer) or 6 (gyro) angles, rad."""
    yz, zy, zx, xz, xy, yx = (*angles, 0.0, 0.0, 0.0) if len(angles) == 3 else angles
    return np.array([[1.0, -yz, zy], [xz, 1.0, -zx], [-xy, yx, 1.0]])


@dataclass(frozen=True, slots=True)
class MemsImuConfig:
    """The IMU's true errors and noise (raw unit: m/s² and rad/s nominally).

    Attributes:
        acc_misalignment_rad: yz, zy, zx.
        acc_scale: s per axis, (m/s²) per raw unit.
        acc_bias: b per axis, raw.
        gyro_misalignment_rad: yz, zy, zx, xz, xy, yx (the gyro axes against the
            accelerometer frame).
        gyro_scale: s per axis, (rad/s) per raw unit.
        gyro_bias: b per axis, raw.
        acc_noise: white noise per sample, raw.
        gyro_noise: white noise per sample, raw.
        lever_arm_m: the accelerometer's offset from the turn axes, m (body frame).
        acc_lsb: the accelerometer's output resolution, raw (0: none).
        gyro_lsb: the gyro's output resolution, raw (0: none).
    """

    acc_misalignment_rad: tuple[float, float, float] = (0.004, -0.006, 0.009)
    acc_scale: tuple[float, float, float] = (1.012, 0.991, 1.004)
    acc_bias: tuple[float, float, float] = (0.12, -0.21, 0.35)
    gyro_misalignment_rad: tuple[float, ...] = (0.006, -0.004, 0.011, -0.008, 0.005, 0.007)
    gyro_scale: tuple[float, float, float] = (0.985, 1.018, 1.007)
    gyro_bias: tuple[float, float, float] = (0.011, -0.007, 0.004)
    acc_noise: float = 0.02
    gyro_noise: float = 0.002
    lever_arm_m: tuple[float, float, float] = (0.03, -0.02, 0.04)
    acc_lsb: float = 0.0
    gyro_lsb: float = 0.0

    def acc_truth(self) -> Array:
        """The accelerometer in the method's parameter order (angles, scales, biases)."""
        return np.array([*self.acc_misalignment_rad, *self.acc_scale, *self.acc_bias])

    def gyro_truth(self) -> Array:
        """The gyro in the method's parameter order (angles, scales, biases)."""
        return np.array([*self.gyro_misalignment_rad, *self.gyro_scale, *self.gyro_bias])


FACES = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))
EDGES = ((1, 1, 0), (-1, 1, 0), (-1, -1, 0), (1, -1, 0), (1, 0, 1), (-1, 0, 1), (-1, 0, -1),
         (1, 0, -1), (0, 1, 1), (0, -1, 1), (0, -1, -1), (0, 1, -1))


@dataclass(frozen=True, slots=True)
class PoseProcedureConfig:
    """The hand-turned procedure.

    Attributes:
        up_axes: the body direction pointing up in each pose (normalised), in order.
        tilt_jitter_deg: how far a hand puts each pose off that direction (1σ per axis), °.
        first_rest_s: the first rest, s.
        rest_s: the other rests, uniform in this range, s.
        turn_s: each turn's duration, uniform in this range, s.
        sample_rate_hz: the IMU's output rate, Hz.
        latitude_deg: the site (Earth rate and g).
        seed: of the headings, jitter, durations and noise.
    """

    up_axes: tuple[tuple[int, int, int], ...] = FACES + EDGES
    tilt_jitter_deg: float = 3.0
    first_rest_s: float = 6.0
    rest_s: tuple[float, float] = (3.0, 4.5)
    turn_s: tuple[float, float] = (1.5, 2.5)
    sample_rate_hz: float = 50.0
    latitude_deg: float = 45.0
    seed: int = 38


@dataclass(frozen=True, slots=True)
class HandTurnedRun:
    """A simulated run: stamps from 0, raw samples, and where the IMU was at rest.

    Attributes:
        t_s: sample instants, s from the start.
        acc: raw accelerometer samples (N×3).
        gyro: raw gyro samples (N×3).
        at_rest: True where the IMU rests.
        gravity_m_s2: the g simulated.
    """

    t_s: Array
    acc: Array
    gyro: Array
    at_rest: npt.NDArray[np.bool_]
    gravity_m_s2: float
    poses: int = field(default=0)


def _pose(up: Array, heading: float, jitter: Array) -> Rotation:
    """Body → local level (ENU) with body direction ``up`` up, turned by ``heading``."""
    level = Rotation.align_vectors(np.array([[0.0, 0.0, 1.0]]), up[None, :])[0]
    return Rotation.from_rotvec(jitter) * Rotation.from_euler('z', heading) * level


def simulate(imu: MemsImuConfig, procedure: PoseProcedureConfig) -> HandTurnedRun:
    """The whole run, deterministic from ``procedure.seed``."""
    rng = np.random.default_rng(procedure.seed)
    dt = 1.0 / procedure.sample_rate_hz
    lever = np.asarray(imu.lever_arm_m, dtype=float)
    times, rots, rates, lin, rest = [], [], [], [], []
    t0 = 0.0
    pose = None
    for k, up in enumerate(procedure.up_axes):
        u = np.asarray(up, dtype=float)
        target = _pose(u / np.linalg.norm(u), rng.uniform(0, 2 * math.pi),
                       np.radians(rng.normal(0, procedure.tilt_jitter_deg, 3)))
        if pose is not None:  # the turn from the previous pose to this one
            rotvec = (pose.inv() * target).as_rotvec()
            angle = float(np.linalg.norm(rotvec))
            axis = rotvec / angle
            n = int(round(rng.uniform(*procedure.turn_s) * procedure.sample_rate_hz))
            dur = n * dt
            tau = np.arange(1, n + 1) / n
            theta = angle * (10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5)
            theta_dot = angle / dur * (30 * tau ** 2 - 60 * tau ** 3 + 30 * tau ** 4)
            theta_ddot = angle / dur ** 2 * (60 * tau - 180 * tau ** 2 + 120 * tau ** 3)
            w = axis[None, :] * theta_dot[:, None]
            alpha = axis[None, :] * theta_ddot[:, None]
            times.append(t0 + dt * np.arange(n))
            rots.append(pose * Rotation.from_rotvec(axis[None, :] * theta[:, None]))
            rates.append(w)
            lin.append(np.cross(alpha, lever) + np.cross(w, np.cross(w, lever)))
            rest.append(np.zeros(n, dtype=bool))
            t0 += n * dt
            target = rots[-1][-1]  # exactly where the turn ended
        pose = target
        n = int(round((procedure.first_rest_s if k == 0 else rng.uniform(*procedure.rest_s))
                      * procedure.sample_rate_hz))
        times.append(t0 + dt * np.arange(n))
        rots.append(Rotation.concatenate([pose] * n))
        rates.append(np.zeros((n, 3)))
        lin.append(np.zeros((n, 3)))
        rest.append(np.ones(n, dtype=bool))
        t0 += n * dt
    t = np.concatenate(times)
    c = Rotation.concatenate(rots)
    g = normal_gravity_m_s2(procedure.latitude_deg)
    lat = math.radians(procedure.latitude_deg)
    earth = EARTH_RATE_RAD_S * np.array([0.0, math.cos(lat), math.sin(lat)])
    f_body = c.inv().apply(np.array([0.0, 0.0, g])) + np.concatenate(lin)
    w_body = np.concatenate(rates) + c.inv().apply(earth)
    acc_from = np.linalg.inv(misalignment_matrix(imu.acc_misalignment_rad)
                             @ np.diag(imu.acc_scale))
    gyro_from = np.linalg.inv(misalignment_matrix(imu.gyro_misalignment_rad)
                              @ np.diag(imu.gyro_scale))
    acc = f_body @ acc_from.T + np.asarray(imu.acc_bias) + rng.normal(0, imu.acc_noise,
                                                                      (len(t), 3))
    gyro = w_body @ gyro_from.T + np.asarray(imu.gyro_bias) + rng.normal(0, imu.gyro_noise,
                                                                         (len(t), 3))
    if imu.acc_lsb > 0:
        acc = np.round(acc / imu.acc_lsb) * imu.acc_lsb
    if imu.gyro_lsb > 0:
        gyro = np.round(gyro / imu.gyro_lsb) * imu.gyro_lsb
    return HandTurnedRun(t, acc, gyro, np.concatenate(rest), g, len(procedure.up_axes))
