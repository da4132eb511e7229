"""Updating a hand-off file (issue 17 items 5, 6, 7).

Updating a hand-off file (issue 17 items 5, 6, 7): nothing measured is lost without a line,
each quantity is kept from the run that measured it best, what would make the file
inconsistent is refused, the gyro id binds, and the file says what each number is.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
import yaml
from ros_in_process import init_undiscovered

from gyro_calib.bag_calibration import method_options
from gyro_calib.bagio import bag_info
from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.handoff import (
    CONVENTIONS,
    Calibration,
    HandoffError,
    Provenance,
    load_calibration,
    merge_lines,
    method_calibration,
    update_calibration,
)
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions

BAGS = Path(__file__).resolve().parents[1] / 'bags'
K = 4.0859e-6


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    code = gyro_calib_main(['calibrate', *args, '--no-progress'])
    out, err = capsys.readouterr()
    return code, out + err


def _k_tilde_run(value: float, std: float, source: str = 'run', start: int = 1,
                 gyro_id: str = '') -> Calibration:
    return method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': value, 'k_tilde_rad_per_pulse_std': std, 'window_pairs': 3},
        Provenance(source, start, start + 10), gyro_id=gyro_id)


# -- item 5: nothing measured is lost -----------------------------------------------------


def test_theta_then_k_tilde_bench_keeps_k_and_theta_and_says_so(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue repro: K and θ were gone, stations 0, complete false, exit 0 and nothing said."""
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, str(BAGS / 'theta_four_position'), '--out', str(path))[0] == 0
    first = load_calibration(path)
    code, text = _cli(capsys, str(BAGS / 'k_tilde_bench'), '--out', str(path))
    assert code == 0
    after = load_calibration(path)
    for key in ('fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'stations'):
        assert after.get(key) == first.get(key)
        assert f'kept: {key} = ' in text
    assert after.get('stations') == 4 and after.complete
    for key in ('k_tilde_rad_per_pulse', 'bias_plus_earth_rate_rad_s', 'bias_rad_s',
                'window_pairs'):
        assert any(line.strip().startswith(verb + key) for line in text.splitlines()
                   for verb in ('kept: ', 'replaced: ')), key
    data = yaml.safe_load(path.read_text())
    run = data['methods']['rbrlg']
    assert run['source'].endswith('k_tilde_bench')
    earlier = {k: r for r in run['earlier_runs'] for k in r['keys']}
    assert earlier['fix_error_angle_rad']['source'].endswith('theta_four_position')
    assert sorted(set(run['keys']) | set(earlier)) == sorted(
        k for k in data['gyro']
        if not k.endswith(('_std', '_dof')))  # each value from exactly one run


def test_fog_turntable_then_mapping_keeps_the_turntable_k_and_its_terms(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A less certain K no longer replaces a better one.

    Issue repro: the 10-rate K (± 0.0058) was replaced by the mapping bag's (± 1.01) and the
    asymmetry and higher-order terms were dropped.
    """
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, str(BAGS / 'fog_turntable'), '--out', str(path))[0] == 0
    first = load_calibration(path)
    code, text = _cli(capsys, str(BAGS / 'fog_mapping_self_cal'), '--out', str(path))
    assert code == 0
    after = load_calibration(path)
    for key in ('fog_scale_factor_counts_per_rad', 'fog_asymmetry_ppm', 'fog_nonlinearity_ppm',
                'fog_scale_factor_quadratic_s_per_rad', 'fog_scale_factor_cubic_s2_per_rad2'):
        assert after.get(key) == first.get(key), key
        assert f'kept: {key} = ' in text
    assert 'is less precise (--replace takes it)' in text
    assert after.get('fog_self_cal_scale_factor_counts_per_rad') is not None
    assert 'added: fog_self_cal_scale_factor_counts_per_rad' in text
    assert after.complete


def test_a_value_that_disagrees_beyond_its_uncertainty_is_refused_unless_replace(
        tmp_path: Path) -> None:
    path = update_calibration(tmp_path / 'h.yaml', _k_tilde_run(K, 1e-13, 'bench A'))
    before = path.read_bytes()
    with pytest.raises(HandoffError, match=r'k_tilde_rad_per_pulse: this run gives .*bench B.*'
                       r'differ by 10\.\d combined standard uncertainties.*--replace'):
        update_calibration(path, _k_tilde_run(K + 1.5e-12, 1e-13, 'bench B', start=50))
    assert path.read_bytes() == before
    report: list[str] = []
    update_calibration(path, _k_tilde_run(K + 1.5e-12, 1e-13, 'bench B', start=50),
                       replace=True, report=report)
    assert load_calibration(path).get('k_tilde_rad_per_pulse') == K + 1.5e-12
    assert any(line.startswith('replaced: k_tilde_rad_per_pulse') and 'replace asked' in line
               for line in report)


def test_a_more_precise_run_replaces_and_a_live_run_updates_its_own_values(
        tmp_path: Path) -> None:
    path = update_calibration(tmp_path / 'h.yaml', _k_tilde_run(K, 2e-13, 'bench A'))
    report: list[str] = []
    update_calibration(path, _k_tilde_run(K + 1e-13, 1e-13, 'bench B', start=50), report=report)
    assert load_calibration(path).get('k_tilde_rad_per_pulse') == K + 1e-13
    assert report[0].startswith('replaced: k_tilde_rad_per_pulse') and 'more precise' in report[0]
    live = _k_tilde_run(K + 2e-13, 5e-13, 'live', start=90)  # a node's first, rough value
    update_calibration(path, live)
    assert load_calibration(path).get('k_tilde_rad_per_pulse') == K + 1e-13  # kept
    update_calibration(path, _k_tilde_run(K, 9e-14, 'live', start=90))  # same run, better
    assert load_calibration(path).get('k_tilde_rad_per_pulse') == K


# -- item 6: the gyro id binds; a model's scale factor must be the file's --------------------


def test_the_gyro_id_of_a_file_binds(tmp_path: Path) -> None:
    path = update_calibration(tmp_path / 'h.yaml', _k_tilde_run(K, 1e-13, gyro_id='A-1'))
    report: list[str] = []
    update_calibration(path, _k_tilde_run(K, 1e-13, 'other', start=40), report=report)
    assert load_calibration(path).gyro_id == 'A-1'
    assert "gyro_id: this run named no gyro; the file is for gyro 'A-1'" in report[0]
    with pytest.raises(HandoffError, match="holds gyro 'A-1', this calibration is for gyro 'B'"):
        update_calibration(path, _k_tilde_run(K, 1e-13, gyro_id='B'))
    unnamed = update_calibration(tmp_path / 'u.yaml', _k_tilde_run(K, 1e-13))
    report = []
    update_calibration(unnamed, _k_tilde_run(K, 1e-13, 'x', 7, gyro_id='C-3'), report=report)
    assert load_calibration(unnamed).gyro_id == 'C-3'
    assert "gyro_id: the file named no gyro; it is now gyro 'C-3'." in report


def test_the_gyro_id_stored_with_the_bags_names_the_run() -> None:
    infos = [bag_info(BAGS / 'thermal_validation')]
    options = method_options(CalibrationOptions(), METHODS['thermal'], infos)
    assert options.setting('gyro_id') == 'A-1'
    given = method_options(CalibrationOptions(gyro_id='X'), METHODS['thermal'], infos)
    assert given.setting('gyro_id') == 'X' and given.conflicts(['gyro_id'])


def _thermal_record(k_rad: float) -> Calibration:
    model = {'thermal_scale_factor_rad_per_pulse': k_rad}
    return Calibration({'thermal_model': model},
                       {'thermal': Provenance('chamber', 0, 1)}, 'A-1')


def test_a_thermal_model_fitted_with_another_scale_factor_is_refused(tmp_path: Path) -> None:
    """A thermal model fitted with another scale factor is refused.

    Issue repro: a file held K = 4.086e-06 beside a model fitted with 1.115e-05 (the
    imu_corrector side: test/nodes/test_imu_corrector.py).
    """
    path = update_calibration(tmp_path / 'h.yaml', _k_tilde_run(4.086e-6, 1e-13))
    before = path.read_bytes()
    with pytest.raises(HandoffError, match=r'k_tilde_rad_per_pulse = 4\.086e-06 .* differs '
                       r'from the K = 1\.115e-05 rad/pulse its thermal_model was fitted with'):
        update_calibration(path, _thermal_record(1.115e-5))
    assert path.read_bytes() == before
    update_calibration(path, _thermal_record(4.086e-6 * (1 + 5e-5)))  # within 100 ppm


# -- item 7: the file says what each number is ----------------------------------------------


def test_the_file_states_conventions_conditions_and_missing_once(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, str(BAGS / 'k_tilde_bench'), '--out', str(path))[0] == 0
    data = yaml.safe_load(path.read_text())
    assert data['conventions'] == CONVENTIONS and 'sense (input) axis' in CONVENTIONS['axis']
    run = data['methods']['rbrlg']
    assert run['conditions'] == {'latitude_deg': 28.2, 'heading_deg': 0.0,
                                 'position_table_revolutions': 1}
    assert 'bias_rad_s' in run['keys'] and 'missing' not in run
    text = path.read_text()
    assert text.count('missing:') == 1  # once, at the top level
    # a K̃ bench cannot give θ: complete for such a bench, θ and K listed as not measurable
    assert data['complete'] is True
    assert set(data['not_measurable']) == {'fix_error_angle_rad', 'scale_factor_rad_per_pulse'}


def test_a_turntable_only_fog_file_is_complete(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, str(BAGS / 'fog_turntable'), '--out', str(path))[0] == 0
    data = yaml.safe_load(path.read_text())
    assert data['complete'] is True and data['missing'] == {}
    assert 'fog_self_cal_scale_factor_counts_per_rad' in data['not_measurable']
    assert data['methods']['fog']['conditions'] == {'latitude_deg': 45.75}


def test_a_mapping_only_run_writes_no_full_scale_nonlinearity(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, str(BAGS / 'fog_mapping_self_cal'), '--out', str(path))[0] == 0
    data = yaml.safe_load(path.read_text())
    assert 'fog_nonlinearity_ppm' not in data['gyro']
    assert 'equivalence-mapping rates' in data['not_measurable']['fog_nonlinearity_ppm']
    assert 'fog_self_cal_nonlinearity_ppm' in data['gyro']


def test_format_2_files_still_load_and_are_rewritten_as_format_3(tmp_path: Path) -> None:
    v2: dict[str, Any] = {
        'format_version': 2, 'gyro_calib_version': '0.2.0', 'gyro_id': 'A-1', 'complete': False,
        'missing': {'bias_rad_s': 'needs the latitude.'},
        'gyro': {'k_tilde_rad_per_pulse': K, 'k_tilde_rad_per_pulse_std': 1e-13,
                 'window_pairs': 3},
        'methods': {'rbrlg': {'source': 'old', 'created_utc': '2026-01-01T00:00:00+00:00',
                              'data_start_stamp_ns': 0, 'data_end_stamp_ns': 1,
                              'missing': {'bias_rad_s': 'needs the latitude.'}}}}
    path = tmp_path / 'v2.yaml'
    path.write_text(yaml.safe_dump(v2))
    old = load_calibration(path)
    assert old.format_version == 2 and old.missing == {'bias_rad_s': 'needs the latitude.'}
    report: list[str] = []
    update_calibration(path, _k_tilde_run(K, 2e-13, 'new', 5), report=report)
    again = yaml.safe_load(path.read_text())
    assert again['format_version'] == 3 and again['gyro_id'] == 'A-1'
    assert again['methods']['rbrlg']['earlier_runs'][0]['source'] == 'old'
    assert 'kept: k_tilde_rad_per_pulse' in report[1]


def test_a_live_run_withdrawing_an_interim_value_removes_it(tmp_path: Path) -> None:
    """A live run withdrawing an interim value removes it.

    A node rewrites its file as its results evolve: a term it measured on the way and no
    longer resolves at the end is not kept from its own interim write (the file equals the
    offline calibration of the same data).
    """
    prov = Provenance('live', 100, 200)
    interim = method_calibration('noise', {
        'angle_random_walk_rad_per_sqrt_s': 2.9e-7, 'angle_random_walk_rad_per_sqrt_s_std': 1e-8,
        'bias_instability_rad_s': 5.7e-5, 'bias_instability_rad_s_std': 1.3e-5}, prov)
    final = method_calibration('noise', {
        'angle_random_walk_rad_per_sqrt_s': 2.8e-7,
        'angle_random_walk_rad_per_sqrt_s_std': 9e-9},
        dataclasses.replace(prov, data_end_stamp_ns=300))
    path = update_calibration(tmp_path / 'h.yaml', interim)
    report: list[str] = []
    update_calibration(path, final, report=report)
    assert set(load_calibration(path).values) == set(final.values)
    assert merge_lines(report) == []  # nothing a node needs to say about its own run


def test_a_live_thermal_node_reports_a_bench_conflict_and_writes_the_published_gyro_id(
        tmp_path: Path) -> None:
    """A node setting differing from the bag's bench is said.

    Issue 17 items 4 and 7: the README's thermal example ran the node with latitude_deg:=45
    against paper_soak's bench at 34.26° without a word, and the live node wrote gyro_id: ''
    while the simulator published A-1. The node (built in-process) gets the /sim/scenario
    message a chamber simulator publishes, then that bench's committed chamber run.
    """
    import rclpy
    from std_msgs.msg import String

    from gyro_calib.bagio import iter_sample_batches
    from gyro_calib.nodes.processes import ros_args
    from gyro_calib.nodes.thermal_calibration_node import ThermalCalibrationNode

    bag = BAGS / 'thermal_validation'  # A-1's shorter run
    scenario = bag_info(bag).scenario
    bench = scenario['bench']
    out = tmp_path / 'A-1.yaml'
    init_undiscovered(args=ros_args({'output_file': str(out), 'latitude_deg': 45.0,
                              'scale_factor_rad_per_pulse': bench['scale_factor_rad_per_pulse'],
                              'state_dir': str(tmp_path / 'state')}))
    try:
        node = ThermalCalibrationNode()
        try:
            node.scenario._on_message(String(data=yaml.safe_dump(scenario)))
            assert node.gyro_id == 'A-1'
            assert any(line.startswith('latitude_deg: parameter latitude_deg gives 45.0 ° but '
                                       'the bench settings stored in /sim/scenario')
                       and '34.26 °' in line for line in node.scenario.told)
            assert not any('scale_factor' in line for line in node.scenario.told)  # same K
            for batch in iter_sample_batches(bag, node.session.topics()):
                node.session.feed(batch)
            node.session.process(flush=True)
            node._write_handoff()
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
    written = load_calibration(out)
    assert written.gyro_id == 'A-1'
    assert written.get('thermal_model')['thermal_gyro_id'] == 'A-1'  # the model names it too


def test_a_published_bench_never_changes_a_nodes_session_it_names_what_it_would_give(
        tmp_path: Path) -> None:
    """A published bench never changes a node's session; it is named.

    Stamps, not wall clocks: whether /sim/scenario arrives before or after the first
    samples is timing, so it never fills a setting the parameters left unset (it did before
    the first sample, which made a live run's numbers depend on arrival order).
    """
    import rclpy
    from std_msgs.msg import String

    from gyro_calib.nodes.fog_calibration_node import FogCalibrationNode
    from gyro_calib.nodes.processes import ros_args

    scenario = bag_info(BAGS / 'fog_turntable').scenario
    init_undiscovered(args=ros_args({'output_file': str(tmp_path / 'fog.yaml')}))
    try:
        node = FogCalibrationNode()
        try:
            before = node.session
            node.scenario._on_message(String(data=yaml.safe_dump(scenario)))
            assert node.session is before
            latitude = scenario['bench']['latitude_deg']
            assert any('latitude_deg' in line and 'not taken' in line
                       and f'-p latitude_deg:={latitude!r}' in line
                       for line in node.scenario.told)
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()


def _rbrlg_write(end: int, *, whole: bool) -> Calibration:
    """One write of a live rbrlg run (data from stamp 100): K̃ early, θ and the bias later."""
    values: dict[str, Any] = {
        'k_tilde_rad_per_pulse': K, 'k_tilde_rad_per_pulse_std': 2e-13, 'window_pairs': 3}
    if whole:
        values.update({'fix_error_angle_rad': 1.2e-3, 'fix_error_angle_rad_std': 1e-5,
                       'scale_factor_rad_per_pulse': K * (1 - 0.72e-6),
                       'scale_factor_rad_per_pulse_std': 2e-13, 'stations': 4,
                       'bias_rad_s': 1e-7, 'bias_rad_s_std': 1e-8})
    missing = {} if whole else {k: 'needs the position-table stations (none yet)' for k in (
        'fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'bias_rad_s')}
    return method_calibration('rbrlg', values, Provenance('live', 100, end, missing=missing))


def test_the_same_run_again_keeps_what_its_first_writes_have_not_re_measured(
        tmp_path: Path) -> None:
    """The same run again (a bag replayed twice, ./run.sh demo twice) loses nothing unsaid.

    The file holds the whole run (K̃, θ, K, the bias, stations). The same run's first write
    again rests on less data and gives K̃ only: θ, K, stations and the bias are kept, each
    with a ``kept: … (not measured by this run).`` line a node prints, and the file stays
    complete. Once the run has re-measured them they are its values again, updated in place
    (nothing said). A live run that goes on and withdraws a value: the test above.
    """
    path = update_calibration(tmp_path / 'h.yaml', _rbrlg_write(900, whole=True))
    whole = load_calibration(path).values
    report: list[str] = []
    update_calibration(path, _rbrlg_write(300, whole=False), report=report)
    after = load_calibration(path)
    assert after.values == whole and after.complete
    lost = ('bias_rad_s', 'fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'stations')
    said = merge_lines(report)
    assert sorted(line.split()[1] for line in said) == list(lost), said
    assert all(line.startswith('kept: ') and line.endswith('(not measured by this run).')
               for line in said), said
    assert after.source_of('fix_error_angle_rad') is not None
    report = []
    again = _rbrlg_write(900, whole=True)
    update_calibration(path, dataclasses.replace(again, values={
        **again.values, 'bias_rad_s': 1.1e-7}), report=report)
    assert load_calibration(path).values['bias_rad_s'] == 1.1e-7
    assert merge_lines(report) == [] and any('bias_rad_s' in line for line in report)
    assert load_calibration(path).methods['rbrlg'].earlier == ()


def test_a_bag_replayed_twice_into_a_calibration_node_keeps_every_value_at_every_write(
        tmp_path: Path) -> None:
    """The same bag replayed twice into calibration_node (built in-process): nothing vanishes.

    The first replay writes the whole run (K̃, θ, K, the bias, stations). At every write of
    the second replay of the same data the file still holds every one of those values (the
    run's first writes lack θ: it is kept until re-measured), and the last write equals the
    first replay's.
    """
    import rclpy

    from gyro_calib.bagio import iter_sample_batches
    from gyro_calib.nodes.calibration_node import CalibrationNode
    from gyro_calib.nodes.processes import ros_args
    from gyro_calib.rbrlg.session import TOPICS

    bag = BAGS / 'theta_four_position'
    bench = bag_info(bag).scenario['bench']
    out = tmp_path / 'gyro_calibration.yaml'

    def replay(n: int) -> list[dict[str, Any]]:
        init_undiscovered(args=ros_args({
            'output_file': str(out), 'latitude_deg': bench['latitude_deg'],
            'position_table_revolutions': bench['position_table_revolutions'],
            'state_dir': str(tmp_path / f'state{n}')}))
        try:
            node = CalibrationNode()
            try:
                written = []
                for batch in iter_sample_batches(bag, TOPICS):
                    node._extend(batch)
                    node._consume(*node.bench.process())
                    node._write_handoff()
                    if out.exists():
                        written.append(dict(load_calibration(out).values))
            finally:
                node.destroy_node()
        finally:
            rclpy.shutdown()
        return written

    first = replay(1)
    whole = first[-1]
    assert {'fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'bias_rad_s',
            'stations'} <= set(whole)
    second = replay(2)
    assert len(second) > 1
    for values in second:
        assert set(values) == set(whole)
    assert second[-1] == whole
