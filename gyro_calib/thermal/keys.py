"""Hand-off keys of the temperature bias compensation (METHODS §D).

The bias model (terms, coefficients with their covariance, centring and scaling, calibrated
temperature range, the scale factor and site it was fitted with, the gyro's identity) is one
mapping, ``thermal_model``, validated by :meth:`ThermalBiasModel.from_dict`; the scalars
beside it say how well it fitted and how much it helped.
"""

from __future__ import annotations

from typing import Any

from gyro_calib.handoff import HandoffKey

METHOD = 'thermal'


def _check_model(value: Any) -> str:
    from gyro_calib.errors import GyroCalibError
    from gyro_calib.thermal.model import ThermalBiasModel

    try:
        ThermalBiasModel.from_dict(value)
    except (GyroCalibError, KeyError, TypeError, ValueError) as exc:
        return f'it is not a valid thermal bias model ({exc})'
    return ''


HANDOFF_KEYS = (
    HandoffKey('thermal_model', METHOD, 'the bias model B(H, Ḣ, gradients) the INS subtracts '
               '(§D eqs. (14)/(17), terms chosen by stepwise regression), with its covariance, '
               'calibrated range and the scale factor it was fitted with', 'mapping',
               has_std=False, check=_check_model),
    HandoffKey('thermal_residual_std_rad_s', METHOD, 'std of the fit residuals of the '
               'interval means, rad/s', 'nonnegative', has_std=False),
    HandoffKey('thermal_holdout_bias_stability_raw_rad_s', METHOD, 'bias stability (std of '
               '100 s means) of the held-out data before compensation, rad/s', 'nonnegative'),
    HandoffKey('thermal_holdout_bias_stability_compensated_rad_s', METHOD, 'the same after '
               'subtracting the model, rad/s', 'nonnegative'),
)
