"""ThermalSession, the thermal method behind the front door.

ThermalSession, the thermal method behind the front door: where K, the site and the gyro
id come from, the hand-off record, the summary, and results independent of batching.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gyro_calib.bagio import SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.cli import main as gyro_calib
from gyro_calib.errors import ConfigError
from gyro_calib.handoff import (
    HandoffError,
    Provenance,
    load_calibration,
    method_calibration,
    update_calibration,
    write_calibration,
)
from gyro_calib.registry import JOINT_STATE, METHODS, TEMPERATURE
from gyro_calib.session import CalibrationOptions
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.session import ThermalSession, thermal_settings
from gyro_calib.thermal.settings import ThermalSettings
from gyro_calib.topics import GYRO_PULSES, GYRO_TEMPERATURE
from sim_nodes.thermal.scenarios import ChamberRunConfig, ThermalRecording

BAGS = Path(__file__).resolve().parents[1] / 'bags'
K_RAD = 2.3 * math.pi / 180 / 3600
LAT = 34.26
RAMP = ChamberRunConfig(programme='continuous_ramp', gyro_id='B-2', seed=4, low_c=-10.0,
                        high_c=10.0, rate_c_per_min=1.0, dwell_s=600.0)


def _batches(rec: ThermalRecording, n: int) -> list[SampleBatch]:
    """The recording as ``n`` batches cut at arbitrary, per-stream different places."""
    names = tuple(dict.fromkeys(rec.temperature_frame_id.tolist()))
    codes = np.array([names.index(f) for f in rec.temperature_frame_id.tolist()], np.int32)
    rng = np.random.default_rng(n)
    cuts_p = np.sort(rng.integers(0, len(rec.pulse_t_ns), n - 1))
    cuts_t = np.sort(rng.integers(0, len(rec.temperature_t_ns), n - 1))
    out = []
    for (a, b), (c, d) in zip(zip(np.r_[0, cuts_p], np.r_[cuts_p, len(rec.pulse_t_ns)]),
                              zip(np.r_[0, cuts_t], np.r_[cuts_t, len(rec.temperature_t_ns)])):
        t = rec.pulse_t_ns[a:b]
        cols = {GYRO_PULSES: TopicColumns(
            GYRO_PULSES, JOINT_STATE, t, t, FrameIds(np.zeros(len(t), np.int32), ('gyro',)),
            {'position': rec.pulse_counts[a:b], 'velocity': np.full(len(t), np.nan)})}
        tt = rec.temperature_t_ns[c:d]
        cols[GYRO_TEMPERATURE] = TopicColumns(
            GYRO_TEMPERATURE, TEMPERATURE, tt, tt, FrameIds(codes[c:d], names),
            {'temperature_degc': rec.temperature_c[c:d],
             'variance_degc2': rec.temperature_variance_c2[c:d]})
        out.append(SampleBatch(cols, len(t) + len(tt), int(max(t[-1:].max(initial=0),
                                                                 tt[-1:].max(initial=0)))))
    return out


@pytest.fixture(scope='module')
def ramp() -> ThermalRecording:
    return RAMP.recording()


def _session(rec: ThermalRecording, n_batches: int = 1,
             **options) -> ThermalSession:  # noqa: ANN003
    opts = dict(scale_factor_rad_per_pulse=K_RAD, latitude_deg=LAT, gyro_id='B-2')
    session = ThermalSession(CalibrationOptions(**{**opts, **options}))
    for batch in _batches(rec, n_batches):
        session.feed(batch)
        session.process()
    session.process(flush=True)
    return session


@pytest.fixture(scope='module')
def session(ramp: ThermalRecording) -> ThermalSession:
    return _session(ramp)


def test_session_is_the_registered_thermal_method(session: ThermalSession) -> None:
    assert METHODS['thermal'].make_session(CalibrationOptions(
        scale_factor_rad_per_pulse=K_RAD, latitude_deg=LAT)).topics() == session.topics()
    assert session.topics() == {GYRO_PULSES: JOINT_STATE, GYRO_TEMPERATURE: TEMPERATURE}


@pytest.mark.parametrize('n_batches', [7, 40])
def test_model_does_not_depend_on_how_the_streams_were_batched(
        session: ThermalSession, ramp: ThermalRecording, n_batches: int) -> None:
    other = _session(ramp, n_batches)
    assert other.results() == session.results()
    assert other.handoff_values() == session.handoff_values()
    assert [r.reason for r in other.rejections()] == [r.reason for r in session.rejections()]


def test_handoff_holds_one_model_mapping_and_merges_with_other_methods(
        session: ThermalSession, tmp_path: Path) -> None:
    values = session.handoff_values()
    assert set(values) >= {'thermal_model', 'thermal_residual_std_rad_s'}
    model = ThermalBiasModel.from_dict(values['thermal_model'])
    assert model == session.report.model  # type: ignore[union-attr]
    assert model.gyro_id == 'B-2' and model.scale_factor_rad_per_pulse == K_RAD
    path = tmp_path / 'gyro.yaml'
    prov = Provenance('rbrlg bench', 0, 10**9)
    write_calibration(path, method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': K_RAD, 'k_tilde_rad_per_pulse_std': 1e-13, 'window_pairs': 3,
        'stations': 0}, prov, gyro_id='B-2'))
    record = session.handoff('live')
    assert record is not None and record.gyro_id == 'B-2'
    update_calibration(path, record)
    merged = load_calibration(path)
    assert merged.get('k_tilde_rad_per_pulse') == K_RAD  # the RBRLG result is kept
    assert ThermalBiasModel.from_dict(merged.get('thermal_model')) == model
    assert set(merged.methods) == {'rbrlg', 'thermal'}
    with pytest.raises(HandoffError, match="holds gyro 'B-2'"):
        update_calibration(path, session.handoff('live', gyro_id='B-3'))  # type: ignore[arg-type]


def test_scale_factor_comes_from_the_flag_then_the_calibration_file_then_the_bag(
        tmp_path: Path) -> None:
    bench = {'bench': {'scale_factor_rad_per_pulse': K_RAD * 1.01, 'latitude_deg': 10.0,
                       'gyro_id': 'BAG', 'sense_axis_elevation_deg': 80.0}}
    settings, origin = thermal_settings(CalibrationOptions(scenario=bench))
    assert settings.scale_factor_rad_per_pulse == K_RAD * 1.01 and settings.latitude_deg == 10.0
    assert settings.gyro_id == 'BAG' and settings.sense_axis_elevation_deg == 80.0
    assert origin['scale_factor_rad_per_pulse'] == 'the bench settings stored in the bag'
    handoff = tmp_path / 'rbrlg.yaml'
    write_calibration(handoff, method_calibration(
        'rbrlg', {'k_tilde_rad_per_pulse': K_RAD, 'k_tilde_rad_per_pulse_std': 1e-13,
                  'window_pairs': 3, 'stations': 0}, Provenance('x', 0, 1), gyro_id='FILE'))
    settings, origin = thermal_settings(CalibrationOptions(scenario=bench,
                                                           calibration_file=handoff))
    assert settings.scale_factor_rad_per_pulse == K_RAD and settings.gyro_id == 'FILE'
    assert 'K̃ with θ = 0' in origin['scale_factor_rad_per_pulse']
    settings, origin = thermal_settings(CalibrationOptions(
        scenario=bench, calibration_file=handoff, scale_factor_rad_per_pulse=K_RAD * 0.99,
        latitude_deg=45.0, gyro_id='FLAG', sense_axis_elevation_deg=60.0))
    assert (settings.scale_factor_rad_per_pulse, settings.latitude_deg, settings.gyro_id,
            settings.sense_axis_elevation_deg) == (K_RAD * 0.99, 45.0, 'FLAG', 60.0)
    assert origin['scale_factor_rad_per_pulse'] == '--scale-factor-rad-per-pulse'


def test_missing_or_unusable_inputs_name_the_flag_or_field(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match='--scale-factor-rad-per-pulse'):
        ThermalSession(CalibrationOptions(latitude_deg=LAT))
    with pytest.raises(ConfigError, match='--latitude-deg'):
        ThermalSession(CalibrationOptions(scale_factor_rad_per_pulse=K_RAD))
    no_k = tmp_path / 'noise.yaml'
    write_calibration(no_k, method_calibration('thermal', {'thermal_residual_std_rad_s': 0.0},
                                               Provenance('x', 0, 1)))
    with pytest.raises(ConfigError, match='holds no scale factor.*--scale-factor-rad-per-pulse'):
        thermal_settings(CalibrationOptions(calibration_file=no_k, latitude_deg=LAT))
    config = tmp_path / 'thermal.yaml'
    config.write_text('thermal_calibration_node:\n  ros__parameters:\n    max_h_power: 9\n')
    with pytest.raises(ConfigError, match=f'max_h_power = 9 .*{config}'):
        ThermalSession(CalibrationOptions(config_file=config, scale_factor_rad_per_pulse=K_RAD,
                                          latitude_deg=LAT))
    config.write_text('max_h_powr: 3\n')
    with pytest.raises(ConfigError, match='unknown field.*max_h_powr'):
        ThermalSession(CalibrationOptions(config_file=config, scale_factor_rad_per_pulse=K_RAD,
                                          latitude_deg=LAT))


def test_node_parameters_are_the_settings_fields(session: ThermalSession) -> None:
    """What MethodNode declares (every field but the common ones) builds the same settings."""
    defaults = ThermalSettings()
    params = {f: getattr(defaults, f) for f in ThermalSettings.__dataclass_fields__
              if f not in ('scale_factor_rad_per_pulse', 'latitude_deg', 'gyro_id')}
    settings, _ = thermal_settings(CalibrationOptions(
        settings=params, scale_factor_rad_per_pulse=K_RAD, latitude_deg=LAT, gyro_id='B-2'))
    assert settings == session.settings


def test_summary_speaks_degrees_per_hour_and_names_terms_snr_and_floor(
        session: ThermalSession) -> None:
    rows = session.summary_rows()
    assert rows[0][0] == 'b0: bias at the centre (°/h)'
    b0 = session.results()['thermal_coefficient_const_rad_s'].value
    assert float(rows[0][1]) == pytest.approx(b0 / (math.pi / 180 / 3600), abs=1e-5)
    text = '\n'.join(session.summary_lines())
    terms = session.report.model.terms  # type: ignore[union-attr]
    for j, term in enumerate(terms, start=1):
        assert f't{j}: {term} coefficient (°/h)' in [r[0] for r in rows]
    assert 'bias = b0' + ''.join(f' + t{j}·{t}' for j, t in enumerate(terms, start=1)) in text
    assert '− -' not in text and '−  -' not in text
    assert 'stepwise over H, H^2, H^3, H^4, Hdot' in text
    assert 'SNR raw → denoised (dB)' in text
    assert 'noise floor of 100 s means' in text
    assert 'held-out check' in text
    m = session.report.model  # type: ignore[union-attr]
    assert m.model_error_n > 0 and (  # u_m in the summary, as the node logs it
        f'{m.model_error_rad_s / (math.pi / 180 / 3600):.4f} °/h from {m.model_error_n} '
        'held-out blocks') in text
    assert 'noise' in session.limiting() or 'misfit' in session.limiting()
    doc = session.json_section()
    json.dumps(doc, allow_nan=False)
    assert doc['thermal_model']['thermal_gyro_id'] == 'B-2'


def test_soak_style_has_no_held_out_check_and_is_still_complete() -> None:
    """Soak style fits soak points only; its JSON stays strict (fit_block_s is NaN)."""
    rec = ChamberRunConfig(programme='paper_soak', gyro_id='A-2', seed=5,
                           pulse_rate_hz=1.0).recording()
    soak = _session(rec, settings={'calibration_style': 'soak', 'candidate_terms': 'static'},
                    gyro_id='A-2')
    assert soak.report is not None and len(soak.report.rows.y_rad_s) == 7  # the 7 set points
    assert soak.missing() == {}
    assert 'thermal_holdout_bias_stability_raw_rad_s' not in soak.handoff_values()
    assert 'no held-out check in this style' in '\n'.join(soak.summary_lines())
    assert 'model error u_m: not estimated' in '\n'.join(soak.summary_lines())
    assert soak.json_section()['thermal_model']['thermal_fit_block_s'] is None
    json.dumps(soak.json_section(), allow_nan=False)


def test_unfitted_session_says_why_for_the_model_key() -> None:
    session = ThermalSession(CalibrationOptions(scale_factor_rad_per_pulse=K_RAD,
                                                latitude_deg=LAT))
    assert session.results() == {} and session.handoff('x') is None
    assert list(session.missing()) == ['thermal_model']
    session.process(flush=True)
    assert 'no /gyro/temperature readings at all' in session.missing()['thermal_model']
    assert session.limiting() == session.missing()['thermal_model']


def test_gyro_calib_info_ends_with_what_limits_the_model(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert gyro_calib(['info', str(BAGS / 'thermal_fault_stuck_sensor')]) == 0
    out = capsys.readouterr().out
    assert '== thermal:' in out and 'cavity_b:' in out
    assert 'limits the result:' in out.splitlines()[-1]
    assert [line for line in out.splitlines() if line.startswith('== ')] == [
        f'== thermal: {METHODS["thermal"].title}']  # the only method these topics reveal
