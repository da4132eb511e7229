"""The hand-off file → the :class:`PulseCalibration` a conversion uses: K, bias or model, ARW."""

from __future__ import annotations

from typing import TYPE_CHECKING

from gyro_calib.handoff import Calibration, HandoffError
from gyro_calib.imu_conversion.calibration import PulseCalibration
from gyro_calib.imu_conversion.fog_scale import (
    FOG_SELF_CAL_KEY,
    FOG_TURNTABLE_KEY,
    fog_pulse_calibration,
)

if TYPE_CHECKING:
    from gyro_calib.thermal.model import ThermalBiasModel


def pulse_calibration(calibration: Calibration, *, use_k_tilde: bool = False,
                      gyro_id: str = '') -> PulseCalibration:
    """The scale factor, bias (or thermal bias model) and ARW the conversion uses.

    Args:
        calibration: the hand-off file's content.
        use_k_tilde: take K̃ as the scale factor (θ = 0: a gyro whose fix-error angle was not
            measured); otherwise K = K̃·cos θ is required (or, with a thermal model, the K
            the model was fitted with). A FOG's file (no such key, but a FOG scale factor)
            goes to :func:`fog_pulse_calibration` instead.
        gyro_id: the gyro this conversion is for ('' = not checked): a thermal model fitted
            on another gyro is refused.

    Raises:
        HandoffError: naming the missing key (``scale_factor_rad_per_pulse``, or
            ``k_tilde_rad_per_pulse`` with ``use_k_tilde``), or a K that disagrees with the
            thermal model's.
        GyroCalibError (ModelFileError, ModelMismatchError): an invalid thermal model, or
            one of another gyro.
    """
    if use_k_tilde:
        key, why = 'k_tilde_rad_per_pulse', 'imu_corrector was told to use K̃ with θ = 0'
    else:
        key, why = 'scale_factor_rad_per_pulse', (
            'K = K̃·cos θ needs the fix-error angle θ; set use_k_tilde to take K̃ with θ = 0')
    arw = calibration.measured('angle_random_walk_rad_per_sqrt_s')
    arw_value = arw[0] if arw else 0.0
    model = thermal_model(calibration, gyro_id=gyro_id)
    if model is not None:
        got = calibration.measured(key)
        k_model = model.scale_factor_rad_per_pulse
        if got is None:
            for other in ('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'):
                beside = calibration.measured(other)
                if beside is not None and abs(beside[0] / k_model - 1.0) > 1e-4:
                    raise HandoffError(
                        f'the calibration\'s {other} = {beside[0]!r} rad/pulse differs from the '
                        f'{k_model!r} rad/pulse its thermal_model was fitted with by '
                        f'{abs(beside[0] / k_model - 1.0) * 1e6:.0f} ppm: the file mixes two '
                        'scale factors (another gyro, or a model fitted with a spec-sheet K); '
                        'refit the thermal model with this K (--calibration FILE).')
            return PulseCalibration(k_model, 0.0, 'thermal_model', 0.0, 0.0, True, arw_value,
                                    model)
        if abs(got[0] / k_model - 1.0) > 1e-4:
            raise HandoffError(
                f'the calibration\'s {key} = {got[0]!r} rad/pulse differs from the '
                f'{k_model!r} rad/pulse its thermal_model was fitted with by more than 100 ppm: '
                'the model\'s bias belongs to that K. Refit the thermal model with this K.')
        return PulseCalibration(got[0], got[1], key, 0.0, 0.0, True, arw_value, model)
    if calibration.measured(key) is None and any(
            calibration.measured(k) is not None for k in (FOG_TURNTABLE_KEY, FOG_SELF_CAL_KEY)):
        return fog_pulse_calibration(calibration)
    k, k_std = calibration.require(key, why=why)
    bias = calibration.measured('bias_rad_s')
    return PulseCalibration(k, k_std, key, bias[0] if bias else 0.0, bias[1] if bias else 0.0,
                            bias is not None, arw_value)


def thermal_model(calibration: Calibration, *, gyro_id: str = '') -> ThermalBiasModel | None:
    """The file's ``thermal_model`` (None without one), checked to belong to the gyro.

    Raises:
        ModelFileError: the mapping is not a valid model.
        ModelMismatchError: the model names another gyro than the file or ``gyro_id``.
    """
    data = calibration.get('thermal_model')
    if data is None:
        return None
    from gyro_calib.thermal.errors import ModelMismatchError
    from gyro_calib.thermal.model import ThermalBiasModel

    model = ThermalBiasModel.from_dict(data, source='the thermal_model of the calibration')
    if calibration.gyro_id and model.gyro_id and calibration.gyro_id != model.gyro_id:
        raise ModelMismatchError(
            f'the calibration file is for gyro {calibration.gyro_id!r} but its thermal_model was '
            f'fitted on gyro {model.gyro_id!r}: the file is inconsistent; recalibrate.')
    for known in (gyro_id, calibration.gyro_id):
        model.check_gyro(known)
    return model
