"""A hand-turned IMU written for the tests from the physics alone (not from sim_nodes).

The body rests in random poses and is turned by hand between them: each turn is about its
own axis fixed in the body, by a random angle, with a minimum-jerk angle profile (so the
body rate is closed form); the pose after a turn is the pose before composed with that
exact rotation. The accelerometer senses the specific force (gravity's reaction rotated into
the body, plus the centripetal/tangential terms of a lever arm during turns); the gyro
senses the body rate plus the Earth rate rotated into the body. Each sensor reads
raw = (T·diag(s))⁻¹·(true) + b + noise: white noise of a random level, a slow random-walk
drift of the gyro bias, and (for some units) quantisation to a count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

EARTH_RATE = 7.2921150e-5
"""rad/s."""


@dataclass(frozen=True)
class Unit:
    """One IMU's true parameters (the estimator's layout; see records.misalignment_matrix)."""

    acc_angles: np.ndarray   # yz, zy, zx, rad
    acc_scale: np.ndarray    # (m/s²)/raw
    acc_bias: np.ndarray     # raw
    gyro_angles: np.ndarray  # yz, zy, zx, xz, xy, yx, rad
    gyro_scale: np.ndarray   # (rad/s)/raw
    gyro_bias: np.ndarray    # raw
    acc_noise: float         # raw, per sample
    gyro_noise: float        # raw, per sample
    gyro_drift: float        # raw per √s: bias random walk
    quantum: float           # raw count (0: none)

    def acc_truth(self) -> np.ndarray:
        """Truth in the accelerometer fit's parameter order."""
        return np.concatenate((self.acc_angles, self.acc_scale, self.acc_bias))

    def gyro_truth(self) -> np.ndarray:
        """Truth in the gyro fit's order (bias: its mean over the recording, see record)."""
        return np.concatenate((self.gyro_angles, self.gyro_scale, self.gyro_bias))


def _t(angles: np.ndarray) -> np.ndarray:
    if len(angles) == 3:
        yz, zy, zx = angles
        xz = xy = yx = 0.0
    else:
        yz, zy, zx, xz, xy, yx = angles
    return np.array([[1.0, -yz, zy], [xz, 1.0, -zx], [-xy, yx, 1.0]])


def random_unit(rng: np.random.Generator) -> Unit:
    """A MEMS-like unit reading SI units nominally (sensor_msgs/Imu), errors of %."""
    return Unit(rng.normal(0, 0.01, 3), 1 + rng.normal(0, 0.02, 3), rng.normal(0, 0.2, 3),
                rng.normal(0, 0.01, 6), 1 + rng.normal(0, 0.02, 3), rng.normal(0, 0.02, 3),
                float(rng.uniform(0.005, 0.05)), float(rng.uniform(5e-4, 5e-3)),
                float(rng.uniform(0, 2e-5)), float(rng.choice([0.0, 0.0, 0.002])))


def record(unit: Unit, rng: np.random.Generator, *, poses: int = 18, rate_hz: float = 50.0,
           rest_s: tuple[float, float] = (2.0, 4.0), turn_s: tuple[float, float] = (1.0, 2.0),
           first_rest_s: float = 5.0, g: float = 9.80665,
           latitude_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(t, raw acc, raw gyro, mean gyro bias over the static samples) of one recording."""
    dt = 1.0 / rate_hz
    pose = Rotation.random(random_state=rng)  # body → local level (ENU)
    t_all, rot_all, w_all, lin_all = [], [], [], []
    t0 = 0.0
    lever = rng.normal(0, 0.05, 3)  # m: the accelerometer off the turn axes
    for k in range(poses):
        n_rest = int(round((first_rest_s if k == 0 else rng.uniform(*rest_s)) * rate_hz))
        tt = t0 + dt * np.arange(n_rest)
        t_all.append(tt)
        rot_all += [pose] * n_rest
        w_all.append(np.zeros((n_rest, 3)))
        lin_all.append(np.zeros((n_rest, 3)))
        t0 = tt[-1] + dt
        if k == poses - 1:
            break
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(math.radians(60), math.radians(200))
        n = int(round(rng.uniform(*turn_s) * rate_hz))
        dur = n / rate_hz  # the whole samples' span: θ(τ) and θ'(t) must agree
        tau = np.arange(1, n + 1) / n
        theta = angle * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
        theta_dot = angle / dur * (30 * tau**2 - 60 * tau**3 + 30 * tau**4)
        theta_ddot = angle / dur**2 * (60 * tau - 180 * tau**2 + 120 * tau**3)
        rots = [pose * Rotation.from_rotvec(axis * th) for th in theta]
        w = axis[None, :] * theta_dot[:, None]
        alpha = axis[None, :] * theta_ddot[:, None]
        lin = np.cross(alpha, lever) + np.cross(w, np.cross(w, lever))
        t_all.append(t0 + dt * np.arange(n))
        rot_all += rots
        w_all.append(w)
        lin_all.append(lin)
        t0 = t_all[-1][-1] + dt
        pose = rots[-1]
    t = np.concatenate(t_all)
    w_body = np.concatenate(w_all)
    lin = np.concatenate(lin_all)
    c = Rotation.concatenate(rot_all)
    lat = math.radians(latitude_deg)
    earth = EARTH_RATE * np.array([0.0, math.cos(lat), math.sin(lat)])
    f_body = c.inv().apply(np.array([0.0, 0.0, g])) + lin
    w_true = w_body + c.inv().apply(earth)
    m_acc = np.linalg.inv(_t(unit.acc_angles) @ np.diag(unit.acc_scale))
    m_gyro = np.linalg.inv(_t(unit.gyro_angles) @ np.diag(unit.gyro_scale))
    drift = np.cumsum(rng.normal(0, unit.gyro_drift * math.sqrt(dt), (len(t), 3)), axis=0)
    acc = f_body @ m_acc.T + unit.acc_bias + rng.normal(0, unit.acc_noise, (len(t), 3))
    gyro = (w_true @ m_gyro.T + unit.gyro_bias + drift
            + rng.normal(0, unit.gyro_noise, (len(t), 3)))
    if unit.quantum:
        acc = np.round(acc / unit.quantum) * unit.quantum
        gyro = np.round(gyro / unit.quantum) * unit.quantum
    static = np.all(np.concatenate(w_all) == 0, axis=1)
    mean_bias = unit.gyro_bias + drift[static].mean(axis=0)
    return t, acc, gyro, mean_bias
