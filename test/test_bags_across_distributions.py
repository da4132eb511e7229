"""A bag written under one supported ROS 2 distribution reads the same under the other.

The committed bags in ``bags/`` were written under Kilted; ``test/data/recorded_on_jazzy``
was recorded over DDS by ``bag_recorder`` running on the Jazzy wheels (rate-bias bench,
seed 7, 12 s at 5× real time, ``log_time:=header``). CI runs this file under both
distributions (``./run.sh test`` and ``./run.sh test --ros jazzy``), so each reads the
other's bags, with our reader and with the running distribution's own rclpy.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gyro_calib import topics
from gyro_calib.bagio import bag_info, iter_raw_messages, iter_sample_batches
from gyro_calib.nodes.ros_distribution import SUPPORTED_DISTRIBUTIONS, rclpy_version
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import simulate_rate_bias_bench
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig

ROOT = Path(__file__).resolve().parents[1]
JAZZY_BAG = ROOT / 'test' / 'data' / 'recorded_on_jazzy'
KILTED_BAGS = [ROOT / 'bags' / name for name in
               ('k_tilde_bench', 'noise_imu_static', 'thermal_validation', 'triad_two_axis_bench',
                'fog_turntable', 'dither_z')]
MESSAGES_PER_TOPIC = 50


def test_the_running_rclpy_is_of_a_supported_distribution() -> None:
    version = rclpy_version()
    assert version is not None and version[0] in (7, 9), version  # Jazzy 7.x, Kilted 9.x
    assert SUPPORTED_DISTRIBUTIONS == ('jazzy', 'kilted')


def test_the_bag_recorded_on_jazzy_holds_the_simulated_bench_sample_for_sample() -> None:
    seed, duration = 7, 12.0
    sim = simulate_rate_bias_bench(RateTableConfig(duration_s=duration, seed=seed),
                                   RingLaserGyroConfig(seed=seed))
    info = bag_info(JAZZY_BAG)
    assert info.topics[topics.GYRO_PULSES].count == len(sim.pulse_t_ns) == 12001
    assert info.topics[topics.RATE_TABLE_JOINT_STATES].count == len(sim.table_t_ns)
    (batch,) = iter_sample_batches(JAZZY_BAG, batch_messages=10**9)
    pulses = batch.joint_state(topics.GYRO_PULSES)
    table = batch.joint_state(topics.RATE_TABLE_JOINT_STATES)
    assert pulses is not None and table is not None
    np.testing.assert_array_equal(pulses[0], sim.pulse_t_ns)
    np.testing.assert_array_equal(pulses[1], sim.pulse_counts)
    np.testing.assert_array_equal(table[1], sim.table_angle_rad)
    np.testing.assert_array_equal(batch.stamps(topics.RATE_TABLE_ZERO_INDEX), sim.zero_index_ns)
    assert info.scenario['table']['seed'] == seed


def _same(ours: Any, theirs: Any, where: str) -> None:
    """The message rclpy reads equals the one rosbags reads, field by field (NaN = NaN)."""
    if hasattr(ours, 'get_fields_and_field_types'):
        for name in ours.get_fields_and_field_types():
            _same(getattr(ours, name), getattr(theirs, name), f'{where}.{name}')
    elif isinstance(ours, (list, tuple, np.ndarray)) and len(ours) and hasattr(
            ours[0], 'get_fields_and_field_types'):
        assert len(ours) == len(theirs), where
        for i, (a, b) in enumerate(zip(ours, theirs, strict=True)):
            _same(a, b, f'{where}[{i}]')
    elif isinstance(ours, (str, bytes)):
        assert ours == theirs, where
    else:
        np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs), err_msg=where)


@pytest.mark.parametrize('bag', [JAZZY_BAG, *KILTED_BAGS], ids=lambda p: p.name)
def test_the_running_rclpy_reads_every_message_as_the_bag_holds_it(bag: Path) -> None:
    """This distribution's rclpy reads each message as rosbags does, and round-trips it."""
    from rclpy.serialization import deserialize_message, serialize_message

    from gyro_calib.bagio import typestore
    from gyro_calib.nodes.bag_player import message_class

    store = typestore()
    wanted = {name: min(t.count, MESSAGES_PER_TOPIC)
              for name, t in bag_info(bag).topics.items() if t.count}
    seen: dict[str, int] = {}
    for topic, msgtype, _, raw in iter_raw_messages(bag):
        if seen == wanted:
            break
        if seen.get(topic, 0) >= wanted[topic]:
            continue
        seen[topic] = seen.get(topic, 0) + 1
        cls = message_class(msgtype)
        message = deserialize_message(raw, cls)
        _same(message, store.deserialize_cdr(raw, msgtype), f'{bag.name}:{topic}')
        assert deserialize_message(serialize_message(message), cls) == message, topic
    assert seen == wanted
