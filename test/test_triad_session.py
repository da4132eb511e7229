"""The triad session from bench streams to K_i, s_i, M, b and the hand-off (METHODS §F, issue 26).

Streams come from test/triad_bench_physics.py (the kinematics composed from rotations, counts
quantised at 1 kHz), fed in batches as a bag or a live node would.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from triad_bench_physics import ARCSEC, Bench, Recording, Triad, random_triad, record

from gyro_calib import topics
from gyro_calib.bagio import JOINT_STATE, SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.handoff import load_calibration, update_calibration
from gyro_calib.imu_calibration import imu_from_section
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions
from gyro_calib.triad.session import TriadSession

HEADER = 'std_msgs/msg/Header'
SIGMAS = 4.0
"""A single run's error is checked within this many stated standard uncertainties."""


def _columns(topic: str, msgtype: str, t: np.ndarray, values: dict[str, np.ndarray]
             ) -> TopicColumns:
    return TopicColumns(topic, msgtype, t, t, FrameIds(np.zeros(len(t), np.int32), ('',)),
                        values)


def batches(rec: Recording, chunk_s: float = 20.0) -> list[SampleBatch]:
    """The recording cut into time slices, every topic in each (as a bag reader gives)."""
    t0, t1 = int(rec.pulse_t[0]), int(rec.pulse_t[-1])
    step = int(chunk_s * 1e9)
    out = []
    streams = [(topics.IMU_PULSES, JOINT_STATE, rec.pulse_t, {'position': rec.counts,
                                                             'velocity': np.full(len(
                                                                 rec.pulse_t), np.nan)}),
               (topics.RATE_TABLE_JOINT_STATES, JOINT_STATE, rec.rate_t,
                {'position': rec.rate[:, 0], 'velocity': rec.rate[:, 1]}),
               (topics.RATE_TABLE_ZERO_INDEX, HEADER, rec.rate_index, {}),
               (topics.POSITION_TABLE_JOINT_STATES, JOINT_STATE, rec.position_t,
                {'position': rec.position[:, 0], 'velocity': rec.position[:, 1]}),
               (topics.POSITION_TABLE_ZERO_INDEX, HEADER, rec.position_index, {})]
    for lo in range(t0, t1 + 1, step):
        cols = {}
        for topic, msgtype, t, values in streams:
            sel = (t >= lo) & (t < lo + step)
            if np.any(sel):
                cols[topic] = _columns(topic, msgtype, t[sel],
                                       {k: v[sel] for k, v in values.items()})
        out.append(SampleBatch(cols, sum(len(c) for c in cols.values()), lo + step))
    return out


def options(bench: Bench, **extra: object) -> CalibrationOptions:
    stored = {'tilt_deg': math.degrees(bench.tilt_rad), 'tilt_std_arcsec': 60.0,
              'position_table_revolutions': bench.position_turns,
              'revolutions_per_window': bench.inner_turns, **extra}
    return CalibrationOptions(latitude_deg=bench.latitude_deg, heading_deg=bench.heading_deg,
                              scenario={'bench': stored})


def run(bench: Bench, triad: Triad, seed: int = 1) -> TriadSession:
    rec = record(bench, triad, np.random.default_rng(seed))
    session = TriadSession(options(bench))
    for batch in batches(rec):
        session.feed(batch)
        session.process()
    session.process(flush=True)
    return session


def errors_in_sigma(session: TriadSession, triad: Triad) -> list[float]:
    """|error|/u of every K_i and every off-axis sense-axis component."""
    r = session.triad_result
    assert r is not None
    out = []
    for i, ch in enumerate(r.channels):
        k, axis = ch.scale_factor_rad_per_pulse, ch.sense_axis
        assert k is not None and axis is not None, ch.not_measurable
        out.append(abs(k.value - triad.scale_factor_rad_per_pulse[i]) / k.std_uncertainty)
        for j in range(3):
            if j != i:
                out.append(abs(axis[j].value - triad.sense_axes[i, j]) / axis[j].std_uncertainty)
    return out


def test_two_axis_bench_gives_every_k_and_sense_axis_within_its_uncertainty() -> None:
    triad = random_triad(np.random.default_rng(5))
    bench = Bench()
    session = run(bench, triad)
    r = session.triad_result
    assert r is not None and r.pulses_to_body_rad is not None
    assert max(errors_in_sigma(session, triad)) < SIGMAS
    labels = {label for _, label in session.pairs}
    assert 'inner axis' in labels and sum(lb.startswith('station') for lb in labels) == 4
    # M = R⁻¹ of the truth, b in the body frame
    m_true = np.linalg.inv(triad.rows)
    m = np.array([[e.value for e in row] for row in r.pulses_to_body_rad])
    m_std = np.array([[e.std_uncertainty for e in row] for row in r.pulses_to_body_rad])
    assert np.all(np.abs(m - m_true) < SIGMAS * m_std + 1e-15)
    assert r.bias_body_rad_s is not None
    b_true = m_true @ (triad.bias_rad_s / triad.scale_factor_rad_per_pulse)
    b = np.array([e.value for e in r.bias_body_rad_s])
    b_std = np.array([e.std_uncertainty for e in r.bias_body_rad_s])
    assert np.all(np.abs(b - b_true) < SIGMAS * b_std)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000), tilt_deg=st.floats(30.0, 60.0),
       n_stations=st.integers(3, 5))
def test_random_benches_and_triads_within_stated_uncertainty(seed: int, tilt_deg: float,
                                                             n_stations: int) -> None:
    rng = np.random.default_rng(seed)
    triad = random_triad(rng)
    start = rng.uniform(0, 2 * math.pi)
    bench = Bench(tilt_rad=math.radians(tilt_deg), inner_pairs=2,
                  stations_rad=tuple((start + 2 * math.pi * k / n_stations) % (2 * math.pi)
                                     for k in range(n_stations)))
    assert max(errors_in_sigma(run(bench, triad, seed), triad)) < SIGMAS


def test_angle_random_walk_is_measured_per_gyro_into_each_window_not_a_global_widening(
        ) -> None:
    """ARW (0.003 °/√h) not stated: measured per gyro into its windows, no Birge widening.

    The window-end fits do not see it: each gyro's count random walk over its windows is
    measured from its own pair residuals (eq. (6c)).
    """
    rng = np.random.default_rng(1)
    arw = 0.003 * math.pi / 180 / 60
    triad = random_triad(rng, arw_rad_sqrt_s=arw)
    session = run(Bench(inner_pairs=3), triad, seed=1)
    r = session.triad_result
    assert r is not None and 'scatter' not in r.basis and 'predicted' in r.basis
    assert max(errors_in_sigma(session, triad)) < SIGMAS
    lines = session.summary_lines()
    walk = next(line for line in lines if line.startswith('count noise'))
    assert 'measured from the pair residuals' in walk
    measured = [float(part.split()[1]) for part in walk.split(': ', 2)[2].split(', ')]
    assert all(0.3 * 0.003 < n < 3 * 0.003 for n in measured), walk  # °/√h, few dof each


def test_a_stated_angle_random_walk_is_used_as_stated() -> None:
    """``angle_random_walk_deg_sqrt_h`` given: each window carries N²·T/K² of the stated N."""
    rng = np.random.default_rng(1)
    triad = random_triad(rng, arw_rad_sqrt_s=0.003 * math.pi / 180 / 60)
    rec = record(Bench(inner_pairs=3), triad, np.random.default_rng(1))
    given = dataclasses.replace(options(Bench(inner_pairs=3)), settings={
        'angle_random_walk_deg_sqrt_h': [0.003, 0.003, 0.003]})
    session = TriadSession(given)
    for batch in batches(rec):
        session.feed(batch)
    session.process(flush=True)
    lines = session.summary_lines()
    assert 'count noise: ARW over each window (°/√h, stated): x 0.003, y 0.003, z 0.003' \
        in lines
    assert max(errors_in_sigma(session, triad)) < SIGMAS
    # one dof per quantity: the summary states the ν the hand-off stores, and no other
    imu = session.imu_calibration()
    assert imu is not None and imu.scale_factor_rad_per_pulse_dof is not None
    dof = ', '.join(f'K_{c}, s_{c} {int(v)}'
                    for c, v in zip('xyz', imu.scale_factor_rad_per_pulse_dof, strict=True))
    assert f'degrees of freedom (hand-off scale_factor_rad_per_pulse_dof): {dof}' in lines
    assert not any('Student t' in line or ' dof)' in line for line in lines), lines


def test_a_channel_locked_in_about_the_inner_axis_is_rejected_there_and_solved_from_stations(
        ) -> None:
    """A rate-biased RLG on x locked in about oZ: rejected there, solved from the stations.

    x sees < 1 °/s about oZ: its inner windows are rejected for it with a line; three stations
    120° apart (each ≥ 20 °/s along x) still span its row.
    """
    triad = random_triad(np.random.default_rng(9))
    bench = Bench(stations_rad=(0.0, 2 * math.pi / 3, 4 * math.pi / 3))
    rec = record(bench, triad, np.random.default_rng(2))
    threshold = math.radians(5.0) / triad.scale_factor_rad_per_pulse[0]  # 5 °/s on x
    session = TriadSession(CalibrationOptions(
        latitude_deg=bench.latitude_deg, heading_deg=bench.heading_deg,
        settings={'min_pulse_rate_hz': threshold},
        scenario={'bench': {'tilt_deg': 45.0, 'revolutions_per_window': bench.inner_turns}}))
    for batch in batches(rec):
        session.feed(batch)
    session.process(flush=True)
    lines = [r.reason for r in session.rejections()]
    assert any(line.startswith('inner-axis window') and 'rejected for channel x' in line
               and 'lock-in' in line for line in lines)
    r = session.triad_result
    assert r is not None
    x = r.channels[0]
    assert x.scale_factor_rad_per_pulse is not None and x.sense_axis is not None
    assert abs(x.scale_factor_rad_per_pulse.value - triad.scale_factor_rad_per_pulse[0]) \
        < SIGMAS * x.scale_factor_rad_per_pulse.std_uncertainty
    assert all(why and 'lock-in' in why for pair, label in session.pairs
               if label == 'inner axis' for why in pair.rejected[:1])


def test_a_channel_whose_directions_do_not_span_3d_is_not_measurable_and_the_others_solved(
        ) -> None:
    """Two stations, x locked in about oZ and at one station: x not measurable, z solved.

    x keeps one direction → not measurable with the reason; z keeps oZ + two stations.
    """
    triad = random_triad(np.random.default_rng(11))
    bench = Bench(stations_rad=(0.0, math.pi / 2))
    rec = record(bench, triad, np.random.default_rng(3))
    session = TriadSession(CalibrationOptions(
        latitude_deg=bench.latitude_deg,
        settings={'min_pulse_rate_hz': math.radians(10.0) / triad.scale_factor_rad_per_pulse[0]
                  * 0.5},
        scenario={'bench': {'tilt_deg': 45.0, 'revolutions_per_window': bench.inner_turns}}))
    for batch in batches(rec):
        session.feed(batch)
    session.process(flush=True)
    r = session.triad_result
    assert r is not None
    x, y, z = r.channels
    assert x.scale_factor_rad_per_pulse is None
    assert 'do not span' in x.not_measurable or 'distinct direction' in x.not_measurable
    assert z.scale_factor_rad_per_pulse is not None
    assert r.pulses_to_body_rad is None
    assert 'imu.pulses_to_body_rad' in session.not_measurable()
    # what was measured reaches the hand-off: z's K and sense axis, x's place null with why
    section = session.imu_calibration()
    assert section is not None
    written = section.to_section()
    assert written['scale_factor_rad_per_pulse'][0] is None and written['sense_axes'][0] is None
    assert written['scale_factor_rad_per_pulse'][2] == z.scale_factor_rad_per_pulse.value
    assert 'pulses_to_body_rad' not in written and 'bias_rad_s' not in written
    assert 'span' in written['not_measurable']['scale_factor_rad_per_pulse'] or 'distinct' in \
        written['not_measurable']['scale_factor_rad_per_pulse']
    back = imu_from_section(written)
    assert back.scale_factor_rad_per_pulse is not None
    assert math.isnan(back.scale_factor_rad_per_pulse[0])
    assert back.scale_factor_rad_per_pulse[2] == z.scale_factor_rad_per_pulse.value


def test_remount_bags_one_mount_each_give_k_and_sense_axes(tmp_path: Path) -> None:
    """Single-axis table, six bags (±x, ±y, ±z up), fed with start_bag between them."""
    assert METHODS['triad'].separate_bags
    triad = random_triad(np.random.default_rng(21))
    mounts = ('+x', '-x', '+y', '-y', '+z', '-z')
    recs = [record(Bench(remount_axis=a, inner_pairs=2), triad, np.random.default_rng(i))
            for i, a in enumerate(mounts)]
    opts = CalibrationOptions(latitude_deg=40.0, stored_benches=tuple(
        (f'bag_{a}', {'mount_axis': a, 'revolutions_per_window': 2}) for a in mounts))
    session = TriadSession(opts)
    for i, rec in enumerate(recs):
        session.start_bag(i, tmp_path / f'bag_{mounts[i]}')
        for batch in batches(rec):
            session.feed(batch)
    session.process(flush=True)
    assert max(errors_in_sigma(session, triad)) < SIGMAS
    assert {label for _, label in session.pairs} == {f'mount {a}' for a in mounts}


def test_handoff_round_trip_is_format_4_and_a_newer_triad_run_replaces_the_section(
        tmp_path: Path) -> None:
    triad = random_triad(np.random.default_rng(5))
    session = run(Bench(inner_pairs=2), triad)
    cal = session.handoff('bags/triad', gyro_id='IMU-7')
    assert cal is not None and cal.imu is not None
    out = tmp_path / 'h.yaml'
    update_calibration(out, cal)
    text = out.read_text()
    assert 'format_version: 4' in text and text.index('imu:') < text.index('methods:')
    back = load_calibration(out)
    assert back.format_version == 4 and back.gyro_id == 'IMU-7' and back.imu is not None
    assert back.imu.scale_factor_rad_per_pulse is not None
    np.testing.assert_allclose(back.imu.scale_factor_rad_per_pulse,
                               triad.scale_factor_rad_per_pulse, rtol=1e-5)
    m_back, m_run = back.imu.pulses_to_body_rad, cal.imu.pulses_to_body_rad
    assert m_back is not None and m_run is not None
    np.testing.assert_allclose(m_back, m_run, rtol=1e-12)
    report: list[str] = []
    update_calibration(out, cal, report=report)
    assert any(line.startswith('imu: the file\'s imu section') for line in report)


def test_a_format_3_file_still_loads_and_a_triad_run_is_not_put_into_a_single_gyros_file(
        tmp_path: Path) -> None:
    """One sensor per file (issue 35 item 2): a format 3 file is a single gyro's."""
    from gyro_calib.handoff import HandoffError, Provenance, method_calibration, write_calibration

    old = method_calibration('rbrlg', {'k_tilde_rad_per_pulse': 4.0e-6,
                                       'k_tilde_rad_per_pulse_std': 1.0e-13},
                             Provenance('bags/k', 1, 2), gyro_id='IMU-7')
    path = tmp_path / 'h.yaml'
    write_calibration(path, old)
    assert 'format_version: 3' in path.read_text()
    assert load_calibration(path).imu is None
    session = run(Bench(inner_pairs=2), random_triad(np.random.default_rng(5)))
    cal = session.handoff('bags/triad', gyro_id='IMU-7')
    assert cal is not None
    before = path.read_bytes()
    with pytest.raises(HandoffError, match=r'another sensor \(sensor kind differs\): the file '
                                           r'holds a single-axis gyro \(RLG, pulse output\), '
                                           r'this run is of a gyro '
                                           r'triad'):
        update_calibration(path, cal)
    assert path.read_bytes() == before
    back = load_calibration(path)
    assert back.imu is None and back.values['k_tilde_rad_per_pulse'] == 4.0e-6


def test_another_imus_run_is_refused(tmp_path: Path) -> None:
    from gyro_calib.handoff import HandoffError

    session = run(Bench(inner_pairs=2), random_triad(np.random.default_rng(5)))
    path = tmp_path / 'h.yaml'
    first = session.handoff('bags/triad', gyro_id='IMU-7')
    other = session.handoff('bags/triad', gyro_id='IMU-8')
    assert first is not None and other is not None
    update_calibration(path, first)
    with pytest.raises(HandoffError, match='IMU-7'):
        update_calibration(path, other)


def test_paper_bench_precision_is_reported() -> None:
    """Paper bench: K_z to ≤ 2e-8 and every direction to ≤ 0.5″ (issue 26).

    Four stations, one position-table revolution each way (one window each way), 5 inner
    pairs of 5 turns at 150 °/s, K = 0.8428″/pulse, quantised counts at 1 kHz.
    """
    k = 0.8428 * ARCSEC
    triad = random_triad(np.random.default_rng(1))
    triad = Triad(np.full(3, k), triad.sense_axes, triad.bias_rad_s)
    session = run(Bench(inner_pairs=5, inner_turns=5, outer_margin_turns=0.6), triad)
    assert sum(label.startswith('station') for _, label in session.pairs) == 4
    r = session.triad_result
    assert r is not None
    k_z = r.channels[2].scale_factor_rad_per_pulse
    assert k_z is not None and k_z.std_uncertainty / k_z.value < 2e-8
    for ch in r.channels:
        assert ch.sense_axis_covariance is not None
        assert math.sqrt(np.trace(ch.sense_axis_covariance)) / ARCSEC < 0.5


def test_the_node_path_gives_the_offline_numbers_bit_for_bit() -> None:
    """The node's input path gives the offline numbers, bit for bit.

    Messages go through the node's LiveInputs as triad_calibration_node receives them (three
    joints per /imu/pulses message, their names kept as the channel names).
    """
    from builtin_interfaces.msg import Time
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Header

    from gyro_calib.nodes.method_node import LiveInputs

    bench = Bench(inner_pairs=1, inner_turns=1, pulse_hz=500.0,
                  stations_rad=(0.0, 2 * math.pi / 3, 4 * math.pi / 3))
    triad = random_triad(np.random.default_rng(4))
    rec = record(bench, triad, np.random.default_rng(4))
    offline = TriadSession(options(bench))
    for batch in batches(rec):
        offline.feed(batch)
    offline.process(flush=True)

    def stamp(ns: int) -> Time:
        return Time(sec=int(ns // 10**9), nanosec=int(ns % 10**9))

    live = LiveInputs(METHODS['triad'].topics)
    names = ['gx', 'gy', 'gz']
    for t, c in zip(rec.pulse_t.tolist(), rec.counts.tolist(), strict=True):
        msg = JointState(name=names, position=c)
        msg.header.stamp = stamp(t)
        live.buffers[topics.IMU_PULSES].add(msg)
    for topic, t_arr, v in ((topics.RATE_TABLE_JOINT_STATES, rec.rate_t, rec.rate),
                            (topics.POSITION_TABLE_JOINT_STATES, rec.position_t, rec.position)):
        for t, (a, w) in zip(t_arr.tolist(), v.tolist(), strict=True):
            msg = JointState(name=['table'], position=[a], velocity=[w])
            msg.header.stamp = stamp(t)
            live.buffers[topic].add(msg)
    for topic, t_arr in ((topics.RATE_TABLE_ZERO_INDEX, rec.rate_index),
                         (topics.POSITION_TABLE_ZERO_INDEX, rec.position_index)):
        for t in t_arr.tolist():
            live.buffers[topic].add(Header(stamp=stamp(t)))
    columns, late = live.take(flush=True)
    assert not late
    node_session = TriadSession(options(bench))
    node_session.feed(SampleBatch(columns, sum(len(c) for c in columns.values()), 0))
    node_session.process(flush=True)
    assert node_session.channels == ('gx', 'gy', 'gz')
    a, b = offline.triad_result, node_session.triad_result
    assert a is not None and b is not None and a.pulses_to_body_rad is not None
    assert b.pulses_to_body_rad is not None
    for ca, cb in zip(a.channels, b.channels, strict=True):
        ka, kb = ca.scale_factor_rad_per_pulse, cb.scale_factor_rad_per_pulse
        assert ka is not None and kb is not None
        assert (ka.value, ka.std_uncertainty) == (kb.value, kb.std_uncertainty)
    assert [[e.value for e in row] for row in a.pulses_to_body_rad] == \
        [[e.value for e in row] for row in b.pulses_to_body_rad]


def _write_bag(path: Path, rec: Recording, bench: Bench) -> None:
    from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag

    cdr = ContractMessages()
    msgs = [BagMessage(topics.IMU_PULSES, t, cdr.joints_state(t, ('gx', 'gy', 'gz'), c))
            for t, c in zip(rec.pulse_t.tolist(), rec.counts.tolist(), strict=True)]
    for topic, joint, t_arr, v in (
            (topics.RATE_TABLE_JOINT_STATES, 'rate_table', rec.rate_t, rec.rate),
            (topics.POSITION_TABLE_JOINT_STATES, 'position_table', rec.position_t,
             rec.position)):
        msgs += [BagMessage(topic, t, cdr.joint_state(t, joint, a, w))
                 for t, (a, w) in zip(t_arr.tolist(), v.tolist(), strict=True)]
    for topic, t_arr in ((topics.RATE_TABLE_ZERO_INDEX, rec.rate_index),
                         (topics.POSITION_TABLE_ZERO_INDEX, rec.position_index)):
        msgs += [BagMessage(topic, t, cdr.header(t, '')) for t in t_arr.tolist()]
    msgs.sort(key=lambda m: m.log_time_ns)
    bench_settings = {'tilt_deg': math.degrees(bench.tilt_rad), 'tilt_std_arcsec': 60.0,
                      'position_table_revolutions': bench.position_turns,
                      'revolutions_per_window': bench.inner_turns,
                      'latitude_deg': bench.latitude_deg, 'heading_deg': bench.heading_deg}
    write_bag(path, msgs, scenario={'bench': bench_settings})


def test_gyro_calib_calibrate_a_triad_bag_prints_the_summary_and_writes_format_4(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`gyro-calib calibrate BAG --method triad --out H.yaml`: the numbers of the session."""
    import json

    from gyro_calib.cli import main as gyro_calib

    bench = Bench(inner_pairs=1, inner_turns=1, pulse_hz=500.0,
                  stations_rad=(0.0, 2 * math.pi / 3, 4 * math.pi / 3))
    triad = random_triad(np.random.default_rng(4))
    rec = record(bench, triad, np.random.default_rng(4))
    bag = tmp_path / 'triad_bag'
    _write_bag(bag, rec, bench)
    out = tmp_path / 'h.yaml'
    assert gyro_calib(['calibrate', str(bag), '--method', 'triad', '--out', str(out)]) == 0
    text = capsys.readouterr().out
    assert 'K_gx (″/pulse)' in text and 'ppm' in text and 's_gz·e_x (″)' in text
    cal = load_calibration(out)
    assert cal.format_version == 4 and cal.imu is not None
    assert cal.imu.channels == ('gx', 'gy', 'gz')
    offline = TriadSession(options(bench))
    for batch in batches(rec):
        offline.feed(batch)
    offline.process(flush=True)
    imu = offline.imu_calibration()
    assert imu is not None and cal.imu.scale_factor_rad_per_pulse is not None
    np.testing.assert_array_equal(cal.imu.scale_factor_rad_per_pulse,
                                  imu.scale_factor_rad_per_pulse)
    assert gyro_calib(['calibrate', str(bag), '--method', 'triad', '--json']) == 0
    doc = json.loads(capsys.readouterr().out)
    schema = json.loads((Path(__file__).resolve().parents[1] / 'gyro_calib' / 'schema'
                         / 'result.schema.json').read_text())
    jsonschema.validate(doc, schema)
    section = doc['methods']['triad']['imu']
    assert section['channels'] == ['gx', 'gy', 'gz']
    assert section['scale_factor_rad_per_pulse'] == list(cal.imu.scale_factor_rad_per_pulse)


def test_gyro_calib_calibrate_three_remount_bags_each_with_its_mount_axis(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Three bags on a single-axis table (+x, +y, +z up, `mount_axis` stored in each)."""
    from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag
    from gyro_calib.cli import main as gyro_calib

    triad = random_triad(np.random.default_rng(21))
    cdr = ContractMessages()
    bags = []
    for i, axis in enumerate(('+x', '+y', '+z')):
        rec = record(Bench(remount_axis=axis, inner_pairs=1, inner_turns=1, pulse_hz=500.0),
                     triad, np.random.default_rng(i))
        msgs = [BagMessage(topics.IMU_PULSES, t, cdr.joints_state(t, ('x', 'y', 'z'), c))
                for t, c in zip(rec.pulse_t.tolist(), rec.counts.tolist(), strict=True)]
        msgs += [BagMessage(topics.RATE_TABLE_JOINT_STATES, t,
                            cdr.joint_state(t, 'rate_table', a, w))
                 for t, (a, w) in zip(rec.rate_t.tolist(), rec.rate.tolist(), strict=True)]
        msgs += [BagMessage(topics.RATE_TABLE_ZERO_INDEX, t, cdr.header(t, ''))
                 for t in rec.rate_index.tolist()]
        msgs.sort(key=lambda m: m.log_time_ns)
        bags.append(tmp_path / f'remount_{axis[1]}')
        write_bag(bags[-1], msgs, scenario={'bench': {
            'mount_axis': axis, 'revolutions_per_window': 1, 'latitude_deg': 40.0}})
    out = tmp_path / 'h.yaml'
    assert gyro_calib(['calibrate', *map(str, bags), '--method', 'triad', '--out',
                       str(out)]) == 0
    capsys.readouterr()
    imu = load_calibration(out).imu
    assert imu is not None and imu.scale_factor_rad_per_pulse is not None
    assert imu.sense_axes is not None and imu.sense_axes_std_rad is not None
    assert imu.scale_factor_rad_per_pulse_std is not None
    assert np.all(np.abs(imu.scale_factor_rad_per_pulse - triad.scale_factor_rad_per_pulse)
                  < SIGMAS * imu.scale_factor_rad_per_pulse_std)
    assert np.all(np.linalg.norm(imu.sense_axes - triad.sense_axes, axis=1)
                  < SIGMAS * imu.sense_axes_std_rad)
