"""A simulator whose reader stops reading while still connected ends cleanly and says why.

Reproduced live (issue 17 leftover): ``thermal_chamber_sim -p real_time_factor:=0.0`` with a
reader that read 6 s and then hung died 30 s later with a traceback ending in
``RCLError: Failed to publish: cannot publish data``. Now the node logs one line naming the
topic, its readers and the patience, and exits with status 3 (the run was not delivered
whole), no traceback. The DDS writer is replaced by one that refuses every sample (what a
full history of unacknowledged samples does), so the test takes a second, not 30 s; the
node is the real ``run_node`` loop with a ``stops_on_stalled_readers`` callback, as in
``sim_nodes.thermal.chamber_node``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from gyro_calib.nodes.processes import ros_environment

ROOT = Path(__file__).resolve().parents[2]

NODE = textwrap.dedent('''
    from rclpy._rclpy_pybind11 import RCLError
    from rclpy.node import Node

    from gyro_calib.nodes.ros_io import (acknowledge_tail, publish_paced, run_node,
                                         simulation_done, stops_on_stalled_readers)


    class FullWriter:
        """A reliable writer whose history is full: every publish fails."""
        topic_name = '/gyro/temperature'

        def publish(self, msg):
            raise RCLError('Failed to publish: cannot publish data')

        def wait_for_all_acked(self, timeout):
            return False

        def get_subscription_count(self):
            return 1


    class Sim(Node):
        def __init__(self):
            super().__init__('stalled_sim')
            self.done, self.exit_when_done, self.stalled = False, True, ''
            self.all_publishers = []
            self.writer = FullWriter()
            self.create_timer(0.01, self._tick)

        @stops_on_stalled_readers
        def _tick(self):
            publish_paced(self.writer, object(), patience_s=0.3)


    run_node('stalled_sim', Sim, None, done=simulation_done, on_stop=acknowledge_tail)
''')


def test_a_stalled_reader_ends_the_simulator_in_one_line_with_status_3() -> None:
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    env['PYTHONPATH'] = os.pathsep.join(filter(None, (str(ROOT), env.get('PYTHONPATH'))))
    proc = subprocess.run([sys.executable, '-c', NODE], env=env, capture_output=True,
                          text=True, timeout=60, check=False)
    err = proc.stderr
    assert proc.returncode == 3, err
    assert 'Traceback' not in err and 'Error occurred at' not in err, err
    errors = [line for line in err.splitlines() if '[ERROR]' in line or '[FATAL]' in line]
    assert len(errors) == 1, err
    assert ('the reader(s) of /gyro/temperature (1 connected) acknowledged nothing for 0.3 s'
            in errors[0]), err
    assert 'stopping before the end of the run' in errors[0]


def test_a_stall_names_the_reading_nodes_where_the_publisher_can_see_them() -> None:
    """``publish_paced(..., graph=node)`` names the readers it waits for, as their nodes.

    (The players and simulators pass themselves: a stalled run says which reader stopped.)
    """
    from std_msgs.msg import String

    from gyro_calib.nodes.ros_io import SENSOR_QOS, reader_nodes

    from .dds_harness import bench_node, wait_discovered

    with bench_node('test_names_player') as (player, executor), \
            bench_node('test_names_reader') as (reader, _):
        reader.create_subscription(String, '/harness/names', lambda _: None, SENSOR_QOS)
        assert wait_discovered(executor, lambda: reader_nodes(player, '/harness/names')
                               == ['/test_names_reader'], timeout_s=30.0, settle_s=0.0), \
            reader_nodes(player, '/harness/names')
