"""The whole RBRLG calibration offline: K̃ phase then θ phase, K = K̃·cos θ, bias."""

from __future__ import annotations

import math

import pytest

from gyro_calib.rbrlg.calibration import calibrate_rbrlg, earth_rate_along_table_axis_deg_h
from gyro_calib.units import ARCSEC_PER_RAD
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import simulate_full_procedure
from sim_nodes.rbrlg.procedure import ThetaProcedureConfig
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig


def test_full_procedure_gives_k_theta_and_bias_of_the_simulated_gyro() -> None:
    gyro = RingLaserGyroConfig(sense_axis_azimuth_deg=23.0, seed=4)
    rec = simulate_full_procedure(ThetaProcedureConfig(), RateTableConfig(seed=4), gyro,
                                  TiltedMountConfig(), k_tilde_pairs=4, chunk_samples=2000)
    res, cal = calibrate_rbrlg(rec, latitude_deg=gyro.latitude_deg)
    assert len(cal.k_tilde.pairs) == 4 and len(cal.stations.stations) == 4
    assert not cal.k_tilde.rejections and not cal.stations.rejections
    assert res.fix_error is not None and res.scale_factor_arcsec_per_pulse is not None
    theta = res.fix_error.fix_error_angle_rad.value * ARCSEC_PER_RAD
    assert theta == pytest.approx(646.75, abs=0.2)
    k = res.scale_factor_arcsec_per_pulse
    assert abs(k.value / gyro.scale_factor_arcsec_per_pulse - 1) < 5 * k.relative_uncertainty
    assert k.relative_uncertainty < 3e-8
    assert res.bias_deg_h is not None
    assert abs(res.bias_deg_h.value - gyro.bias_deg_h) < 4 * res.bias_deg_h.std_uncertainty + 1e-3


def test_bias_needs_the_site_latitude() -> None:
    gyro = RingLaserGyroConfig(sense_axis_azimuth_deg=23.0)
    rec = simulate_full_procedure(ThetaProcedureConfig(), RateTableConfig(), gyro,
                                  TiltedMountConfig(), k_tilde_pairs=2, chunk_samples=2000)
    res, _ = calibrate_rbrlg(rec)
    assert res.earth_plus_bias_deg_h is not None
    assert res.bias_deg_h is None  # never a number resting on a guessed latitude


def test_earth_rate_along_a_vertical_axis_is_the_vertical_component() -> None:
    value = earth_rate_along_table_axis_deg_h(latitude_deg=30.0, heading_deg=10.0, tilt_rad=0.0,
                                              position_table_angle_rad=1.0)
    assert value == pytest.approx(15.041 * math.sin(math.radians(30.0)), rel=1e-12)
