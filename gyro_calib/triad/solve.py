"""Solving the pairs, with the tilt α fitted and each gyro's count random walk (METHODS §F.3).

:func:`solve_pairs` hands the pairs to :func:`~gyro_calib.triad.estimator.triad_calibration`
(eq. (8)): with position-table (station) pairs the bench tilt α is fitted, its stated
uncertainty as prior; without them the directions do not depend on α and it is no parameter.
Each window's count carries the gyro's angle random walk over its length (eq. (6b)): stated
(converted with K̂ of a first solve) or measured from the gyro's own pair residuals (eq. (6c),
solved again until it settles); the prediction is then complete, and the scatter widens it
only where it exceeds the prediction at 99 % (the model is wrong there).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.triad.count_noise import CountWalk, measured_walk, stated_walk, with_count_walk
from gyro_calib.triad.estimator import triad_calibration
from gyro_calib.triad.kinematics import TILT
from gyro_calib.triad.records import BenchParameter, TriadResult

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.records import TriadPair

MEASURE_ITERATIONS = 4
"""Solve–measure rounds of the measured count random walk (it settles in two or three)."""


def solve_pairs(pairs: list[tuple[TriadPair, str]], channels: tuple[str, str, str],
                tilt_std_rad: float, arw_rad_sqrt_s: npt.ArrayLike | None = None,
                ) -> tuple[TriadResult | None, str, CountWalk | None]:
    """The estimator's result from the pairs, or None and why (eqs. (6b)–(14)).

    ``tilt_std_rad``: the stated uncertainty of the tilt α, its prior when it is fitted.
    ``arw_rad_sqrt_s``: the gyros' stated angle random walk (3,), rad/√s; None (or any NaN)
    measures it from the record. Returns the result, why there is none, and the walk used.
    """
    outer = any(label.startswith('station') for _, label in pairs)
    params = (BenchParameter(TILT, tilt_std_rad, fitted=True),) if outer else ()
    fitted = (0,) if outer else ()
    use = [pr if outer else dataclasses.replace(pr, direction_sensitivity=None)
           for pr, _ in pairs]

    def solve(walk: CountWalk | None, model: CountWalk | None = None) -> TriadResult:
        given = use if walk is None else [
            with_count_walk(p, walk.density_pulses2_per_s,
                            None if model is None else model.density_pulses2_per_s)
            for p in use]
        return triad_calibration(given, channels=channels, parameters=params,
                                 prediction_complete=True,
                                 count_noise_dof=None if model is None else model.dof)

    try:
        result = solve(None)
    except InsufficientDataError as exc:
        return None, str(exc), None
    if result.pulses_to_body_rad is None and all(
            c.scale_factor_rad_per_pulse is None for c in result.channels):
        return result, '', None
    stated = None if arw_rad_sqrt_s is None else np.asarray(arw_rad_sqrt_s, dtype=np.float64)
    if stated is not None and stated.shape == (3,) and np.all(np.isfinite(stated)):
        k = np.array([c.scale_factor_rad_per_pulse.value if c.scale_factor_rad_per_pulse
                      is not None else math.nan for c in result.channels])
        walk = stated_walk(stated, k)
        return solve(walk), '', walk
    walk = measured_walk(use, result, fitted, dof_at_most_pairs=False)
    for _ in range(MEASURE_ITERATIONS):
        result = solve(walk)
        again = measured_walk(use, result, fitted, dof_at_most_pairs=False)
        settled = np.allclose(np.nan_to_num(again.density_pulses2_per_s),
                              np.nan_to_num(walk.density_pulses2_per_s), rtol=1e-3, atol=1e-12)
        walk = again
        if settled:
            break
    # The weights' walk above keeps the estimates; the covariance's walk is measured from the
    # same residuals against the count error model (eq. (6a)), the prediction it completes.
    result = solve(walk)
    model = measured_walk([p.as_modelled() for p in use], result, fitted)
    return solve(walk, model), '', model
