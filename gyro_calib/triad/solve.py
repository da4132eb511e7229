"""Solving the pairs, with the tilt α fitted when the position table gave pairs (METHODS §F.3).

:func:`solve_pairs` hands the pairs to :func:`~gyro_calib.triad.estimator.triad_calibration`
(eq. (8)): with position-table (station) pairs the bench tilt α is fitted, its stated
uncertainty as prior; without them the directions do not depend on α and it is no parameter.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from gyro_calib.errors import InsufficientDataError
from gyro_calib.triad.estimator import triad_calibration
from gyro_calib.triad.kinematics import TILT
from gyro_calib.triad.records import BenchParameter, TriadResult

if TYPE_CHECKING:
    from gyro_calib.triad.records import TriadPair


def solve_pairs(pairs: list[tuple[TriadPair, str]], channels: tuple[str, str, str],
                tilt_std_rad: float) -> tuple[TriadResult | None, str]:
    """The estimator's result from the pairs, or None and why (eqs. (7)–(14)).

    ``tilt_std_rad``: the stated uncertainty of the tilt α, its prior when it is fitted.
    """
    outer = any(label.startswith('station') for _, label in pairs)
    params = (BenchParameter(TILT, tilt_std_rad, fitted=True),) if outer else ()
    use = [pr if outer else dataclasses.replace(pr, direction_sensitivity=None)
           for pr, _ in pairs]
    try:
        return triad_calibration(use, channels=channels, parameters=params,
                                 prediction_complete=False), ''
    except InsufficientDataError as exc:
        return None, str(exc)
