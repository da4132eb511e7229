"""The noise method on a triad's ``/imu/pulses`` (issue 26 §2; METHODS §E, §F).

Specifications, from a generator of the physics written here (not sim_nodes): three channels
at rest, each with white rate noise (angle random walk N_i), the Earth rate along its sense
axis, and whole-pulse quantisation of K_i·count_i. Each channel is turned into angle with its
own K_i from the ``imu:`` section of ``--calibration``; the terms go to ``imu.noise.<channel>``
of the hand-off (not the top-level ``gyro:``), and a triad run and a noise run each keep what
the other wrote.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from gyro_calib import topics
from gyro_calib.handoff import (
    Calibration,
    Provenance,
    load_calibration,
    method_calibration,
    update_calibration,
    write_calibration,
)
from gyro_calib.imu_calibration import ImuCalibration

CHANNELS = ('gx', 'gy', 'gz')
K = np.array([1.0e-6, 1.3e-6, 1.7e-6])
"""K_i, rad/pulse."""
ARW = np.array([2.0e-5, 3.0e-5, 4.5e-5])
"""The truth N_i, rad/√s."""
SENSE = np.array([[1.0, 0.002, -0.001], [-0.001, 1.0, 0.003], [0.002, -0.002, 1.0]])
SENSE /= np.linalg.norm(SENSE, axis=1)[:, None]
RATE_HZ = 100.0
SECONDS = 400.0
EARTH_RATE = 7.292115e-5
LATITUDE = math.radians(48.0)
SIGMAS = 3.0
"""A term within this many of its stated standard uncertainties of the truth."""


def counts_at_rest(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (ns) and cumulative counts (n × 3) of a triad at rest, level, heading North.

    angle_i = ∫ (s_i·Ω_E + n_i) dt with n_i white of density N_i (rad/√s), counts the whole
    pulses of angle_i/K_i from a random sub-pulse phase (IEEE 952 quantisation).
    """
    rng = np.random.default_rng(seed)
    n = int(SECONDS * RATE_HZ)
    dt = 1.0 / RATE_HZ
    earth = EARTH_RATE * np.array([math.cos(LATITUDE), 0.0, -math.sin(LATITUDE)])  # NED body
    steps = (SENSE @ earth)[None, :] * dt + rng.standard_normal((n, 3)) * ARW * math.sqrt(dt)
    angle = np.cumsum(steps, axis=0) + rng.uniform(0.0, 1.0, 3) * K
    counts = np.floor(angle / K)
    t = (10**9 + np.arange(n) * int(1e9 / RATE_HZ)).astype(np.int64)
    return t, counts


@pytest.fixture(scope='module')
def triad_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag

    t, counts = counts_at_rest(0)
    cdr = ContractMessages()
    path = tmp_path_factory.mktemp('triad_noise') / 'rest'
    write_bag(path, [BagMessage(topics.IMU_PULSES, ti, cdr.joints_state(ti, CHANNELS, c))
                     for ti, c in zip(t.tolist(), counts.tolist(), strict=True)])
    return path


def triad_record(*, noise: dict[str, dict[str, float]] | None = None) -> Calibration:
    """A triad run's hand-off record: K, sense axes, M (and noise when given)."""
    m = np.linalg.inv(SENSE / K[:, None])
    imu = ImuCalibration(CHANNELS, scale_factor_rad_per_pulse=K,
                         scale_factor_rad_per_pulse_std=K * 1e-7, sense_axes=SENSE,
                         sense_axes_std_rad=np.full(3, 1e-6), pulses_to_body_rad=m,
                         pulses_to_body_rad_covariance=np.eye(9) * 1e-30,
                         noise=noise or {})
    cal = method_calibration('triad', {}, Provenance('triad_bench', 1, 2))
    return dataclasses.replace(cal, gyro_id='imu-7', imu=imu)


@pytest.fixture
def imu_yaml(tmp_path: Path) -> Path:
    path = tmp_path / 'imu.yaml'
    write_calibration(path, triad_record())
    return path


def noise_cli(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    from gyro_calib.cli import main

    status = main(['noise', *map(str, argv), '--no-progress'])
    out, err = capsys.readouterr()
    return status, out, err


def test_each_channel_gets_its_own_arw_within_its_u_from_its_own_k(
        triad_bag: Path, imu_yaml: Path) -> None:
    """calibrate_bags: N_i of every channel within 3 u of the truth; the axes are the channels."""
    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.session import CalibrationOptions

    outcome = calibrate_bags([triad_bag], methods=['noise'], options=CalibrationOptions(
        topic=topics.IMU_PULSES, calibration_file=imu_yaml))
    session = outcome.sessions['noise']
    results = session.results()
    for i, ch in enumerate(CHANNELS):
        est = results[f'imu.noise.{ch}.angle_random_walk_rad_per_sqrt_s']
        assert abs(est.value - ARW[i]) < SIGMAS * est.std_uncertainty, (ch, est, ARW[i])
        assert est.std_uncertainty < 0.1 * ARW[i]
    assert session.handoff_values() == {}  # nothing at the top level


def test_noise_cli_writes_imu_noise_per_channel_and_keeps_the_triad_section(
        triad_bag: Path, imu_yaml: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`gyro-calib noise BAG --topic /imu/pulses --calibration imu.yaml --out imu.yaml`."""
    status, out, err = noise_cli(capsys, triad_bag, '--topic', '/imu/pulses', '--calibration',
                                 imu_yaml, '--out', imu_yaml)
    assert status == 0, err
    assert 'input: /imu/pulses' in out and 'K_gy = 1.3e-06' in out
    assert "imu: the file's section kept" in out
    cal = load_calibration(imu_yaml)
    assert cal.format_version == 4 and cal.imu is not None
    assert cal.imu.scale_factor_rad_per_pulse is not None  # K, M … kept
    np.testing.assert_array_equal(cal.imu.scale_factor_rad_per_pulse, K)
    assert set(cal.imu.noise) == set(CHANNELS)
    for i, ch in enumerate(CHANNELS):
        terms = cal.imu.noise[ch]
        n, u = terms['angle_random_walk_rad_per_sqrt_s'], \
            terms['angle_random_walk_rad_per_sqrt_s_std']
        assert abs(n - ARW[i]) < SIGMAS * u
        unresolved = [k for k in terms if k.endswith('_upper_bound_2sigma')]
        assert all(k.removesuffix('_upper_bound_2sigma') not in terms for k in unresolved)
    assert not any('angle_random_walk' in k for k in cal.values)  # not the top-level gyro:
    raw = yaml.safe_load(imu_yaml.read_text())
    assert 'angle_random_walk_rad_per_sqrt_s' in raw['imu']['noise']['gz']


def test_noise_json_names_the_axes_by_channel(
        triad_bag: Path, imu_yaml: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    status, out, err = noise_cli(capsys, triad_bag, '--topic', '/imu/pulses', '--calibration',
                                 imu_yaml, '--json')
    assert status == 0, err
    section = json.loads(out)['methods']['noise']
    assert set(section['axes']) == set(CHANNELS)
    assert 'imu.noise.gx.angle_random_walk_rad_per_sqrt_s' in section['results']


def test_imu_pulses_without_k_is_refused_in_one_line(
        triad_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / 'h.yaml'
    status, out, err = noise_cli(capsys, triad_bag, '--topic', '/imu/pulses', '--out', out_file)
    assert status == 2 and out == '' and not out_file.exists()
    assert len(err.strip().splitlines()) == 1
    assert '/imu/pulses' in err and '--calibration' in err


def test_a_triad_run_after_a_noise_run_keeps_the_noise_and_the_reverse(tmp_path: Path) -> None:
    """Either order gives the same file: the triad's K, M … and the noise run's terms."""
    noise = {ch: {'angle_random_walk_rad_per_sqrt_s': float(a),
                  'angle_random_walk_rad_per_sqrt_s_std': float(a) * 0.03,
                  'rate_ramp_rad_per_s2_upper_bound_2sigma': 1e-9}
             for ch, a in zip(CHANNELS, ARW, strict=True)}
    noise_run = dataclasses.replace(
        method_calibration('noise', {}, Provenance('rest_bag', 3, 4)), gyro_id='imu-7',
        imu=ImuCalibration(CHANNELS, noise=noise))
    first_noise = tmp_path / 'a.yaml'
    report: list[str] = []
    update_calibration(first_noise, noise_run, report=report)  # no imu section yet: made
    only = load_calibration(first_noise).imu
    assert only is not None and only.noise == noise and only.pulses_to_body_rad is None
    assert any('imu: added with the channels' in line for line in report)
    report.clear()
    update_calibration(first_noise, triad_record(), report=report)
    assert any('noise per channel kept' in line for line in report), report
    first_triad = tmp_path / 'b.yaml'
    update_calibration(first_triad, triad_record())
    update_calibration(first_triad, noise_run)
    for path in (first_noise, first_triad):
        imu = load_calibration(path).imu
        assert imu is not None and imu.noise == noise, path
        assert imu.pulses_to_body_rad is not None and imu.scale_factor_rad_per_pulse is not None
    # a triad run that measured noise itself brings its own
    own = {ch: {'angle_random_walk_rad_per_sqrt_s': 1e-6} for ch in CHANNELS}
    update_calibration(first_triad, triad_record(noise=own))
    imu = load_calibration(first_triad).imu
    assert imu is not None and imu.noise == own


def test_another_imus_channels_are_refused(tmp_path: Path) -> None:
    from gyro_calib.handoff import HandoffError

    path = tmp_path / 'h.yaml'
    update_calibration(path, triad_record())
    other = dataclasses.replace(method_calibration('noise', {}, Provenance('b', 3, 4)),
                                imu=ImuCalibration(('a', 'b', 'c'), noise={
                                    'a': {'angle_random_walk_rad_per_sqrt_s': 1e-6}}))
    with pytest.raises(HandoffError, match='channels'):
        update_calibration(path, other)


def test_the_corrector_and_export_read_the_arw_the_noise_run_wrote(
        triad_bag: Path, imu_yaml: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """imu_corrector's covariance and `gyro-calib export` take N_i from imu.noise.<ch>."""
    from gyro_calib.export.source import read_source
    from gyro_calib.imu_body_rate import load_imu_calibration, triad_rate_model

    assert noise_cli(capsys, triad_bag, '--topic', '/imu/pulses', '--calibration', imu_yaml,
                     '--out', imu_yaml)[0] == 0
    written = load_calibration(imu_yaml).imu
    assert written is not None
    arw = [written.noise[ch]['angle_random_walk_rad_per_sqrt_s'] for ch in CHANNELS]
    model = triad_rate_model(load_imu_calibration(imu_yaml))
    np.testing.assert_array_equal(model.arw_rad_per_sqrt_s, arw)
    assert np.all(np.abs(model.arw_rad_per_sqrt_s - ARW) < 0.1 * ARW)
    source = read_source(imu_yaml)
    assert [source.gyro[axis]['N'].value for axis in ('x', 'y', 'z')] == arw


def test_the_span_while_the_rate_table_swings_is_left_out_of_every_channel(
        tmp_path: Path, imu_yaml: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The table (axis = body z) swings ±10° at 0.5 Hz from 150 s to 250 s: left out (§E.1).

    Kept in, the swing would be Allan deviation of order 10°·… on gz and ~mrad-level on gx,
    gy (their sense axes lean 2–3 mrad towards z): N off by orders of magnitude.
    """
    from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag

    t, counts = counts_at_rest(0)
    s = (t - t[0]) / 1e9
    swing = (s >= 150.0) & (s < 250.0)
    w = 2 * math.pi * 0.5
    table = np.where(swing, math.radians(10.0) * np.sin(w * (s - 150.0)), 0.0)
    rate = np.where(swing, math.radians(10.0) * w * np.cos(w * (s - 150.0)), 0.0)
    turned = counts + np.floor(np.outer(table, SENSE[:, 2]) / K)
    cdr = ContractMessages()
    msgs = [BagMessage(topics.IMU_PULSES, ti, cdr.joints_state(ti, CHANNELS, c))
            for ti, c in zip(t.tolist(), turned.tolist(), strict=True)]
    msgs += [BagMessage(topics.RATE_TABLE_JOINT_STATES, ti,
                        cdr.joint_state(ti, 'rate_table', a, r))
             for ti, a, r in zip(t.tolist(), table.tolist(), rate.tolist(), strict=True)]
    msgs.sort(key=lambda m: m.log_time_ns)
    bag = tmp_path / 'swing'
    write_bag(bag, msgs)
    status, out, err = noise_cli(capsys, bag, '--topic', '/imu/pulses', '--calibration',
                                 imu_yaml, '--out', imu_yaml)
    assert status == 0, err
    assert 'samples of /imu/pulses' in out and 'left out' in out
    imu = load_calibration(imu_yaml).imu
    assert imu is not None
    found = np.array([imu.noise[ch]['angle_random_walk_rad_per_sqrt_s'] for ch in CHANNELS])
    assert np.all(np.abs(found / ARW - 1) < 0.05), found  # kept in: off by orders of magnitude


def test_the_node_input_path_gives_the_offline_terms_bit_for_bit(
        triad_bag: Path, imu_yaml: Path) -> None:
    """noise_node's LiveInputs (three joints per /imu/pulses message) → the bag's numbers."""
    from sensor_msgs.msg import JointState

    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.bagio import SampleBatch
    from gyro_calib.nodes.method_node import LiveInputs
    from gyro_calib.noise.session import NoiseSession
    from gyro_calib.session import CalibrationOptions

    options = CalibrationOptions(topic=topics.IMU_PULSES, calibration_file=imu_yaml)
    offline = calibrate_bags([triad_bag], methods=['noise'], options=options).sessions['noise']
    session = NoiseSession(options)
    live = LiveInputs(session.topics())
    t, counts = counts_at_rest(0)
    for ti, c in zip(t.tolist(), counts.tolist(), strict=True):
        msg = JointState(name=list(CHANNELS), position=c)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ti, 10**9)
        live.buffers[topics.IMU_PULSES].add(msg)
    columns, late = live.take(flush=True)
    assert not late
    session.feed(SampleBatch(columns, sum(len(c) for c in columns.values()), 0))
    session.process(flush=True)
    got = {k: (e.value, e.std_uncertainty) for k, e in session.results().items()}
    assert got == {k: (e.value, e.std_uncertainty) for k, e in offline.results().items()}
    assert len(got) == 3


def test_each_channel_is_the_single_gyro_analysis_of_its_counts_with_its_k() -> None:
    """A triad channel gives what /gyro/pulses with that channel's counts and K gives, exactly."""
    from gyro_calib.noise.calibrator import NoiseCalibrator
    from gyro_calib.noise.settings import NoiseSettings

    t, counts = counts_at_rest(3)
    triad = NoiseCalibrator(NoiseSettings(), triad=(CHANNELS, tuple(float(k) for k in K)))
    triad.extend_triad(t, counts)
    triad.process(flush=True)
    for i, ch in enumerate(CHANNELS):
        one = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=float(K[i])))
        one.extend_pulses(t, counts[:, i])
        one.process(flush=True)
        a, b = triad.axis_results()[ch], one.axis_results()['gyro']
        assert a.curve is not None and b.curve is not None
        np.testing.assert_array_equal(a.curve.adev, b.curve.adev)
        assert a.fit is not None and b.fit is not None
        assert {k: (e.value, e.std_uncertainty) for k, e in a.fit.estimates.items()} == \
            {k: (e.value, e.std_uncertainty) for k, e in b.fit.estimates.items()}
        assert a.fit.upper_bounds == b.fit.upper_bounds


def test_a_hand_off_of_other_channels_is_refused_in_one_line(
        triad_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """K for channels x, y, z but the bag's joints are gx, gy, gz: another IMU's file."""
    record = triad_record()
    assert record.imu is not None
    other = tmp_path / 'other.yaml'
    write_calibration(other, dataclasses.replace(
        record, imu=dataclasses.replace(record.imu, channels=('x', 'y', 'z'))))
    before = other.read_bytes()
    status, out, err = noise_cli(capsys, triad_bag, '--topic', '/imu/pulses', '--calibration',
                                 other, '--out', other)
    assert status == 2 and out == '' and other.read_bytes() == before
    assert len(err.strip().splitlines()) == 1 and "['gx', 'gy', 'gz']" in err
