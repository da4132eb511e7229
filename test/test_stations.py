"""θ from the simulated position-table procedure, through the same windows as K̃."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gyro_calib.rbrlg.stations import calibrate_fix_error_angle
from gyro_calib.units import ARCSEC_PER_RAD
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import (
    ThetaRecording,
    simulate_theta_procedure,
    true_k_tilde_arcsec_per_pulse,
)
from sim_nodes.rbrlg.procedure import ThetaProcedureConfig
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig

QUIET_TABLE = RateTableConfig(zero_index_jitter_arcsec=0.0, encoder_counts_per_rev=0)
QUIET_GYRO = RingLaserGyroConfig(angle_random_walk_deg_sqrt_h=0.0, sense_axis_azimuth_deg=23.0)


def _run(gyro: RingLaserGyroConfig, stations: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0),
         mount: TiltedMountConfig | None = None) -> ThetaRecording:
    return simulate_theta_procedure(ThetaProcedureConfig(stations_deg=stations), QUIET_TABLE,
                                    gyro, mount or TiltedMountConfig(), chunk_samples=2000)


def _theta(rec: ThetaRecording, gyro: RingLaserGyroConfig):  # noqa: ANN202
    return calibrate_fix_error_angle(
        (rec.pulse_t_ns, rec.pulse_counts), rec.position_table, rec.position_zero_index_ns,
        rec.rate_table, k_tilde_arcsec_per_pulse=true_k_tilde_arcsec_per_pulse(gyro))


def test_noise_free_unquantised_procedure_recovers_theta_beta0_alpha_to_0_01_arcsec() -> None:
    """Earth rate and bias on: they cancel in the half-difference (METHODS §A.3)."""
    gyro = dataclasses.replace(QUIET_GYRO, quantise=False, bias_drift_deg_h_per_h=0.0)
    res, cal = _theta(_run(gyro), gyro)
    assert len(cal.stations) == 4 and not cal.rejections
    assert abs(res.fix_error_angle_rad.value * ARCSEC_PER_RAD - 646.75) < 0.01
    assert abs(np.degrees(res.beta0_rad.value) - 23.0) * 3600 < 0.01
    assert abs(np.degrees(res.tilt_rad.value) - 45.0) * 3600 < 0.01


def test_integer_pulses_limit_theta_to_a_few_thousandths_of_an_arcsec() -> None:
    res, _ = _theta(_run(QUIET_GYRO), QUIET_GYRO)
    assert abs(res.fix_error_angle_rad.value * ARCSEC_PER_RAD - 646.75) < 0.005
    assert abs(np.degrees(res.tilt_rad.value) - 45.0) * 3600 < 0.01
    # β₀ is amplified by 1/sin θ: one hundredth of a pulse moves it by ~0.6″
    assert abs(np.degrees(res.beta0_rad.value) - 23.0) * 3600 < 1.0


def test_wobble_of_the_position_table_axis_moves_theta_by_less_than_its_size() -> None:
    res, _ = _theta(_run(QUIET_GYRO, mount=TiltedMountConfig(wobble_arcsec=0.5)), QUIET_GYRO)
    assert abs(res.fix_error_angle_rad.value * ARCSEC_PER_RAD - 646.75) < 0.5 * np.sqrt(2)


def test_stations_all_at_one_beta_say_theta_is_unobservable() -> None:
    from gyro_calib.errors import InsufficientDataError

    with pytest.raises(InsufficientDataError, match='unobservable'):
        _theta(_run(QUIET_GYRO, stations=(30.0, 30.0, 30.0, 30.0)), QUIET_GYRO)
