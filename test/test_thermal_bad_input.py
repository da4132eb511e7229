"""Bad input to the thermal method: a clear reason, never a wrong number."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gyro_calib.errors import ConfigError, GyroCalibError, InsufficientDataError
from gyro_calib.thermal.calibrator import ThermalCalibrator, ThermalSettings, calibrate_thermal
from gyro_calib.thermal.compensate import ThermalBiasTracker, compensate
from gyro_calib.thermal.errors import (
    ExtrapolationError,
    ModelFileError,
    ModelMismatchError,
    TemperatureDataError,
)
from gyro_calib.thermal.model import ThermalBiasModel
from sim_nodes.thermal.chamber import soak_programme
from sim_nodes.thermal.scenarios import (
    ThermalFaults,
    ThermalRecording,
    continuous_ramp_scenario,
    gyro_config,
    simulate_thermal_run,
)

K_RAD = 2.3 * math.pi / 180 / 3600
BASE = dict(scale_factor_rad_per_pulse=K_RAD, latitude_deg=34.26, gyro_id='A-2',
            fit_block_s=20.0, noise_max_span_s=600.0)


def _ramp(faults: ThermalFaults | None = None, **gyro_kw) -> ThermalRecording:  # noqa: ANN003
    gyro = gyro_config('A-2', seed=6, **gyro_kw)
    return continuous_ramp_scenario(gyro=gyro, low_c=-20.0, high_c=20.0, rate_c_per_min=0.5,
                                    dwell_s=900.0, faults=faults)


def _calibrate(rec: ThermalRecording, **kw):  # noqa: ANN003, ANN202
    settings = ThermalSettings(**{**BASE, **kw})
    return calibrate_thermal(rec.pulse_t_ns, rec.pulse_counts, rec.temperature_t_ns,
                             rec.temperature_c, rec.temperature_frame_id, settings)


@pytest.fixture(scope='module')
def clean() -> ThermalRecording:
    return _ramp()


@pytest.fixture(scope='module')
def model(clean: ThermalRecording) -> ThermalBiasModel:
    return _calibrate(clean).model()


def test_no_temperature_topic_is_named_in_the_error(clean: ThermalRecording) -> None:
    settings = ThermalSettings(**BASE)
    with pytest.raises(TemperatureDataError, match='no /gyro/temperature readings at all'):
        calibrate_thermal(clean.pulse_t_ns, clean.pulse_counts, np.zeros(0, np.int64),
                          np.zeros(0), np.zeros(0, str), settings)
    cal = ThermalCalibrator(settings)
    cal.extend_pulses(clean.pulse_t_ns, clean.pulse_counts)
    cal.process(flush=True)
    assert cal.results() == {}
    assert 'cavity' in cal.missing()['thermal_coefficient_const_rad_s']


def test_one_cavity_sensor_missing_names_it_and_the_ids_seen() -> None:
    rec = _ramp(ThermalFaults(drop_sensor='cavity_b'))
    with pytest.raises(TemperatureDataError, match=r'cavity_b.*frame_ids seen: cavity_a, shell'):
        _calibrate(rec)


def test_stuck_sensor_is_found_and_its_span_not_used(clean: ThermalRecording) -> None:
    stuck_from = 2000.0
    rec = _ramp(ThermalFaults(stuck_sensor='cavity_a', stuck_from_s=stuck_from))
    with pytest.raises(TemperatureDataError, match='distinct temperature'):
        _calibrate(rec)  # after the stuck span is removed, one temperature is left
    rec2 = _ramp(ThermalFaults(stuck_sensor='cavity_a', stuck_from_s=9000.0))
    cal = _calibrate(rec2)
    stuck = [r for r in cal.rejections if 'stuck' in r.reason]
    assert len(stuck) == 1 and 'cavity_a' in stuck[0].reason
    t0 = rec2.pulse_t_ns[0]
    assert abs((stuck[0].stamp_ns - t0) / 1e9 - 9000.0) < 2.0
    assert cal.report.rows.t_ns.max() < t0 + 9001 * 10**9


def test_nan_and_dropped_out_sensor_spans_are_rejected_not_interpolated() -> None:
    rec = _ramp(ThermalFaults(nan_sensor='cavity_b', nan_s=(1000.0, 1600.0),
                              dropout_sensor='shell', dropout_s=(3000.0, 3300.0)))
    cal = _calibrate(rec)
    reasons = [r.reason for r in cal.rejections if 'no finite reading' in r.reason]
    assert any('cavity_b' in r and '600 interval' in r for r in reasons)
    assert any('shell' in r and '300 interval' in r for r in reasons)
    assert 'non-finite' in cal.stream_summary
    t = (cal.report.rows.t_ns - rec.pulse_t_ns[0]) / 1e9
    assert not np.any((t > 1010) & (t < 1590))  # no fit block inside the NaN span


def test_too_few_distinct_temperatures_for_the_terms_asked() -> None:
    gyro = gyro_config('A-2', seed=2)
    rec = simulate_thermal_run(gyro, soak_programme([10.0, 20.0], soak_s=3000.0,
                                                    ramp_rate_c_per_min=1.0))
    with pytest.raises(TemperatureDataError,
                       match=r'distinct temperature level.*H\^3 needs at least 5'):
        _calibrate(rec, calibration_style='soak', candidate_terms='static', soak_min_s=600.0,
                   max_h_power=3)


def test_soak_style_without_any_plateau_says_how_to_fix_it(clean: ThermalRecording) -> None:
    with pytest.raises(TemperatureDataError, match='no plateau'):
        _calibrate(clean, calibration_style='soak', candidate_terms='static',
                   soak_min_s=3600.0)


def test_validation_run_outside_the_calibrated_range_is_refused(
        model: ThermalBiasModel) -> None:
    hot = continuous_ramp_scenario(gyro=gyro_config('A-2', seed=7), low_c=10.0, high_c=40.0,
                                   rate_c_per_min=0.5, dwell_s=900.0)
    args = (hot.pulse_t_ns, hot.pulse_counts, hot.temperature_t_ns, hot.temperature_c,
            hot.temperature_frame_id)
    with pytest.raises(ExtrapolationError, match=r'H = 2\d\.\d\d °C at .* outside the calibrated '
                                                 r'range -\d+\.\d\d…\d+\.\d\d °C'):
        compensate(model, *args, gyro_id='A-2')
    rep = compensate(model, *args, gyro_id='A-2', out_of_range='skip')
    assert any('not compensated' in r.reason for r in rep.rejections)
    assert np.all(np.isnan(rep.bias_model_rad_s[rep.h_c > model.h_range_c[1] + 2.0]))


def test_falling_temperature_outside_the_calibrated_rate_range_is_refused() -> None:
    rising = simulate_thermal_run(gyro_config('B-1', seed=3), soak_programme(
        [-20.0, 0.0, 20.0], soak_s=2400.0, ramp_rate_c_per_min=0.5))
    model = _calibrate(rising, candidate_terms='H,H^2,Hdot', validation_fraction=0.0).model()
    assert 'Hdot' in model.terms
    falling = simulate_thermal_run(gyro_config('B-1', seed=4), soak_programme(
        [15.0, -15.0], soak_s=1800.0, ramp_rate_c_per_min=0.5))
    with pytest.raises(ExtrapolationError, match='temperature rate Ḣ = -0.'):
        compensate(model, falling.pulse_t_ns, falling.pulse_counts, falling.temperature_t_ns,
                   falling.temperature_c, falling.temperature_frame_id)


def test_model_of_another_gyro_is_refused(model: ThermalBiasModel,
                                          clean: ThermalRecording) -> None:
    args = (clean.pulse_t_ns, clean.pulse_counts, clean.temperature_t_ns, clean.temperature_c,
            clean.temperature_frame_id)
    with pytest.raises(ModelMismatchError, match="fitted on gyro 'A-2'.*from gyro 'A-1'"):
        compensate(model, *args, gyro_id='A-1')
    with pytest.raises(ModelMismatchError, match='scale factor'):
        compensate(model, *args, scale_factor_rad_per_pulse=K_RAD * 1.001)


def test_unnamed_gyro_with_another_bias_is_flagged_by_its_mean_rate(
        model: ThermalBiasModel) -> None:
    """Identity unknown: the compensated mean rate, far from the Earth rate, says so."""
    other = _ramp()
    other_gyro = gyro_config('B-2', seed=6)
    rec = continuous_ramp_scenario(gyro=other_gyro, low_c=-20.0, high_c=20.0,
                                   rate_c_per_min=0.5, dwell_s=900.0)
    rep = compensate(model, rec.pulse_t_ns, rec.pulse_counts, rec.temperature_t_ns,
                     rec.temperature_c, rec.temperature_frame_id)
    assert any('may belong to another gyro' in n for n in rep.notes)
    assert any('identity not checked' in n for n in rep.notes)
    assert other.gyro_id == 'A-2'


def test_model_needing_the_shell_sensor_refuses_a_recording_without_it() -> None:
    gyro = gyro_config('B-2', seed=1)
    rec = continuous_ramp_scenario(gyro=gyro, low_c=-20.0, high_c=20.0, rate_c_per_min=0.5,
                                   dwell_s=900.0)
    model = _calibrate(rec, candidate_terms='H,dTcs', validation_fraction=0.0,
                       gyro_id='B-2').model()
    assert 'dTcs' in model.terms
    no_shell = continuous_ramp_scenario(gyro=dataclasses.replace(gyro, shell_sensor=False),
                                        low_c=-20.0, high_c=20.0, rate_c_per_min=0.5,
                                        dwell_s=900.0)
    with pytest.raises(ModelMismatchError, match='shell'):
        compensate(model, no_shell.pulse_t_ns, no_shell.pulse_counts,
                   no_shell.temperature_t_ns, no_shell.temperature_c,
                   no_shell.temperature_frame_id, gyro_id='B-2')
    with pytest.raises(TemperatureDataError, match='dTcs'):
        _calibrate(no_shell, candidate_terms='H,dTcs', gyro_id='B-2')


@pytest.mark.parametrize('mutate, match', [
    (lambda d: d.pop('thermal_terms'), 'has no thermal_terms'),
    (lambda d: d.update(thermal_format_version=7), 'thermal_format_version 7'),
    (lambda d: d.update(thermal_coefficients_rad_s=[1.0]), 'coefficients'),
    (lambda d: d.update(thermal_terms=['H', 'T^2']), 'thermal_terms'),
    (lambda d: d.update(thermal_h_scale_c=0.0), 'thermal_h_scale_c'),
    (lambda d: d.update(thermal_latitude_deg='north'), 'thermal_latitude_deg'),
])
def test_broken_model_dict_names_the_key(model: ThermalBiasModel, mutate,  # noqa: ANN001
                                         match: str) -> None:
    d = model.to_dict()
    mutate(d)
    with pytest.raises(ModelFileError, match=match):
        ThermalBiasModel.from_dict(d, source='calib.yaml')


@pytest.mark.parametrize('field, value, match', [
    ('scale_factor_rad_per_pulse', math.nan, 'scale-factor-rad-per-pulse'),
    ('latitude_deg', math.nan, 'latitude'),
    ('p_remove', 0.01, 'p_remove'),
    ('candidate_terms', 'H,T', 'candidate term'),
    ('fit_block_s', 2.5, 'fit_block_s'),
    ('wavelet', 'haar', 'wavelet'),
    ('calibration_style', 'sweep', 'calibration_style'),
    ('denoise', 'yes', 'denoise'),
])
def test_invalid_settings_name_the_field(field: str, value, match: str) -> None:  # noqa: ANN001
    # K and the latitude may be left NaN ("not given") in the settings (node parameters are
    # declared before they are known); the calibrator refuses to start without them
    with pytest.raises(ConfigError, match=match):
        ThermalCalibrator(ThermalSettings(**{**BASE, field: value}))


def test_missing_scale_factor_and_latitude_are_named_together_in_one_line() -> None:
    with pytest.raises(ConfigError) as err:
        ThermalCalibrator(ThermalSettings(gyro_id='A-2'))
    msg = str(err.value)
    assert '\n' not in msg
    assert 'scale_factor_rad_per_pulse = nan' in msg and '--scale-factor-rad-per-pulse' in msg
    assert 'latitude_deg = nan' in msg and '--latitude-deg' in msg


def test_a_bad_value_from_the_bench_names_its_source_once() -> None:
    from gyro_calib.thermal.session import provenance

    bench = "the bag's bench settings"
    text = provenance({'scale_factor_rad_per_pulse': bench, 'latitude_deg': bench,
                       'sense_axis_elevation_deg': bench, 'gyro_id': '--gyro-id'})
    assert text.count(bench) == 1
    assert text == ('scale_factor_rad_per_pulse, latitude_deg and sense_axis_elevation_deg '
                    "from the bag's bench settings; gyro_id from --gyro-id")


def test_soak_style_refuses_dynamic_terms() -> None:
    with pytest.raises(ConfigError, match="only\npowers of H|powers of H"):
        ThermalSettings(**BASE, calibration_style='soak', candidate_terms='dynamic')


def test_pulse_gap_and_counter_glitch_are_rejected_with_their_span(
        clean: ThermalRecording) -> None:
    t, c = clean.pulse_t_ns.copy(), clean.pulse_counts.copy()
    rel = (t - t[0]) / 1e9
    keep = ~((rel > 2000) & (rel < 2030))
    c[rel >= 5000.05] += 1e6  # counter jumps by a million pulses
    cal = calibrate_thermal(t[keep], c[keep], clean.temperature_t_ns, clean.temperature_c,
                            clean.temperature_frame_id, ThermalSettings(**BASE))
    reasons = [r.reason for r in cal.rejections]
    assert any('gap longer than max_pulse_gap_s' in r for r in reasons)
    assert any('counter glitch' in r for r in reasons)
    assert cal.model().residual_std_rad_s < 1e-6  # the glitch did not reach the fit


def test_live_tracker_refuses_before_it_has_data_and_outside_the_range(
        model: ThermalBiasModel) -> None:
    tracker = ThermalBiasTracker(model)
    with pytest.raises(InsufficientDataError):
        tracker.bias()
    for i in range(200):
        for sensor in ('cavity_a', 'cavity_b', 'shell'):
            tracker.add_temperature(i * 10**9, 60.0, sensor)
    with pytest.raises(ExtrapolationError, match='60.00 °C'):
        tracker.bias()


def test_every_thermal_error_is_a_gyro_calib_error() -> None:
    for exc in (ExtrapolationError, ModelFileError, ModelMismatchError, TemperatureDataError):
        assert issubclass(exc, GyroCalibError)


def test_live_tracker_refuses_a_stuck_cavity_sensor(model: ThermalBiasModel) -> None:
    tracker = ThermalBiasTracker(model)
    for i in range(400):
        tracker.add_temperature(i * 10**9, 5.0 + 0.01 * i, 'cavity_a')
        tracker.add_temperature(i * 10**9, 4.55, 'cavity_b')  # frozen while a warms by 4 °C
    with pytest.raises(InsufficientDataError, match='cavity_b .* stuck'):
        tracker.bias()


def test_temperatures_sparser_than_the_averaging_interval_are_interpolated() -> None:
    """Temperatures sparser than the averaging interval are used.

    Sensors read every 2 s (all together) still give a model on 1 s intervals, close to
    the one from the same run read every second.
    """
    sparse, dense = _ramp(temperature_rate_hz=0.5), _ramp()
    rep = _calibrate(sparse).report
    assert any('read about every 2 s: interpolated' in n for n in rep.notes)
    assert not rep.rejections
    ref = _calibrate(dense).report
    both = np.isfinite(rep.bias_model_rad_s) & np.isfinite(ref.bias_model_rad_s)
    gap = np.sqrt(np.mean((rep.bias_model_rad_s - ref.bias_model_rad_s)[both] ** 2))
    assert gap < 0.005 * math.pi / 180 / 3600  # °/h


def test_a_sensor_read_further_apart_than_the_largest_gap_is_refused_in_one_line() -> None:
    rec = _ramp(temperature_rate_hz=1 / 200)
    with pytest.raises(TemperatureDataError) as err:
        _calibrate(rec)
    msg = str(err.value)
    assert '\n' not in msg
    assert 'temperature sensor cavity_a is read about every 200 s' in msg
    assert 'max_temperature_gap_s = 120 s' in msg and 'at least 240 s' in msg
    model = _calibrate(rec, max_temperature_gap_s=240.0).model()
    assert model.max_temperature_gap_s == 240.0
