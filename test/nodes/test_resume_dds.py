"""A calibration node killed mid-run resumes losing nothing.

A calibration node killed (SIGKILL) mid-run and started again loses nothing it had
consumed: its final hand-off equals the offline calibration of the data it saw, bit for bit
(issue 19, part 1).

The data it saw is exactly its state directory (kept with ``keep_state``): what it consumed
before the kill and after the restart; what the bench published while no node ran is a gap.
The kill instants are drawn at random (seeded, so CI is repeatable); set
GYRO_CALIB_STRESS=1 for more of them.
"""

from __future__ import annotations

import os
import random
import signal
import time
from pathlib import Path

import pytest

from gyro_calib.bagio import SampleBatch, bag_info
from gyro_calib.bagio.columns import iter_column_batches
from gyro_calib.handoff import load_calibration
from gyro_calib.nodes.ros_io import EXIT_HANDOFF_NOT_WRITTEN
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions
from gyro_calib.state_record import StateRecord
from gyro_calib.units import RAD_PER_ARCSEC

from .dds_harness import _WATCHED, NodeProcess, launch

BAGS = Path(__file__).resolve().parents[2] / 'bags'
KILLS = 6 if os.environ.get('GYRO_CALIB_STRESS') else 1


def _offline_of_record(method: str, state_dir: Path, options: CalibrationOptions) -> dict:
    """Hand-off values of a fresh session fed the record, as ``gyro-calib calibrate`` feeds."""
    session = METHODS[method].make_session(options)
    for columns in StateRecord(state_dir, {}).replay():
        n = sum(len(c) for c in columns.values())
        session.feed(SampleBatch(columns, n, max(int(c.stamp_ns.max())
                                                 for c in columns.values())))
        session.process()
    if hasattr(session, 'end_of_recording'):
        session.end_of_recording()
    session.process(flush=True)
    record = session.handoff('offline')
    assert record is not None
    return dict(record.values)


def _last_stamp_s(bag: Path, topic: str) -> float:
    """The header stamp of the bag's last message on ``topic``, s."""
    last = 0
    for batch in iter_column_batches(bag, {topic: bag_info(bag).topics[topic].msgtype}):
        last = max(last, int(batch.topics[topic].stamp_ns.max()))
    return last / 1e9



def _wait_until_recorded(state: Path, topic: str, stamp_s: float, node: NodeProcess,
                         timeout_s: float = 90.0) -> None:
    """Until the node has consumed ``topic`` up to ``stamp_s`` (the end of the run)."""
    deadline = time.monotonic() + timeout_s
    while True:
        last = StateRecord(state, {}).summary().last_stamp_ns_by_topic.get(topic, 0)
        if last >= stamp_s * 1e9:
            return
        assert time.monotonic() < deadline and node.proc.poll() is None, \
            f'{topic} recorded up to {last / 1e9} s only:\n{node.log()}\n' + '\n'.join(
                f'-- {p.name} (exit {p.proc.poll()}): ' + '\n'.join(p.lines[-8:])
                for p in _WATCHED if p is not node)
        time.sleep(0.2)


@pytest.mark.parametrize('seed', range(KILLS))
def test_fog_node_killed_mid_run_resumes_to_the_offline_numbers_of_what_it_saw(
        seed: int, tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """SIGKILL mid-run; the bench goes on; a restart after a gap continues the record.

    The bench after the restart is a second player starting where the first left off plus
    a gap: DDS holds a writer up to its lease (~20 s) on a killed reader, so the first
    player's tail cannot be relied on to reach the restarted node.
    """
    bag = BAGS / 'fog_fault_short_plateau'
    info = bag_info(bag)
    latitude = float(info.scenario['bench']['latitude_deg'])
    handoff, state = tmp_path / 'fog.yaml', tmp_path / 'state'
    params = {'latitude_deg': latitude, 'output_file': str(handoff), 'gyro_id': 'FOG-1',
              'state_dir': str(state), 'keep_state': True}
    draw = random.Random(seed)
    first = launch('fog_calibration_node', params)
    nodes.append(first)
    player = launch('bag_player', {'bag': str(bag), 'rate': 8.0})
    nodes.append(player)
    # kill once the node has consumed some of the first two thirds of the bag
    kill_after_s = info.start_ns / 1e9 + draw.uniform(10.0, 80.0)
    _wait_until_recorded(state, '/fog/output', kill_after_s, first)
    first.send_signal(signal.SIGKILL)
    first.proc.wait(timeout=10)
    player.proc.wait(timeout=120)
    recorded_s = StateRecord(state, {}).summary().last_stamp_ns_by_topic['/fog/output'] / 1e9
    gap_s = draw.uniform(0.0, 20.0)
    second = launch('fog_calibration_node', params)
    nodes.append(second)
    nodes.append(launch('bag_player', {
        'bag': str(bag), 'rate': 8.0,
        'start_offset_s': recorded_s - info.start_ns / 1e9 + gap_s}))
    _wait_until_recorded(state, '/fog/output', _last_stamp_s(bag, '/fog/output'), second)
    second.send_signal(signal.SIGINT)
    second.proc.wait(timeout=90)
    logs = '\n'.join(n.log() for n in nodes)
    assert second.proc.returncode == 0, logs
    assert 'resumed from' in second.log(), logs
    got = dict(load_calibration(handoff).values)
    expected = _offline_of_record('fog', state, CalibrationOptions(latitude_deg=latitude))
    assert got == expected, logs
    assert StateRecord(state, {}).summary().messages < sum(
        t.count for t in info.topics.values())  # a gap while no node ran


def test_calibration_node_resumes_its_windows_after_a_kill(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    handoff, state = tmp_path / 'gyro.yaml', tmp_path / 'state'
    params = {'output_file': str(handoff), 'state_dir': str(state), 'keep_state': True}
    first = launch('calibration_node', params)
    nodes.append(first)
    nodes.append(launch('rlg_sim', {'seed': 7}))
    table = launch('rate_table_sim', {'duration_s': 120.0, 'seed': 7, 'real_time_factor': 6.0,
                                      'sample_rate_hz': 250.0})
    nodes.append(table)
    deadline = time.monotonic() + 120
    while 'K̃ = ' not in first.log():  # killed once it holds a pair of windows
        assert time.monotonic() < deadline and table.proc.poll() is None, first.log()
        time.sleep(0.1)
    first.send_signal(signal.SIGKILL)
    first.proc.wait(timeout=10)
    second = launch('calibration_node', params)
    nodes.append(second)
    table.proc.wait(timeout=180)
    # a killed reader holds the pulse writer up until its lease ends: wait for the pulses
    _wait_until_recorded(state, '/gyro/pulses', 119.0, second)
    second.send_signal(signal.SIGINT)
    second.proc.wait(timeout=60)
    logs = '\n'.join(n.log() for n in nodes)
    assert second.proc.returncode == 0, logs
    assert 'resumed from' in second.log(), logs
    assert handoff.exists(), logs
    got = dict(load_calibration(handoff).values)
    expected = _offline_of_record('rbrlg', state, CalibrationOptions())
    assert got == expected, logs
    assert 'k_tilde_rad_per_pulse' in got, logs


def _k_tilde_run(params: dict, gyro: dict, table: dict, nodes: list[NodeProcess]
                 ) -> NodeProcess:
    """One gyro on the K̃ bench: node started first, bench run, Ctrl-C once K̃ is out.

    ``table`` holds ``duration_s``: long enough for the two window pairs K̃ needs.
    """
    node = launch('calibration_node', params)
    nodes.append(node)
    sim = launch('rlg_sim', gyro)
    nodes.append(sim)
    bench = launch('rate_table_sim', {'real_time_factor': 8.0, 'sample_rate_hz': 250.0,
                                      **table})
    nodes.append(bench)
    bench.proc.wait(timeout=180)
    deadline = time.monotonic() + 60
    while 'K̃ = ' not in node.log():
        assert time.monotonic() < deadline, node.log()
        time.sleep(0.1)
    time.sleep(1.0)
    node.send_signal(signal.SIGINT)
    node.proc.wait(timeout=60)
    sim.stop()
    return node


def test_a_second_gyro_run_with_defaults_never_resumes_the_first_gyros_record(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """Issue 24 §1: the paper bench, then an unfamiliar gyro, each with default parameters.

    Before the fix the second K̃ came out 1.5714″/pulse (−32 %): the first gyro's record
    (a K̃-only bench never completes, so it stays) was resumed into the second run.
    """
    handoff = tmp_path / 'gyro_calibration.yaml'
    params = {'output_file': str(handoff)}  # the state directory beside it, by default
    first = _k_tilde_run(params, {'seed': 3}, {'seed': 3, 'duration_s': 60.0}, nodes)
    assert first.proc.returncode == 0, first.log()
    state = tmp_path / 'gyro_calibration.yaml.state'
    assert StateRecord(state, {}).summary().messages > 0, first.log()
    second = _k_tilde_run(
        params, {'seed': 4, 'scale_factor_arcsec_per_pulse': 2.3,
                 'fix_error_angle_arcsec': 300.0, 'latitude_deg': 45.0},
        {'seed': 4, 'rate_deg_s': 120.0, 'duration_s': 85.0}, nodes)
    logs = '\n'.join(n.log() for n in nodes)
    # its hand-off file was another gyro's (refused at write time): the run fails, state kept
    assert second.proc.returncode == EXIT_HANDOFF_NOT_WRITTEN, logs
    assert f'the data consumed are kept in {state} (not removed)' in second.log(), logs
    assert 'resumed from' not in second.log(), logs
    said = [line for line in second.lines if 'not resumed' in line]
    assert len(said) == 1 and 'stamps go back' in said[0] and 'moved to' in said[0], logs
    # the second gyro's own K̃ (K / cos θ ≈ K), from exactly the data of its own run
    told = [line for line in second.lines if 'K̃ = ' in line][-1]
    k_tilde_arcsec = float(told.split('K̃ = ')[1].split()[0])
    assert abs(k_tilde_arcsec / 2.3 - 1) < 1e-5, logs
    offline = _offline_of_record('rbrlg', state, CalibrationOptions())
    assert f"{offline['k_tilde_rad_per_pulse'] / RAD_PER_ARCSEC:.10f}" == f'{k_tilde_arcsec:.10f}'
    aside = [p for p in tmp_path.iterdir() if '.superseded-' in p.name]
    assert len(aside) == 1
    # the first gyro's file is not overwritten by another gyro's values without --replace
    first_k = dict(load_calibration(handoff).values)['k_tilde_rad_per_pulse'] / RAD_PER_ARCSEC
    assert abs(first_k / 0.84279066 - 1) < 1e-5
    assert 'hand-off file not written' in second.log(), logs


@pytest.mark.flaky(reruns=1)
def test_a_node_killed_before_the_theta_phase_resumes_while_the_position_table_turns(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """Issue 35 item 0 over DDS: killed at the end of the K̃ phase, back during a turn.

    The full procedure, killed as K̃ is out (the position table at rest in the record),
    started again while the table begins its first station's turn. Before the fix the
    restarted node refused the record ('the recorded rate allows at most 0') and the run
    ended without K and θ.

    Run again once on a failure: in 2 of 8 CI runs under the load of the other xdist worker
    (Kilted once, Jazzy once; shared-memory and UDP transport alike) the restarted node,
    started while the simulators still waited for the killed node's reader (its lease,
    measured 19.5–19.7 s), logged 'reading reliable' on all five topics and then received
    nothing: no writer got an acknowledgement from it, and rlg_sim ended after 30 s (exit
    3). The first node had lagged 27 s of bench time behind the table at the kill. Here: 1
    failure in 11 runs (a quiet run of this file on Jazzy; the rerun passed); the others
    passed, up to four CPU hogs, one in 221 s. Cause not found.
    """
    speed, rate = 5.0, 75.0  # as test_dds_procedure: every phase in 163 s of bench time
    handoff, state = tmp_path / 'gyro.yaml', tmp_path / 'state'
    params = {'output_file': str(handoff), 'state_dir': str(state), 'keep_state': True,
              'resume_max_gap_s': 150.0}  # a node slow to start again on a loaded machine
    first = launch('calibration_node', params)
    nodes.append(first)
    nodes.append(launch('rlg_sim', {'seed': 6}))
    table = launch('rate_table_sim', {'scenario': 'full', 'k_tilde_pairs': 2, 'seed': 6,
                                      'real_time_factor': speed, 'sample_rate_hz': 250.0,
                                      'procedure.position_table_rate_deg_s': rate})
    nodes.append(table)
    deadline = time.monotonic() + 180
    while 'K̃ = ' not in first.log():  # the K̃ phase is over: the θ phase starts
        assert time.monotonic() < deadline and table.proc.poll() is None, first.log()
        time.sleep(0.1)
    first.proc.send_signal(signal.SIGKILL)
    first.proc.wait(timeout=10)
    time.sleep(2.0)  # 10 s of bench time: the position table starts its turn meanwhile
    second = launch('calibration_node', params)
    nodes.append(second)
    table.proc.wait(timeout=300)
    _wait_until_recorded(state, '/gyro/pulses', 162.0, second)
    second.proc.send_signal(signal.SIGINT)
    second.proc.wait(timeout=60)
    logs = '\n'.join(n.log() for n in nodes)
    assert second.proc.returncode == 0, logs
    assert 'not resumed' not in second.log() and 'resumed from' in second.log(), logs
    # nothing of the record lost: the hand-off is the offline calibration of every sample
    # the two lives consumed (a station cut by the down-time is a gap, as offline)
    got = dict(load_calibration(handoff).values)
    assert 'k_tilde_rad_per_pulse' in got, logs
    assert got == _offline_of_record('rbrlg', state, CalibrationOptions()), logs
