"""The Ferraris variant: six static positions and three known turns (docs/methods.md §G.6).

Ferraris, Grimaldi and Parvis (Sensors and Materials 7(5), 1995), as imucal computes it: with
U₊, U₋ the 3×3 matrices whose columns are the raw accelerometer means with axis i up and
down,

    b_a = diag((U₊ + U₋)/2),  K_a = diag(√diag(U_d U_dᵀ)/(2g)),  R_a = K_a⁻¹ U_d/(2g)   (10)

(U_d = U₊ − U₋); raw = K_a R_a a + b_a. The gyro bias b_g is the mean of all samples of
the six static positions, its g-sensitivity K_ga = (G₊ − G₋)/(2g) from the gyro means; the
turn about axis i by the known angle θ gives column i of W = Σ_t (raw − K_ga a_t − b_g)/f_s,
and

    K_g = diag(√diag(W Wᵀ)/θ²),  R_g = K_g⁻¹ W/θ                                       (11)

raw = K_g R_g ω + K_ga a + b_g. The uncertainty propagates the sample noise of every section
mean and turn sum through (10)–(11) (numerical Jacobian, eq. (8)); the positions are taken as
exactly aligned with gravity and the turns as exactly θ (Ferraris' assumptions): a placement
error is not in the uncertainty, as the basis line says.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gyro_calib.multiposition.recording import Array, Recording

POSITIONS = ('x_p', 'x_a', 'y_p', 'y_a', 'z_p', 'z_a')
"""The six static positions (imucal's labels: axis up 'p', down 'a')."""
TURNS = ('x_rot', 'y_rot', 'z_rot')
"""The three turns."""
OUTPUTS = ('K_a', 'R_a', 'b_a', 'K_g', 'R_g', 'K_ga', 'b_g')
"""The result's matrices, in the order of the flat vector."""
_SHAPES = {'K_a': (3,), 'R_a': (3, 3), 'b_a': (3,), 'K_g': (3,), 'R_g': (3, 3),
           'K_ga': (3, 3), 'b_g': (3,)}


@dataclass(frozen=True, slots=True)
class FerrarisResult:
    """The Ferraris calibration (imucal's matrices; K_a, K_g as their diagonals).

    Attributes:
        values: name → array (K_a, K_g: (3,) diagonals; R_a, R_g, K_ga 3×3; b_a, b_g (3,)).
        covariance: of the flat vector (K_a, R_a row-major, b_a, K_g, R_g, K_ga, b_g).
        n_used: samples in the sections.
        basis: what the uncertainty rests on.
    """

    values: dict[str, Array]
    covariance: Array
    n_used: int
    basis: str

    def std(self, name: str) -> Array:
        """The standard uncertainty of one output, shaped like it."""
        start = 0
        for n in OUTPUTS:
            size = int(np.prod(_SHAPES[n]))
            if n == name:
                d = np.diag(self.covariance)[start:start + size]
                return np.sqrt(d).reshape(_SHAPES[n])
            start += size
        raise KeyError(name)

    def calibrate(self, acc: Array, gyro: Array) -> tuple[Array, Array]:
        """Calibrated accelerometer and gyro samples (raw → SI by (10)–(11))."""
        v = self.values
        a = (acc - v['b_a']) @ np.linalg.inv(np.diag(v['K_a']) @ v['R_a']).T
        w = (gyro - a @ v['K_ga'].T - v['b_g']) @ np.linalg.inv(np.diag(v['K_g'])
                                                                 @ v['R_g']).T
        return a, w


def _solve(x: Array, g: float, angle: float, weights: Array) -> Array:
    """Eqs. (10)–(11) on the section statistics x (flat), the outputs flat."""
    acc_means = x[:18].reshape(6, 3)
    gyro_means = x[18:36].reshape(6, 3)
    gyro_sums = x[36:45].reshape(3, 3)   # Σ raw/f_s per turn
    acc_sums = x[45:54].reshape(3, 3)    # Σ raw/f_s per turn
    durations = x[54:57]                 # n/f_s per turn
    u_p, u_n = acc_means[0::2].T, acc_means[1::2].T
    b_a = np.diag((u_p + u_n) / 2)
    u_d = u_p - u_n
    k_a = np.sqrt(np.diag(u_d @ u_d.T)) / (2 * g)
    r_a = np.diag(1 / k_a) @ u_d / (2 * g)
    b_g = weights @ gyro_means  # the mean of all static samples (imucal)
    k_ga = (gyro_means[0::2].T - gyro_means[1::2].T) / (2 * g)
    a_inv = np.linalg.inv(np.diag(k_a) @ r_a)
    w = np.empty((3, 3))
    for i in range(3):
        a_sum = a_inv @ (acc_sums[i] - b_a * durations[i])  # Σ a_t/f_s
        w[:, i] = gyro_sums[i] - k_ga @ a_sum - b_g * durations[i]
    m = w / angle
    k_g = np.sqrt(np.diag(m @ m.T))
    r_g = np.diag(1 / k_g) @ m
    return np.concatenate((k_a, r_a.ravel(), b_a, k_g, r_g.ravel(), k_ga.ravel(), b_g))


def ferraris(rec: Recording, sections: Mapping[str, tuple[int, int]], *, rate_hz: float,
             gravity: float, angle_rad: float) -> FerrarisResult:
    """The Ferraris calibration of a recording with its sections (start, stop sample).

    ``gravity`` and ``angle_rad`` carry imucal's sign conventions: the value the accelerometer
    reads with the axis 'up', and the signed turn angle in the gyro's unit × s (rad for rad/s;
    imucal works in deg/s, its default −360: clockwise).

    Raises:
        ValueError: a section is missing or empty.
    """
    gone = [s for s in POSITIONS + TURNS if s not in sections]
    if gone:
        raise ValueError(f'no section {gone[0]}; the Ferraris variant needs '
                         f'{", ".join(POSITIONS + TURNS)}.')
    parts = {k: (int(a), int(b)) for k, (a, b) in sections.items()}
    if any(b <= a + 1 for a, b in parts.values()):
        raise ValueError('a Ferraris section holds fewer than two samples.')
    x, var = [], []
    for data in (rec.acc, rec.gyro):
        for s in POSITIONS:
            a, b = parts[s]
            seg = data[a:b]
            x += list(seg.mean(axis=0))
            var += list(seg.var(axis=0, ddof=1) / len(seg))
    static_gyro_var = np.mean([rec.gyro[a:b].var(axis=0, ddof=1)
                               for a, b in (parts[s] for s in POSITIONS)], axis=0)
    static_acc_var = np.mean([rec.acc[a:b].var(axis=0, ddof=1)
                              for a, b in (parts[s] for s in POSITIONS)], axis=0)
    for data, noise in ((rec.gyro, static_gyro_var), (rec.acc, static_acc_var)):
        for s in TURNS:
            a, b = parts[s]
            x += list(data[a:b].sum(axis=0) / rate_hz)
            var += list(noise * (b - a) / rate_hz ** 2)
    x += [(parts[s][1] - parts[s][0]) / rate_hz for s in TURNS]
    var += [0.0, 0.0, 0.0]
    xv = np.array(x)
    sizes = np.array([parts[s][1] - parts[s][0] for s in POSITIONS], dtype=float)
    weights = sizes / sizes.sum()
    y = _solve(xv, gravity, angle_rad, weights)
    jac = np.empty((len(y), len(xv)))
    for j in range(len(xv)):
        h = 1e-7 * max(abs(xv[j]), 1e-6)
        dx = np.zeros(len(xv))
        dx[j] = h
        jac[:, j] = (_solve(xv + dx, gravity, angle_rad, weights)
                      - _solve(xv - dx, gravity, angle_rad, weights)) \
            / (2 * h)
    cov = jac @ np.diag(var) @ jac.T
    values, start = {}, 0
    for n in OUTPUTS:
        size = int(np.prod(_SHAPES[n]))
        values[n] = y[start:start + size].reshape(_SHAPES[n])
        start += size
    n_used = sum(b - a for a, b in parts.values())
    return FerrarisResult(values, 0.5 * (cov + cov.T), n_used,
                          'sample noise of the 6 section means and 3 turn sums propagated; '
                          'positions taken as aligned with gravity, turns as exactly '
                          f'{angle_rad:g} (the gyro unit × s; not in the uncertainty)')
