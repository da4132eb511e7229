"""/diagnostics content: values beside their standard uncertainties, units in the keys."""

from __future__ import annotations

from gyro_calib.rbrlg.calibration import RbrlgCalibrator, calibrate_rbrlg
from gyro_calib.rbrlg.diagnostics import calibration_status
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import simulate_full_procedure
from sim_nodes.rbrlg.procedure import ThetaProcedureConfig
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig


def test_status_before_any_pair_warns_and_names_the_count() -> None:
    ok, message, values = calibration_status(RbrlgCalibrator(), '')
    assert not ok and '0 window pair(s)' in message
    assert values['window_pairs'] == '0' and 'k_tilde_rad_per_pulse' not in values


def test_status_after_the_procedure_carries_every_value_with_its_uncertainty() -> None:
    gyro = RingLaserGyroConfig(sense_axis_azimuth_deg=23.0)
    rec = simulate_full_procedure(ThetaProcedureConfig(), RateTableConfig(), gyro,
                                  TiltedMountConfig(), k_tilde_pairs=2, chunk_samples=2000)
    _, cal = calibrate_rbrlg(rec, latitude_deg=gyro.latitude_deg)
    ok, _, values = calibration_status(cal, 'none')
    assert ok and values['stations'] == '4'
    for name, unit in (('k_tilde', '_rad_per_pulse'), ('fix_error_angle', '_rad'),
                       ('scale_factor', '_rad_per_pulse'), ('bias', '_deg_h'),
                       ('earth_plus_bias', '_deg_h'), ('tilt', '_rad')):
        assert float(values[name + unit]) == float(values[name + unit])  # a plain float
        assert float(values[f'{name}_std_uncertainty{unit}']) >= 0.0
