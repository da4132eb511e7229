"""An IMU recording as the multiposition method reads it (any source)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Recording:
    """Stamped raw accelerometer and gyro samples.

    Attributes:
        t_s: stamps, s (strictly increasing).
        acc: raw accelerometer samples (N×3), ``acc_unit``.
        gyro: raw gyro samples (N×3), ``gyro_unit``.
        acc_unit: e.g. 'm/s²', 'count'.
        gyro_unit: e.g. 'rad/s', 'deg/s', 'count'.
        source: where it was read from.
        nominal_gyro_scale: rad/s per raw gyro unit as the format states it (start value).
        nominal_acc_scale: m/s² per raw accelerometer unit as the format states it.
    """

    t_s: Array
    acc: Array
    gyro: Array
    acc_unit: str
    gyro_unit: str
    source: str = ''
    nominal_gyro_scale: float = 1.0
    nominal_acc_scale: float = 1.0

    def __post_init__(self) -> None:
        """Check shapes and stamps.

        Raises:
            ValueError: shapes differ, not N×3, non-finite samples or stamps not increasing.
        """
        n = len(self.t_s)
        if self.acc.shape != (n, 3) or self.gyro.shape != (n, 3):
            raise ValueError(f'{self.source}: accelerometer and gyro must be N×3 with N = {n} '
                             f'stamps; got {self.acc.shape} and {self.gyro.shape}.')
        if not (np.all(np.isfinite(self.acc)) and np.all(np.isfinite(self.gyro))
                and np.all(np.isfinite(self.t_s))):
            raise ValueError(f'{self.source}: non-finite samples.')
        if n > 1 and np.any(np.diff(self.t_s) <= 0):
            i = int(np.flatnonzero(np.diff(self.t_s) <= 0)[0])
            raise ValueError(f'{self.source}: stamps not increasing at sample {i + 1}.')

    def __len__(self) -> int:
        """Number of samples."""
        return len(self.t_s)
