"""What the calibration reports on /diagnostics, as plain strings (no ROS import).

Keys carry their units; every value has its ``_std_uncertainty`` twin. The node only
wraps the result in a diagnostic_msgs/DiagnosticStatus.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gyro_calib.errors import InsufficientDataError
from gyro_calib.units import RAD_PER_ARCSEC

if TYPE_CHECKING:
    from gyro_calib.rbrlg.calibration import RbrlgCalibrator


def calibration_status(bench: RbrlgCalibrator, last_rejection: str) -> tuple[bool, str,
                                                                             dict[str, str]]:
    """(ok, message, values): ok once K̃ is measured; values as strings, floats by repr."""
    cal = bench.k_tilde
    values = {
        'window_pairs': str(len(cal.pairs)),
        'windows_accepted': str(len(cal.windows)),
        'windows_rejected': str(len(cal.rejections)),
        'pulse_samples_missing': str(sum(w.pulse_samples_missing for w in cal.windows)),
        'last_rejection': last_rejection,
        'pulse_stream_dropped': cal.pulses.stats.summary(),
        'table_stream_dropped': cal.table.stats.summary(),
        'stations': str(len(bench.stations.stations)),
    }
    try:
        k = cal.k_tilde()
    except InsufficientDataError as exc:
        return False, str(exc), values
    res = bench.results()
    # (name, unit suffix) -> (value, standard uncertainty)
    quantities = {
        ('k_tilde', '_rad_per_pulse'): (k.value * RAD_PER_ARCSEC,
                                        k.std_uncertainty * RAD_PER_ARCSEC),
        ('k_tilde', '_arcsec_per_pulse'): (k.value, k.std_uncertainty),
    }
    if res.earth_plus_bias_deg_h is not None:
        eb = res.earth_plus_bias_deg_h
        quantities[('earth_plus_bias', '_deg_h')] = (eb.value, eb.std_uncertainty)
    if res.fix_error is not None:
        theta, tilt = res.fix_error.fix_error_angle_rad, res.fix_error.tilt_rad
        quantities[('fix_error_angle', '_rad')] = (theta.value, theta.std_uncertainty)
        quantities[('tilt', '_rad')] = (tilt.value, tilt.std_uncertainty)
    if res.scale_factor_arcsec_per_pulse is not None:
        kk = res.scale_factor_arcsec_per_pulse
        quantities[('scale_factor', '_rad_per_pulse')] = (kk.value * RAD_PER_ARCSEC,
                                                           kk.std_uncertainty * RAD_PER_ARCSEC)
    if res.bias_deg_h is not None:
        quantities[('bias', '_deg_h')] = (res.bias_deg_h.value, res.bias_deg_h.std_uncertainty)
    for (name, unit), (value, std) in quantities.items():
        values[name + unit] = repr(float(value))
        values[f'{name}_std_uncertainty{unit}'] = repr(float(std))
    return True, f'K̃ from {k.n_used} window pairs', values
