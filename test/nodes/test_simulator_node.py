"""One simulator-node skeleton (issue 28): every simulator node is built on it.

Start-up, the run parameters, the start gate, the pacing, the progress and the end of a run
are written once (:mod:`sim_nodes.simulator_node`); a simulator node keeps only its physics
and its messages. A toy simulator on the skeleton shows what every one of them does.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import inspect
import os
import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import sim_nodes
from gyro_calib.nodes.processes import ros_environment

ROOT = Path(__file__).resolve().parents[2]

SKELETON_NAMES = ('StartGate', 'ProgressLog', 'simulation_done', 'acknowledge_tail',
                  'stops_on_stalled_readers', 'SCENARIO_QOS')
"""What only the skeleton uses: a node module naming one wrote its own start-up again."""


def _source(module: str) -> str:
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin is not None, module
    return Path(spec.origin).read_text(encoding='utf-8')


def _node_modules() -> list[str]:
    """The modules of sim_nodes that are ROS nodes (they use rclpy or the skeleton)."""
    return [m.name for m in pkgutil.walk_packages(sim_nodes.__path__, 'sim_nodes.')
            if m.name != 'sim_nodes.simulator_node'
            and any(word in _source(m.name) for word in ('rclpy', 'sim_nodes.simulator_node'))]


def test_every_simulator_node_is_built_on_the_skeleton() -> None:
    from rclpy.node import Node

    from sim_nodes.simulator_node import PacedSimulatorNode, SimulatorNode

    modules = _node_modules()
    assert {'sim_nodes.rate_table_node', 'sim_nodes.rbrlg.rlg_node',
            'sim_nodes.dither.vibration_table_node', 'sim_nodes.thermal.chamber_node',
            'sim_nodes.fog.fog_node', 'sim_nodes.triad.triad_node',
            'sim_nodes.multiposition.imu_node'} <= set(modules)
    paced = 0
    for name in modules:
        module = importlib.import_module(name)
        nodes = [cls for _, cls in inspect.getmembers(module, inspect.isclass)
                 if cls.__module__ == name and issubclass(cls, Node)]
        assert nodes, name
        for cls in nodes:
            assert issubclass(cls, SimulatorNode), cls
            paced += issubclass(cls, PacedSimulatorNode)
        source = inspect.getsource(module)
        used = {n.id for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Name)} | {
            a.name for n in ast.walk(ast.parse(source)) if isinstance(n, ast.ImportFrom)
            for a in n.names}
        assert not used & set(SKELETON_NAMES) - ({'ProgressLog'} if name.endswith('rlg_node')
                                                 else set()), name
    assert paced == len(modules) - 1  # all but rlg_sim, which follows the table's true motion


TOY = textwrap.dedent('''
    from sensor_msgs.msg import JointState

    from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced
    from sim_nodes.simulator_node import PacedSimulatorNode, run_simulator

    published = []


    class Toy(PacedSimulatorNode):
        samples_what = 'toy samples'
        progress_what = 'toy'
        total_s = 0.7

        def __init__(self):
            super().__init__('toy_sim')
            self.declare_run_parameters()
            self.pub = self.create_publisher(JointState, 'toy', SENSOR_QOS)
            self.publish_scenario({'name': 'toy', 'chunks': 7})
            self.sample_rate_hz = 100.0
            self._chunks = iter([list(range(10 * k, 10 * k + 10)) for k in range(7)])

        @property
        def all_publishers(self):
            return [self.pub]

        def _publish(self, chunk):
            for i in chunk:
                msg = JointState(name=['toy'], position=[float(i)])
                ns_to_stamp(i * 10_000_000, msg.header.stamp)
                publish_paced(self.pub, msg)
                published.append(i)
            self._n_published += len(chunk)


    run_simulator('toy_sim', Toy, ['--ros-args', '-p', 'wait_for_subscribers:=false',
                                   '-p', 'real_time_factor:=0.0'])
    print('published', published == list(range(70)))
''')


def test_a_simulator_on_the_skeleton_publishes_its_whole_run_says_so_and_exits() -> None:
    """Unpaced and not waiting for readers: every chunk in order, a start and an end line."""
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    env['PYTHONPATH'] = os.pathsep.join(filter(None, (str(ROOT), env.get('PYTHONPATH'))))
    proc = subprocess.run([sys.executable, '-c', TOY], env=env, capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == 'published True', proc.stdout + proc.stderr
    assert "toy: simulating 0.7 s at the readers' pace" in proc.stderr
    assert 'run finished: 70 toy samples' in proc.stderr
    assert proc.stderr.count('run finished') == 1
