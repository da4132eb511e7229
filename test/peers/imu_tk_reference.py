"""IMU-TK's multi-position calibration re-implemented in Python: a test peer, nothing more.

IMU-TK (Tedaldi, Pretto, Menegatti, ICRA 2014; github.com/Kyle-ak/imu_tk at 7780270, a copy of
bitbucket.org/alberto_pretto/imu_tk, BSD) is C++ with Ceres and Qt and is not built here. This
module follows its algorithm as read in its ``src/calibration.cpp``, ``src/filters.cpp``,
``include/imu_tk/base.h``, ``include/imu_tk/integration.h`` and the settings of
``apps/test_imu_calib.cpp`` (written afresh; no code copied), with
``scipy.optimize.least_squares`` in place of Ceres. It exists to give IMU-TK's misalignments,
which IMU-TK's README does not publish, for the comparison in
test/test_multiposition_imu_tk_peer.py. It is not part of gyro_calib.

What IMU-TK does, step by step:

1. The initial rest: samples 0 … the one nearest t₀ + 50 s (``setInitStaticIntervalDuration``).
   Its accelerometer variance per axis (n − 1 divisor), and the norm of that 3-vector, ς₀.
2. Static detector (``staticIntervalsDetector``, window 101 samples): ς(t) is the norm of the
   per-axis variance in the 101 samples centred on t; a run of ς < threshold is an interval.
3. For threshold multiplier m = 2 … 10 (threshold m·ς₀): the intervals with ≥ 100 samples,
   and their *first 100 samples* each (``acc_use_means`` false); at least 12 intervals. The
   accelerometer cost is Σ (g − ‖T_a·K_a·(x − b_a)‖)² over those samples, T_a upper
   unitriangular with the three angles (yz, zy, zx), from scales 1 and biases 32768 counts.
   The multiplier with the smallest final cost wins.
4. Gyro: the bias is the mean of the gyro over the initial rest (not optimised). The gravity
   versors are the normalised means of the *calibrated* accelerometer over each interval with
   ≥ 100 samples of the winning set. Between consecutive intervals the calibrated gyro
   T_g·K_g·(ω − b_g) (six angles) is integrated with IMU-TK's RK4 quaternion step, from the
   last sample of interval i to the sample before the first of interval i + 1, stamps as dt;
   the residual is R_iᵀ·u_i − u_{i+1} (3 per motion), from scales 1/6258.

The model and the parameter names are IMU-TK's: X' = T·K·(X − B) with
T = [[1, −yz, zy], [xz, 1, −zx], [−xy, yx, 1]], the same layout as gyro_calib's
``misalignment_matrix`` (docs/methods/multiposition.md eq. (3)).
"""

from __future__ import annotations

import lzma
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

Array = npt.NDArray[np.float64]

INIT_REST_S = 50.0
"""test_imu_calib: setInitStaticIntervalDuration(50.0)."""
GRAVITY_M_S2 = 9.81744
"""test_imu_calib: setGravityMagnitude(9.81744)."""
WINDOW = 101
"""staticIntervalsDetector's default window, samples."""
INTERVAL_SAMPLES = 100
"""MultiPosCalibration's default interval_n_samples."""
MIN_INTERVALS = 12
"""MultiPosCalibration's min_num_intervals."""
ACC_BIAS_START = 32768.0
"""test_imu_calib: the accelerometer's initial bias, counts."""
GYRO_SCALE_START = 1.0 / 6258.0
"""test_imu_calib: the gyro's initial scale, rad/s per count."""


@dataclass(frozen=True)
class Triad:
    """IMU-TK's CalibratedTriad: angles (yz, zy, zx, xz, xy, yx) rad, scales, biases."""

    misalignment: Array
    scale: Array
    bias: Array

    @property
    def t(self) -> Array:
        """IMU-TK's misalignment matrix T."""
        yz, zy, zx, xz, xy, yx = self.misalignment
        return np.array([[1.0, -yz, zy], [xz, 1.0, -zx], [-xy, yx, 1.0]])

    def unbias_normalize(self, raw: Array) -> Array:
        """T·K·(X − B) for samples (…×3)."""
        return np.asarray((raw - self.bias) @ (self.t @ np.diag(self.scale)).T)


@dataclass(frozen=True)
class ImuTkResult:
    """What IMU-TK's test_imu_calib would print and save."""

    acc: Triad
    gyro: Triad
    intervals: list[tuple[int, int]]
    """The winning multiplier's static intervals (start, end inclusive), all of them."""
    threshold_multiplier: int
    acc_cost: float
    """Ceres' final cost, ½Σr², of the winning accelerometer fit."""
    gyro_cost: float


def load(path: Path) -> tuple[Array, Array]:
    """An IMU-TK ASCII file (``t x y z``), plain or .xz: stamps (s) and samples (N×3)."""
    opener = lzma.open if path.suffix == '.xz' else open
    with opener(path, 'rt') as f:
        data = np.loadtxt(f, ndmin=2)
    return data[:, 0], data[:, 1:4]


def initial_rest_end(t_s: Array, duration_s: float) -> int:
    """DataInterval::initialInterval: the index nearest t₀ + duration (later one on a tie)."""
    end = t_s[0] + duration_s
    if end >= t_s[-1]:
        return len(t_s) - 1
    i1 = int(np.searchsorted(t_s, end, side='left'))  # first stamp ≥ end
    i0 = i1 - 1
    return i0 if end - t_s[i0] < t_s[i1] - end else i1


def variance_norms(samples: Array, window: int = WINDOW) -> Array:
    """ς of every window centre h … N − h − 1: ‖var₍ₙ₋₁₎ per axis‖ over the window."""
    centred = samples - samples.mean(axis=0)
    var = np.empty((len(samples) - window + 1, 3))
    for j in range(3):
        w = np.lib.stride_tricks.sliding_window_view(centred[:, j], window)
        var[:, j] = w.var(axis=1, ddof=1)
    return np.asarray(np.linalg.norm(var, axis=1))


def static_intervals(norms: Array, threshold: float, n: int,
                     window: int = WINDOW) -> list[tuple[int, int]]:
    """staticIntervalsDetector: runs of ς < threshold, (start, end) inclusive sample indices."""
    h = window // 2
    still = norms < threshold
    out: list[tuple[int, int]] = []
    start = -1
    for k, s in enumerate(still):
        i = k + h
        if start < 0 and s:
            start = i
        elif start >= 0 and not s:
            out.append((start, i - 1))
            start = -1
    if start >= 0:
        out.append((start, n - h - 1))
    return out


def long_enough(intervals: list[tuple[int, int]],
                n: int = INTERVAL_SAMPLES) -> list[tuple[int, int]]:
    """The valid intervals of IMU-TK's extractIntervalsSamples: at least n samples."""
    return [(a, b) for a, b in intervals if b - a + 1 >= n]


def _acc_triad(p: Array) -> Triad:
    return Triad(np.concatenate((p[:3], np.zeros(3))), p[3:6], p[6:9])


def fit_accelerometer(samples: Array, g: float) -> tuple[Triad, float]:
    """MultiPosAccResidual over the samples, from IMU-TK's start (scales 1, biases 32768)."""
    def residual(p: Array) -> Array:
        return np.asarray(g - np.linalg.norm(_acc_triad(p).unbias_normalize(samples), axis=1))

    def jacobian(p: Array) -> Array:
        tri = _acc_triad(p)
        d = samples - tri.bias
        y = d @ (tri.t @ np.diag(tri.scale)).T
        r = np.linalg.norm(y, axis=1, keepdims=True)
        e = y / r  # ∂‖y‖/∂y
        sx, sy, sz = tri.scale
        dx, dy, dz = d.T
        jac = np.empty((len(samples), 9))
        jac[:, 0] = -e[:, 0] * sy * dy         # yz: T[0,1] = −yz
        jac[:, 1] = e[:, 0] * sz * dz          # zy: T[0,2]
        jac[:, 2] = -e[:, 1] * sz * dz         # zx: T[1,2] = −zx
        m = tri.t
        for j, dj in enumerate((dx, dy, dz)):
            jac[:, 3 + j] = (e @ m[:, j]) * dj
            jac[:, 6 + j] = -(e @ m[:, j]) * tri.scale[j]
        return -jac

    p0 = np.concatenate((np.zeros(3), np.ones(3), np.full(3, ACC_BIAS_START)))
    sol = least_squares(residual, p0, jac=jacobian, method='lm', x_scale='jac',
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=10000)
    return _acc_triad(sol.x), float(sol.cost)


def omega_matrix(w: Array) -> Array:
    """½·Ω(ω) of IMU-TK's computeOmegaSkew (…×3 → …×4×4): q̇ = ½Ω(ω)q."""
    x, y, z = np.moveaxis(w, -1, 0)
    o = np.zeros(w.shape[:-1] + (4, 4))
    o[..., 0, 1], o[..., 0, 2], o[..., 0, 3] = -x, -y, -z
    o[..., 1, 0], o[..., 1, 2], o[..., 1, 3] = x, z, -y
    o[..., 2, 0], o[..., 2, 1], o[..., 2, 3] = y, -z, x
    o[..., 3, 0], o[..., 3, 1], o[..., 3, 2] = z, y, -x
    return 0.5 * o


def rk4_step_literal(q: Array, w0: Array, w1: Array, dt: float) -> Array:
    """quatIntegrationStepRK4 as IMU-TK writes it, one step (the check of :func:`rk4_steps`)."""
    o0, om, o1 = omega_matrix(w0), omega_matrix(0.5 * (w0 + w1)), omega_matrix(w1)
    k1 = o0 @ q
    k2 = om @ (q + 0.5 * dt * k1)
    k3 = om @ (q + 0.5 * dt * k2)
    k4 = o1 @ (q + dt * k3)
    out = q + dt * (k1 / 6.0 + k2 / 3.0 + k3 / 3.0 + k4 / 6.0)
    return np.asarray(out / np.linalg.norm(out))


def hamilton(p: Array, q: Array) -> Array:
    """Hamilton products p⊗q of quaternions (w, x, y, z), …×4."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack((pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw), axis=-1)


def rk4_steps(w0: Array, w1: Array, dt: Array) -> Array:
    """Each RK4 step as the quaternion a with step(q) ∝ q⊗a (…×4).

    ½Ω(ω)q is q⊗(0, ½ω), so every matrix in the step is a right multiplication and the step
    is q ↦ q⊗a, a = 1 + dt(k1 + 2k2 + 2k3 + k4)/6 with k1 = o₀, k2 = (1 + ½dt·k1)⊗oₘ,
    k3 = (1 + ½dt·k2)⊗oₘ, k4 = (1 + dt·k3)⊗o₁ (o = (0, ½ω), oₘ at the mean rate). IMU-TK
    normalises after each step: a positive factor, which does not change the product's
    direction.
    """
    def pure(w: Array) -> Array:
        return np.concatenate((np.zeros(w.shape[:-1] + (1,)), 0.5 * w), axis=-1)

    one = np.zeros(w0.shape[:-1] + (4,))
    one[..., 0] = 1.0
    h = dt[..., None]
    o0, om, o1 = pure(w0), pure(0.5 * (w0 + w1)), pure(w1)
    k1 = o0
    k2 = hamilton(one + 0.5 * h * k1, om)
    k3 = hamilton(one + 0.5 * h * k2, om)
    k4 = hamilton(one + h * k3, o1)
    return np.asarray(one + h * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0)


def ordered_product(a: Array) -> Array:
    """a₀⊗a₁⊗…⊗a_{L−1} along axis −2 (M×L×4 → M×4, unit), by pairs."""
    while a.shape[-2] > 1:
        if a.shape[-2] % 2:
            pad = np.zeros(a.shape[:-2] + (1, 4))
            pad[..., 0] = 1.0
            a = np.concatenate((a, pad), axis=-2)
        a = hamilton(a[..., 0::2, :], a[..., 1::2, :])
        a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    return a[..., 0, :]


def quaternion_to_rotation(q: Array) -> Array:
    """Ceres' QuaternionToRotation (w, x, y, z), normalised: …×4 → …×3×3."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack((
        np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
        np.stack((2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)), -1),
        np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)), -1)),
        -2)


def motion_spans(t_s: Array, intervals: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The gyro samples each MultiPosGyroResidual integrates over, (first, last) inclusive.

    From the first gyro stamp ≥ the end stamp of interval i to the sample before the first
    gyro stamp ≥ the start stamp of interval i + 1 (the accelerometer's and gyro's stamps are
    the same here, so these are the accelerometer's indices).
    """
    out = []
    for (_, e0), (s1, _) in zip(intervals[:-1], intervals[1:], strict=True):
        i0 = int(np.searchsorted(t_s, t_s[e0], side='left'))
        i1 = int(np.searchsorted(t_s[i0 + 1:], t_s[s1], side='left')) + i0 + 1 - 1
        out.append((i0, i1))
    return out


def _gyro_triad(p: Array, bias: Array) -> Triad:
    return Triad(p[:6], p[6:9], bias)


def fit_gyro(t_s: Array, gyro_unbiased: Array, spans: list[tuple[int, int]],
             u: Array) -> tuple[Array, float]:
    """MultiPosGyroResidual over the motions (bias not optimised), from scales 1/6258."""
    length = max(b - a for a, b in spans)
    w0 = np.zeros((len(spans), length, 3))
    w1 = np.zeros_like(w0)
    dt = np.zeros((len(spans), length))
    for m, (a, b) in enumerate(spans):
        w0[m, :b - a] = gyro_unbiased[a:b]
        w1[m, :b - a] = gyro_unbiased[a + 1:b + 1]
        dt[m, :b - a] = np.diff(t_s[a:b + 1])

    def residual(p: Array) -> Array:
        tk = _gyro_triad(p, np.zeros(3)).t @ np.diag(p[6:9])
        q = ordered_product(rk4_steps(w0 @ tk.T, w1 @ tk.T, dt))  # from the identity
        rot = quaternion_to_rotation(q)
        return np.asarray((np.einsum('kji,kj->ki', rot, u[:-1]) - u[1:]).ravel())

    p0 = np.concatenate((np.zeros(6), np.full(3, GYRO_SCALE_START)))
    sol = least_squares(residual, p0, method='lm', x_scale='jac',
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return sol.x, float(sol.cost)


def calibrate(acc_path: Path, gyro_path: Path, *, g: float = GRAVITY_M_S2,
              init_rest_s: float = INIT_REST_S) -> ImuTkResult:
    """IMU-TK's calibrateAccGyro with test_imu_calib's settings."""
    t_s, acc = load(acc_path)
    t_g, gyro = load(gyro_path)
    rest = initial_rest_end(t_s, init_rest_s)
    norm_th = float(np.linalg.norm(acc[:rest + 1].var(axis=0, ddof=1)))
    norms = variance_norms(acc)
    best: tuple[float, int, list[tuple[int, int]], Triad] | None = None
    for mult in range(2, 11):
        found = static_intervals(norms, mult * norm_th, len(acc))
        used = long_enough(found)
        if len(used) < MIN_INTERVALS:
            continue
        samples = np.concatenate([acc[a:a + INTERVAL_SAMPLES] for a, _ in used])
        tri, cost = fit_accelerometer(samples, g)
        if best is None or cost < best[0]:
            best = (cost, mult, found, tri)
    if best is None:
        raise ValueError('IMU-TK: no threshold multiplier gives 12 intervals')
    acc_cost, mult, found, acc_tri = best
    used = long_enough(found)
    cal = acc_tri.unbias_normalize(acc)
    means = np.array([cal[a:b + 1].mean(axis=0) for a, b in used])
    u = means / np.linalg.norm(means, axis=1, keepdims=True)
    gyro_bias = gyro[:initial_rest_end(t_g, init_rest_s) + 1].mean(axis=0)
    p, gyro_cost = fit_gyro(t_g, gyro - gyro_bias, motion_spans(t_g, used), u)
    return ImuTkResult(acc_tri, _gyro_triad(p, gyro_bias), found, mult, acc_cost, gyro_cost)
