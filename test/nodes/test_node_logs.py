"""The nodes say what they wait for and what changed (issue 17 items 13 and 15).

- simulators and bag_player name the topics whose readers they wait for, and log progress;
  rlg_sim says it waits for the bench's true motion;
- noise_node reading an Imu topic waits for that topic (not the pulse/FOG defaults), and a
  node updating its hand-off logs what changed, not its whole missing list every period;
- imu_corrector names K as K, whichever key it came from.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.imu_conversion import PulseCalibration, scale_factor_line
from gyro_calib.nodes.node_state import calibration_complete
from gyro_calib.nodes.ros_io import StartGate, changes_line, progress_line

from .dds_harness import NodeProcess, launch

ROOT = Path(__file__).resolve().parents[2]

BAGS = Path(__file__).resolve().parents[2] / 'bags'


def wait_for_line(node: NodeProcess, text: str, timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if text in node.log():
            return True
        time.sleep(0.1)
    return False


def test_simulators_and_player_say_what_they_wait_for(nodes: list[NodeProcess]) -> None:
    # nobody reads /rate_table/zero_index or /gyro/pulses here, nobody publishes /imu/data;
    # noise_node reads /rate_table/joint_states (the table's motion) and rlg_sim the true
    # motion, each as soon as it is up: the line each gate settles on (said on every change)
    started = {
        'rate_table_sim': 'waiting for a reader of /rate_table/zero_index',
        'rlg_sim': 'waiting for the true motion on /sim/rate_table/true_motion',
        'bag_player': 'waiting for a reader of /gyro/pulses, /rate_table/zero_index',
        'noise_node': 'noise: waiting for /imu/data (sensor_msgs/msg/Imu)',
    }
    params = {'rate_table_sim': {'scenario': 'rate_bias', 'duration_s': 5.0},
              'rlg_sim': {}, 'bag_player': {'bag': str(BAGS / 'k_tilde_bench')},
              'noise_node': {'topic': '/imu/data'}}
    procs = {name: launch(name, params[name]) for name in started}
    nodes.extend(procs.values())
    for name, text in started.items():
        assert wait_for_line(procs[name], text), f'{name}:\n{procs[name].log()}'
    assert '/gyro/pulses' not in procs['noise_node'].log()


@dataclass
class _Pub:
    topic_name: str
    readers: int

    def get_subscription_count(self) -> int:
        return self.readers


class _Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, line: str) -> None:
        self.lines.append(line)


def test_the_start_gate_logs_each_change_of_what_it_waits_for_once() -> None:
    log = _Log()
    gate = StartGate(True, settle_s=0.0, logger=log)
    a, b = _Pub('/a', 0), _Pub('/b', 0)
    for _ in range(5):
        assert not gate.open([a, b])
    a.readers = 1
    for _ in range(5):
        assert not gate.open([a, b])
    b.readers = 1
    assert gate.open([a, b])
    assert log.lines == ['waiting for a reader of /a, /b', 'waiting for a reader of /b',
                         'every topic has its readers; starting in 0 s']


def test_min_readers_holds_the_sensor_topics_but_an_internal_topic_needs_one_reader() -> None:
    # A lab records and calibrates at once (min_subscribers 2): the table waits until both
    # hear its sensor topics; the true motion only the gyro simulator reads opens with one.
    gate = StartGate(True, min_readers=2, settle_s=0.0)
    table, truth = _Pub('/rate_table/joint_states', 1), _Pub('/sim/rate_table/true_motion', 1)
    assert not gate.open([table], internal=[truth])  # the recorder alone: not yet
    table.readers = 2
    truth.readers = 0
    assert not gate.open([table], internal=[truth])  # no gyro simulator yet
    truth.readers = 1
    assert gate.open([table], internal=[truth])


def test_a_hand_off_update_logs_what_changed_not_the_whole_list() -> None:
    keys = {f'k{i}' for i in range(20)}
    assert changes_line(None, keys).startswith('still missing: k0, k1')
    assert changes_line(keys, keys) is None  # nothing new: nothing logged
    assert changes_line(keys, keys - {'k3'}) == 'now measured: k3; 19 still missing'
    assert changes_line(keys - {'k3'}, keys) == 'now missing: k3; 20 still missing'
    assert changes_line({'k1'}, set()) == 'now measured: k1; complete'


def test_a_node_calls_complete_what_its_hand_off_file_calls_complete() -> None:
    # A plain rate table gives K̃ only: θ and K are not measurable there, so the hand-off is
    # complete, and the node must not keep its state directory as 'calibration not complete'.
    session = calibrate_bags([str(ROOT / 'bags' / 'k_tilde_bench')]).sessions['rbrlg']
    record = session.handoff('bags/k_tilde_bench')
    assert record is not None and record.complete
    assert 'fix_error_angle_rad' in session.missing()
    assert calibration_complete(session.missing(), session.not_measurable())
    assert not calibration_complete({'k1': 'why', 'k2': 'why'}, {'k1': 'bench'})
    assert calibration_complete({}, {})


def test_progress_lines_say_how_far_and_how_fast() -> None:
    assert progress_line('rate table', 120.0, 600.0, 24.0) == \
        'rate table: 120 of 600 s (20 %), 5.0× real time'
    assert progress_line('rlg_sim', 30.0, float('nan'), 10.0) == \
        'rlg_sim: 30 s so far, 3.0× real time'


def test_imu_corrector_names_k_whichever_key_it_came_from() -> None:
    line = scale_factor_line(PulseCalibration(1.115e-05, 0.0, 'thermal_model'))
    assert line.startswith('K = 1.115e-05 ± 0.0 rad/pulse (from the scale factor the '
                           'thermal_model was fitted with)')
    assert 'thermal_model =' not in line
    assert scale_factor_line(PulseCalibration(4e-6, 1e-13, 'k_tilde_rad_per_pulse')) \
        .startswith('K̃ = 4e-06')
