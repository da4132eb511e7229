"""The committed scenario bags.

The committed scenario bags: reproducible, readable by rosbags and mcap, and calibrated
offline to their expected results (truth within tolerance, counts, rejection reasons).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import CONTRACT_TYPES, bag_info, iter_raw_messages
from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.rbrlg.session import RbrlgSession
from gyro_calib.units import RAD_PER_ARCSEC
from sim_nodes.rbrlg.scenarios import SCENARIOS as RBRLG_SCENARIOS
from sim_nodes.scenarios import SCENARIOS, write_scenario_files

BAGS = Path(__file__).resolve().parents[1] / 'bags'
MAX_BAG_BYTES = 5 * 1024 * 1024


def _expected(name: str) -> dict:
    return yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))


def _rbrlg(name: str) -> RbrlgSession:
    """The bag calibrated offline (bench settings from the bag's stored scenario)."""
    session = calibrate_bags([BAGS / name]).sessions['rbrlg']
    assert isinstance(session, RbrlgSession)
    return session


def test_every_scenario_has_a_committed_bag_of_at_most_5_mb() -> None:
    for name in SCENARIOS:
        bag = BAGS / name
        assert (bag / 'metadata.yaml').is_file() and (bag / f'{name}.mcap').is_file(), name
        assert sum(f.stat().st_size for f in bag.iterdir()) <= MAX_BAG_BYTES, name
        assert (BAGS / f'{name}.expected.yaml').is_file(), name


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_regenerated_bag_matches_the_committed_one_message_for_message(
        name: str, tmp_path: Path) -> None:
    write_scenario_files(name, tmp_path)
    fresh, committed = iter_raw_messages(tmp_path / name), iter_raw_messages(BAGS / name)
    n = 0
    for n, (a, b) in enumerate(zip(fresh, committed, strict=True), start=1):
        assert a == b, f'{name}: message {n} differs ({a[0]} at {a[2]} ns vs {b[0]} at {b[2]} ns)'
    assert n == bag_info(BAGS / name).message_count
    _assert_same(bag_info(tmp_path / name).scenario, bag_info(BAGS / name).scenario,
                 f'{name}: stored scenario')
    _assert_same(yaml.safe_load((tmp_path / f'{name}.expected.yaml').read_text(encoding='utf-8')),
                 _expected(name), f'{name}.expected.yaml')


DERIVED_RELATIVE_TOLERANCE = 1e-9
"""Floats derived from the bench (the truth of a fit, a predicted uncertainty) may differ in
their last bits between machines: numpy's least squares (np.polyfit → LAPACK) takes
CPU-dependent paths (seen: 44277.957994202916 on one CPU, 44277.95799420295 on an AMD
EPYC). The messages themselves are compared bit for bit."""


def _assert_same(fresh: object, committed: object, where: str) -> None:
    """Equal structure, keys, strings and integers; floats within the relative tolerance."""
    if isinstance(committed, dict):
        assert isinstance(fresh, dict) and fresh.keys() == committed.keys(), (
            f'{where}: keys differ: {sorted(fresh) if isinstance(fresh, dict) else fresh} vs '
            f'{sorted(committed)}')
        for key in committed:
            _assert_same(fresh[key], committed[key], f'{where}.{key}')
    elif isinstance(committed, list):
        assert isinstance(fresh, list) and len(fresh) == len(committed), (where, fresh, committed)
        for i, (a, b) in enumerate(zip(fresh, committed)):
            _assert_same(a, b, f'{where}[{i}]')
    elif isinstance(committed, float) and not isinstance(fresh, bool) and isinstance(
            fresh, (int, float)):
        assert (math.isnan(committed) and math.isnan(fresh)) or math.isclose(
            fresh, committed, rel_tol=DERIVED_RELATIVE_TOLERANCE, abs_tol=0.0), (
            f'{where}: {fresh!r} vs committed {committed!r}')
    else:
        assert type(fresh) is type(committed) and fresh == committed, (
            f'{where}: {fresh!r} vs committed {committed!r}')


def test_derived_floats_are_compared_to_a_relative_tolerance_and_the_rest_exactly() -> None:
    committed = {'truth': {'self_cal_k_counts_per_rad': 44277.957994202916, 'n': 3},
                 'name': 'fog_mapping_self_cal', 'rates': [1.0, math.nan]}
    epyc = {'truth': {'self_cal_k_counts_per_rad': 44277.95799420295, 'n': 3},
            'name': 'fog_mapping_self_cal', 'rates': [1.0, math.nan]}
    _assert_same(epyc, committed, 'x')
    for wrong in ({**epyc, 'name': 'other'}, {**epyc, 'truth': {
            'self_cal_k_counts_per_rad': 44277.96, 'n': 3}},
            {**epyc, 'truth': {'self_cal_k_counts_per_rad': 44277.95799420295, 'n': 4}},
            {**epyc, 'rates': [1.0]}, {**epyc, 'extra': 1}):
        with pytest.raises(AssertionError):
            _assert_same(wrong, committed, 'x')


@pytest.mark.parametrize('name', list(RBRLG_SCENARIOS))
def test_committed_bag_calibrates_offline_to_its_expected_results(name: str) -> None:
    exp = _expected(name)
    session = _rbrlg(name)
    res, cal, rejections = session.rbrlg_results, session.calibrator, session.rejections()
    assert len(cal.k_tilde.pairs) == exp['window_pairs']
    assert len(cal.k_tilde.windows) == exp['windows_accepted']
    assert len(rejections) == exp['rejections'], [r.reason for r in rejections]
    for reason in exp.get('rejection_reasons', []):
        assert any(reason in r.reason for r in rejections), (reason, rejections)
    truth, tol = exp['truth'], exp['tolerance']
    k_tilde = res.k_tilde_arcsec_per_pulse
    assert k_tilde is not None
    assert abs(k_tilde.value / truth['k_tilde_arcsec_per_pulse'] - 1) < tol['k_tilde_relative']
    if 'stations' in exp:
        assert len(cal.stations.stations) == exp['stations']
        assert res.fix_error is not None and res.scale_factor_arcsec_per_pulse is not None
        theta = res.fix_error.fix_error_angle_rad.value / RAD_PER_ARCSEC
        assert abs(theta - truth['fix_error_angle_arcsec']) < tol['fix_error_angle_arcsec']
        assert abs(math.degrees(res.fix_error.tilt_rad.value) - truth['tilt_deg']) \
            < tol['tilt_deg']
        k = res.scale_factor_arcsec_per_pulse.value
        assert abs(k / truth['scale_factor_arcsec_per_pulse'] - 1) < tol['scale_factor_relative']
        assert res.bias_deg_h is not None
        assert abs(res.bias_deg_h.value - exp['bias_deg_h_truth']) < tol['bias_deg_h']
    else:
        assert res.fix_error is None and not cal.stations.stations


@pytest.mark.parametrize('name', ['k_tilde_bench', 'theta_four_position'])
def test_bags_open_in_both_the_rosbags_and_the_mcap_reader(name: str) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.rosbag2 import Reader

    bag = BAGS / name
    with Reader(bag) as reader:
        rosbags_counts = {c.topic: c.msgcount for c in reader.connections}
        assert reader.message_count == sum(rosbags_counts.values())
    mcap_counts: dict[str, int] = {}
    first_stamps: dict[str, int] = {}
    with open(bag / f'{name}.mcap', 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == 'ros2'
        for _, channel, message, decoded in reader.iter_decoded_messages():
            mcap_counts[channel.topic] = mcap_counts.get(channel.topic, 0) + 1
            stamp = decoded.stamp if channel.topic.endswith('zero_index') else \
                decoded.header.stamp
            first_stamps.setdefault(channel.topic, stamp.sec * 10**9 + stamp.nanosec)
        schemas = {s.name for s in reader.get_summary().schemas.values()}
    assert mcap_counts == rosbags_counts
    assert schemas <= set(CONTRACT_TYPES.values())
    assert set(rosbags_counts) >= {topics.GYRO_PULSES, topics.RATE_TABLE_JOINT_STATES,
                                   topics.RATE_TABLE_ZERO_INDEX}
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['storage_identifier'] == 'mcap' and meta['version'] == 9
    assert meta['relative_file_paths'] == [f'{name}.mcap']


def test_cli_calibrate_prints_summary_and_writes_the_handoff(tmp_path: Path, capsys) -> None:
    out = tmp_path / 'calib.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'theta_four_position'), '--out', str(out),
                            '--no-progress']) == 0
    text = capsys.readouterr().out
    for label in ('K̃ (″/pulse)', 'θ (″)', 'K (″/pulse)', 'bias ω_B (°/h)', 'stations: 4'):
        assert label in text
    record = yaml.safe_load(out.read_text())
    assert record['gyro']['stations'] == 4 and record['complete'] is True
    assert record['methods']['rbrlg']['source'].endswith('theta_four_position')
    k = _rbrlg('theta_four_position').rbrlg_results.scale_factor_arcsec_per_pulse
    assert k is not None
    assert record['gyro']['scale_factor_rad_per_pulse'] == k.value * RAD_PER_ARCSEC


def test_cli_writes_the_handoff_of_whatever_was_measured_and_says_what_is_missing(
        tmp_path: Path, capsys) -> None:
    out = tmp_path / 'calib.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'fault_pulse_gap'), '--out', str(out),
                            '--no-progress']) == 0
    captured = capsys.readouterr()
    assert 'gap in the pulse stream' in captured.out
    assert 'not measurable on the bench' in captured.out
    assert 'fix_error_angle_rad' in captured.out
    record = yaml.safe_load(out.read_text())  # issue 17 item 7: complete for such a bench
    assert record['complete'] is True and record['missing'] == {}
    assert set(record['not_measurable']) == {'fix_error_angle_rad', 'scale_factor_rad_per_pulse'}
    assert {'k_tilde_rad_per_pulse', 'bias_plus_earth_rate_rad_s', 'bias_rad_s'} <= set(
        record['gyro'])


def test_cli_json_prints_one_document_with_every_result_and_rejection(capsys) -> None:
    import json

    assert gyro_calib_main(['calibrate', str(BAGS / 'fault_pulse_gap'), '--json',
                            '--no-progress']) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    rbrlg = doc['methods']['rbrlg']
    k = rbrlg['results']['k_tilde_rad_per_pulse']
    assert set(k) == {'value', 'std', 'n'} and k['n'] == 2
    assert any('gap in the pulse stream' in r for r in rbrlg['rejections'])
    assert 'K̃ (″/pulse)' in captured.err  # the human summary goes to stderr


def test_cli_info_lists_topics_counts_windows_and_stations(capsys) -> None:
    assert gyro_calib_main(['info', str(BAGS / 'theta_four_position')]) == 0
    text = capsys.readouterr().out
    info = bag_info(BAGS / 'theta_four_position')
    for t in info.topics.values():
        assert t.name in text and str(t.count) in text
    assert 'K̃ windows it would use: 4' in text and 'θ stations it would use: 4' in text
    assert 'limits the result: ' in text.splitlines()[-1]


def test_cli_simulate_writes_a_scenario_bag(tmp_path: Path) -> None:
    out = tmp_path / 'bag'
    assert gyro_calib_main(['simulate', 'fault_lock_in', '--out', str(out)]) == 0
    assert bag_info(out).scenario['name'] == 'fault_lock_in'
    assert gyro_calib_main(['simulate', '--list']) == 0


def test_cli_simulate_stores_the_description_of_the_run_it_simulated(tmp_path: Path) -> None:
    """--duration-s / --sample-rate-hz / --seed: the stored sentence states what was used."""
    out = tmp_path / 'short'
    assert gyro_calib_main(['simulate', 'noise_rlg_static', '--out', str(out),
                            '--duration-s', '6', '--sample-rate-hz', '250']) == 0
    stored = bag_info(out).scenario
    assert stored['duration_s'] == 6.0 and stored['sample_rate_hz'] == 250.0
    text = stored['description']
    assert '250 Hz, 6 s,' in text and '280 s' not in text and '500 Hz' not in text
    assert 'The 240–242 s gap lies beyond this 6 s record: it has none.' in text
    assert bag_info(out).duration_s < 6.0
    # a changed value the sentence does not state is said after it
    from sim_nodes.scenarios import SCENARIOS, with_overrides

    assert with_overrides('k_tilde_bench', {'duration_s': 50.0}).description == (
        SCENARIOS['k_tilde_bench'].description
        + " Simulated with table.duration_s = 50 (the scenario's 100).")
    assert with_overrides('k_tilde_bench', {'sample_rate_hz': 2000.0}).description.endswith(
        '150 °/s, 2 kHz.')
    assert with_overrides('noise_rlg_static', {}).description == \
        SCENARIOS['noise_rlg_static'].description
