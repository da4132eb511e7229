"""The committed noise bags calibrated offline.

The committed noise bags (noise_imu_static, noise_imu_band_limited, noise_rlg_static,
noise_rlg_spikes, noise_rlg_turning) calibrated offline through the
front door: terms within their stated uncertainties of the generators' truth, the ordering
and gap counts, Kalibr keys and units, the JSON shape, the figure; and the messages' bytes
equal rosbags' own serialisation. (Regeneration and size: test/test_bags.py.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import ContractMessages, bag_info, iter_raw_messages
from gyro_calib.cli import main
from gyro_calib.noise.session import NoiseSession
from gyro_calib.session import CalibrationOptions
from sim_nodes.noise.bag_scenarios import SCENARIOS, imu_message, imu_template, pulse_template

BAGS = Path(__file__).resolve().parents[1] / 'bags'
NAMES = list(SCENARIOS)
KALIBR_KEYS = {'accelerometer_noise_density', 'accelerometer_random_walk',
               'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic', 'update_rate'}


def expected(name: str) -> dict[str, Any]:
    return yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))


@pytest.fixture(scope='module')
def sessions() -> dict[str, NoiseSession]:
    out = {}
    for name in NAMES:
        session = calibrate_bags([BAGS / name], methods=['noise'], options=CalibrationOptions(
            settings=expected(name).get('settings', {}))).sessions['noise']
        assert isinstance(session, NoiseSession)
        out[name] = session
    return out


@pytest.mark.parametrize('name', NAMES)
def test_terms_lie_within_their_uncertainties_of_the_generator_truth(
        name: str, sessions: dict[str, NoiseSession]) -> None:
    exp = expected(name)
    session = sessions[name]
    assert session.topic == exp['topic']  # from the bench settings stored in the bag
    results = session.calibrator.results()
    k = exp['coverage_factor']
    checked = 0
    for axis, truth in exp['truth'].items():
        for key, est in results.get(axis, {}).items():
            z = (est.value - truth[key]) / est.std_uncertainty
            assert abs(z) <= k, (axis, key, est, truth[key], z)
            checked += 1
        for key in exp['must_resolve'].get(axis, []):
            assert key in results.get(axis, {}), (axis, key, session.missing())
    assert checked >= sum(len(v) for v in exp['must_resolve'].values())


@pytest.mark.parametrize('name', NAMES)
def test_stamp_faults_and_gaps_are_counted_and_shown_in_the_summary(
        name: str, sessions: dict[str, NoiseSession]) -> None:
    exp = expected(name)
    (counts,) = sessions[name].calibrator.stream_counts()
    for field, value in exp['counts'].items():
        assert getattr(counts, field) == value, field
    assert bag_info(BAGS / name).message_count == exp['messages']
    c = exp['counts']
    line = (f"{exp['topic']}: {c['received']} samples received; {c['out_of_order']} re-sorted "
            f"(out of order), {c['duplicate']} duplicate stamps dropped, 0 too late (dropped), "
            f"0 restart(s); {c['segments']} segment(s), {c['gaps']} gap(s)")
    assert any(ln.startswith(line) for ln in sessions[name].summary_lines())


def test_rlg_bag_shows_quantisation_because_its_dither_moves_the_phase(
        sessions: dict[str, NoiseSession]) -> None:
    lines = sessions['noise_rlg_static'].summary_lines()
    assert any('quantisation Q shows because the sub-pulse phase moves' in ln for ln in lines)
    assert 'K = 4.0860157e-06 rad/pulse from the bench settings stored in the bag' in lines[0]
    assert 'bias_instability_rad_s' in sessions['noise_rlg_static'].missing()


def test_rate_biased_rlg_at_constant_rate_gives_its_noise_and_leaves_out_only_the_reversal(
        sessions: dict[str, NoiseSession]) -> None:
    """noise_rlg_turning: 100 s at +37.9 °/s, a reversal, 100 s at −37.9 °/s.

    The two steady segments are analysed (a constant rate is a constant the Allan variance
    removes), the reversal is left out — the gyro samples strictly inside it, and at most two
    table-state intervals more on each side — and the line says so and which reference was
    used. With the table's encoder angle subtracted (gyro_minus_table) the terms agree.
    """
    exp = expected('noise_rlg_turning')
    session = sessions['noise_rlg_turning']
    record = session.calibrator.table_record()
    assert record is not None
    assert record['changes'] == ['reversal'] and record['reference'] == 'gyro'
    assert [math.degrees(r) for r in record['steady_rates_rad_s']] == pytest.approx(
        exp['table']['steady_rates_deg_s'], rel=1e-6)
    lo, hi = exp['table']['reversal_s']
    dt = exp['table']['state_interval_s']
    rate_hz = 250.0
    inside = int(math.ceil((hi - lo) * rate_hz)) - 1  # samples strictly inside the reversal
    left = record['samples_left_out']['/gyro/pulses']
    assert inside <= left <= inside + 4 * dt * rate_hz
    assert ('the rate table changed rate during 0.76 s of its 200.76 s record (1 span(s): 1 × '
            'reversal;') in record['line']
    assert 'held 2 steady segment(s) (at 37.9 °/s, at -37.9 °/s;' in record['line']
    assert record['line'].endswith('reference: the gyro alone (table_reference = gyro).')
    (rejection,) = session.calibrator.rejections
    assert 'the rate table reversed from 37.9 °/s to -37.9 °/s' in rejection.reason
    referenced = calibrate_bags([BAGS / 'noise_rlg_turning'], methods=['noise'],
                                options=CalibrationOptions(settings={
                                    'table_reference': 'gyro_minus_table'})).sessions['noise']
    assert isinstance(referenced, NoiseSession)
    ref_record = referenced.calibrator.table_record()
    assert ref_record is not None and ref_record['reference'] == 'gyro_minus_table'
    assert ref_record['samples_referenced'] == {'/gyro/pulses': exp['counts']['received'] - left}
    assert 'reference: the gyro angle minus the rate table\'s encoder angle (K·counts − ' \
        'encoder angle)' in ref_record['line']
    alone, minus = session.calibrator.results()['gyro'], referenced.calibrator.results()['gyro']
    truth = exp['truth']['gyro']
    for key in exp['must_resolve']['gyro']:
        a, b = alone[key], minus[key]
        assert abs(a.value - b.value) < math.hypot(a.std_uncertainty, b.std_uncertainty)
        assert abs(b.value - truth[key]) < exp['coverage_factor'] * b.std_uncertainty


def test_imu_bag_kalibr_file_has_kalibrs_keys_in_their_units(
        sessions: dict[str, NoiseSession]) -> None:
    session = sessions['noise_imu_static']
    text = session.kalibr_text()
    doc = yaml.safe_load(text)
    assert set(doc) == KALIBR_KEYS
    assert doc['rostopic'] == '/imu/data'
    assert doc['update_rate'] == pytest.approx(200.0, rel=1e-4)
    results = session.calibrator.results()
    n_gyro = max(results[f'gyro_{a}']['angle_random_walk_rad_per_sqrt_s'].value for a in 'xyz')
    n_accel = max(results[f'accel_{a}']['velocity_random_walk_m_s_per_sqrt_s'].value
                  for a in 'xyz')
    assert doc['gyroscope_noise_density'] == pytest.approx(n_gyro, rel=1e-6)
    assert doc['accelerometer_noise_density'] == pytest.approx(n_accel, rel=1e-6)
    truth = expected('noise_imu_static')['truth']
    # K is not resolved in 500 s: Kalibr gets the largest 2σ bound, which covers the truth
    assert doc['gyroscope_random_walk'] >= max(
        truth[f'gyro_{a}']['rate_random_walk_rad_per_s_sqrt_s'] for a in 'xyz')
    for unit in ('# rad/s/sqrt(Hz)', '# rad/s^2/sqrt(Hz)', '# m/s^2/sqrt(Hz)',
                 '# m/s^3/sqrt(Hz)', '2σ upper bound (not resolved)'):
        assert unit in text


def test_noise_command_and_calibrate_method_noise_give_the_same_json(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = BAGS / 'noise_rlg_static'
    assert main(['noise', str(bag), '--json', '--no-progress',
                 '--plot', str(tmp_path)]) == 0
    noise = json.loads(capsys.readouterr().out)
    assert main(['calibrate', str(bag), '--method', 'noise', '--json', '--no-progress']) == 0
    assert json.loads(capsys.readouterr().out)['methods'] == noise['methods']
    png = (tmp_path / 'noise_adev.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 20_000


@pytest.mark.parametrize('name', NAMES)
def test_json_section_has_the_issue_shape_and_the_figure_is_written(
        name: str, sessions: dict[str, NoiseSession], tmp_path: Path) -> None:
    section = json.loads(json.dumps(sessions[name].json_section()))
    axes = section['axes']
    table = {'table_motion'} if 'table' in expected(name) else set()
    assert set(section) == {'results', 'missing', 'rejections', 'axes'} | table
    assert list(axes) == (['gyro'] if expected(name)['kind'] == 'pulses' else
                          ['gyro_x', 'gyro_y', 'gyro_z', 'accel_x', 'accel_y', 'accel_z'])
    for a in axes.values():
        assert {'tau_s', 'adev', 'adev_std', 'results', 'mdev', 'hdev', 'totdev'} <= set(a)
        assert np.all(np.diff(a['tau_s']) > 0) and np.all(np.asarray(a['adev_std']) > 0)
        assert all(set(r) == {'value', 'std', 'n'} for r in a['results'].values())
    (png,) = sessions[name].plot(tmp_path)
    assert png == (tmp_path / 'noise_adev.png').absolute()
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_message_templates_are_byte_for_byte_rosbags_serialisation() -> None:
    rng = np.random.default_rng(1)
    t = 1_767_225_600_000_000_000 + np.cumsum(rng.integers(1, 10**9, 20))
    gyro, accel = rng.normal(size=(20, 3)), rng.normal(size=(20, 3))
    template, offset = imu_template('imu_link')
    rows = template.rows(t, gyro)
    at = template.value_at + offset
    rows[:, at:at + 24] = np.ascontiguousarray(accel).view(np.uint8).reshape(20, 24)
    for i in range(20):
        assert rows[i].tobytes() == imu_message(int(t[i]), 'imu_link', gyro[i], accel[i])
    counts = rng.normal(size=20) * 1e6
    pulses = pulse_template().rows(t, counts)
    cdr = ContractMessages()
    for i in range(20):
        assert pulses[i].tobytes() == cdr.joint_state(int(t[i]), 'gyro', float(counts[i]))
    first = next(iter_raw_messages(BAGS / 'noise_imu_static'))
    assert first[:2] == ('/imu/data', 'sensor_msgs/msg/Imu')


def test_imu_bag_columns_are_bit_identical_to_rosbags_decoding() -> None:
    """The Imu topic decodes bit-identically to rosbags.

    The Imu topic is no contract topic (test_mcap_columns.py checks those): a window of
    it decoded both ways, values compared as bits.
    """
    from gyro_calib.bagio.columns import iter_column_batches

    bag, types = BAGS / 'noise_imu_static', {'/imu/data': 'sensor_msgs/msg/Imu'}
    start = bag_info(bag).start_ns
    window = {'start_ns': start, 'stop_ns': start + 40 * 10**9}

    def columns(**kw: Any) -> dict[str, np.ndarray]:
        parts = [b.topics['/imu/data'] for b in iter_column_batches(bag, types, **window, **kw)]
        out = {'stamp_ns': np.concatenate([c.stamp_ns for c in parts]),
               'log_time_ns': np.concatenate([c.log_time_ns for c in parts])}
        for name in parts[0].values:
            out[name] = np.concatenate([c.values[name] for c in parts]).view(np.uint64)
        return out

    mine, reference = columns(), columns(decoder='rosbags')
    assert len(mine['stamp_ns']) > 7000
    assert mine.keys() == reference.keys()
    for name in mine:
        assert np.array_equal(mine[name], reference[name]), name


def test_imu_with_its_own_decimation_filter_gives_b_with_its_tau_range(
        sessions: dict[str, NoiseSession]) -> None:
    """noise_imu_band_limited: the bent short-τ range is left out.

    noise_imu_band_limited: the IMU's 20 Hz low-pass bends the short-τ curve; the fit leaves
    those τ out (and says why), and B of every gyro axis comes out with the τ range it rests
    on, above the cut and inside the fitted range.
    """
    exp = expected('noise_imu_band_limited')
    axes = sessions['noise_imu_band_limited'].json_section()['axes']
    for axis in ('gyro_x', 'gyro_y', 'gyro_z'):
        fit = axes[axis]['fit']
        b = axes[axis]['results']['bias_instability_rad_s']
        assert abs(b['value'] - exp['truth'][axis]['bias_instability_rad_s']) \
            <= exp['coverage_factor'] * b['std']
        cut = fit['band_limited_below_s']
        assert cut is not None and cut > 0.01  # the 100 Hz τ0 is left out
        assert any('low-pass filter' in note for note in fit['notes'])
        tau_b = fit['term_tau_ranges_s']['bias_instability_rad_s']
        assert cut <= fit['tau_min_s'] <= tau_b['tau_min_s'] < tau_b['tau_max_s'] \
            <= fit['tau_max_s']
        assert tau_b['tau_min_s'] > 1.0  # B rests on the plateau, not on the bent short τ


def test_spiky_rlg_bag_finds_every_bit_error_and_removal_gives_the_gyro_terms(
        sessions: dict[str, NoiseSession], tmp_path: Path) -> None:
    """noise_rlg_spikes: 40 one-sample bit errors of ±2^5 … 2^9 pulses in the count.

    Each gives two increments beyond 8 robust σ (up, then back): 80 found, at the stamps
    injected. With outliers = remove (the expected file's setting) the terms lie within their
    uncertainties of the truth (the coverage test above); kept, Q is 20× too large, and the
    report's 'removed' value is the gyro's. The run's conditions in the hand-off say which
    treatment was used and what the other would change, and so does the certificate.
    """
    exp = expected('noise_rlg_spikes')
    spikes = exp['spikes']
    session = sessions['noise_rlg_spikes']
    report = session.calibrator.axis_result('gyro').outliers
    assert report is not None and report.mode == 'remove'
    assert report.tally.spikes == spikes['increments'] == 80
    first = [ns / 1e9 for ns, _ in report.tally.first]
    glitch = [s for s0 in spikes['stamps_s'][:3] for s in (s0, s0 + 0.002)][:5]
    assert first == pytest.approx(glitch, abs=1e-6)  # the samples lie 2 ms apart
    assert session.conditions()['outliers'] == 'remove'
    assert session.conditions()['outliers_found'] == 80
    assert any(ln.startswith('gyro: spikes: 80 of 59999 samples') and 'outliers = remove'
               in ln for ln in session.summary_lines())
    out = tmp_path / 'h.yaml'
    assert main(['noise', str(BAGS / 'noise_rlg_spikes'), '--json', '--out', str(out)]) == 0
    run = yaml.safe_load(out.read_text(encoding='utf-8'))
    text = json.dumps(run)
    assert '"outliers": "keep"' in text and '"outliers_found": 80' in text
    assert main(['report', str(out), '--out', str(tmp_path / 'certs'), '--no-pdf']) == 0
    (html,) = (tmp_path / 'certs').glob('*.html')
    page = html.read_text(encoding='utf-8')  # the certificate says which treatment was used
    assert 'outliers</span> = keep' in page and 'outliers_found</span> = 80' in page
    truth, k = exp['truth']['gyro'], exp['coverage_factor']
    kept = session.calibrator  # the estimator took the repaired record; its shadow the raw
    q_removed = kept.results()['gyro']['quantization_noise_rad']
    raw = report.terms['quantization_noise_rad'][0]
    assert raw > 10 * truth['quantization_noise_rad']
    assert abs(q_removed.value - truth['quantization_noise_rad']) < k * q_removed.std_uncertainty
