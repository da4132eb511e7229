"""Rotations integrated from gyro rates, vectorised over motions (§G eq. (5))."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


def quaternions(rotvec: Array) -> Array:
    """Unit quaternions (w, x, y, z) of rotation vectors (…×3), rad."""
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(θ/2)/θ, its series below 1e-8 rad
    k = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0),
                 0.5 - angle ** 2 / 48.0)
    return np.concatenate((np.cos(half), k * rotvec), axis=-1)


def multiply(p: Array, q: Array) -> Array:
    """Hamilton products p·q (…×4)."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack((pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw), axis=-1)


def ordered_product(q: Array) -> Array:
    """q₀·q₁·…·q_{L−1} along axis −2 (M×L×4 → M×4), by pairs: log₂ L vector steps."""
    while q.shape[-2] > 1:
        if q.shape[-2] % 2:
            pad = np.zeros(q.shape[:-2] + (1, 4))
            pad[..., 0] = 1.0
            q = np.concatenate((q, pad), axis=-2)
        q = multiply(q[..., 0::2, :], q[..., 1::2, :])
    return q[..., 0, :]


def matrices(q: Array) -> Array:
    """Rotation matrices (…×3×3) of unit quaternions (…×4)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack((
        np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
        np.stack((2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)), -1),
        np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)), -1)),
        -2)


def body_rotations(steps: Array) -> Array:
    """R_k = Π_i exp([φ_i]×) of each motion's steps φ (M×L×3, body frame), M×3×3.

    R_k maps vectors in the body frame at the motion's end to its start: a fixed direction
    u seen at the start is Rᵀu at the end (§G eq. (5)). Padding steps are zero.
    """
    return matrices(ordered_product(quaternions(steps)))
