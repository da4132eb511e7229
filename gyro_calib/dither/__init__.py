"""Dither-axis misalignment of a mechanically dithered RLG and its coning drift (METHODS §C).

Pure core (no ROS import). Modules:

* :mod:`floor` — the detection floor σ_c and the record / sample rate / table amplitude a
  target needs;
* :mod:`lines` — table motion and the output's own dither line by nonlinear least squares;
* :mod:`regression` — sideband regressors in closed form, block-reduced least squares;
* :mod:`misalignment` — components → a (bias-corrected), rocking bound, acceptance verdict;
* :mod:`coning` — eq. (24) and the dither × rocking coning;
* :mod:`spectral` — the paper's one-orientation spectral method, for comparison (import it
  from there: it pulls in scipy.signal, which the rest does not need);
* :mod:`settings`, :mod:`calibrator` — the streaming :class:`DitherCalibrator` and
  :func:`calibrate_dither`, built from :mod:`block` (judge and reduce one block),
  :mod:`components` (an orientation's sums → its component, clock lock, rocking allowance)
  and :mod:`results` (summary, results, what is missing);
* :mod:`plots` — figures; :mod:`topics` — topic names; :mod:`keys` — hand-off keys for the
  method registry; :mod:`wording` — how angles, durations and stamps are written.
"""

from __future__ import annotations

from gyro_calib.dither.calibrator import (
    RESULT_KEYS,
    DitherCalibrator,
    DitherRecordingArrays,
    calibrate_dither,
)
from gyro_calib.dither.coning import coning_drift
from gyro_calib.dither.floor import (
    detection_floor,
    required_record_s,
    required_sample_rate_hz,
    required_table_rate_amplitude_rad_s,
)
from gyro_calib.dither.settings import DitherSettings

__all__ = [
    'RESULT_KEYS',
    'DitherCalibrator',
    'DitherRecordingArrays',
    'DitherSettings',
    'calibrate_dither',
    'coning_drift',
    'detection_floor',
    'required_record_s',
    'required_sample_rate_hz',
    'required_table_rate_amplitude_rad_s',
]
