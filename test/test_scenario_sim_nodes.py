"""The scenario simulator nodes (triad_sim, imu_multiposition_sim) share one set-up.

``duplicates`` found imu_multiposition_sim's set-up a near-copy of triad_sim's: the
parameters ``scenario``, ``seed`` and ``sample_rate_hz`` declared, an unknown scenario
refused, the seed and rate applied (:meth:`PacedSimulatorNode.declare_scenario
<sim_nodes.simulator_node.PacedSimulatorNode.declare_scenario>`). One set-up, one behaviour:
triad_sim ended an unknown scenario with exit 1 (``SystemExit``), the IMU sim with exit 2
and one fatal line; now both refuse it as bad input — exit 2, one line naming the scenarios.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gyro_calib.nodes.processes import NODE_MODULES, ros_args, ros_environment
from sim_nodes.multiposition.scenarios import SCENARIOS as MULTIPOSITION
from sim_nodes.scenarios import with_node_parameters, with_overrides
from sim_nodes.triad.scenarios import SCENARIOS as TRIAD

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(('node', 'known'), [('triad_sim', TRIAD),
                                             ('imu_multiposition_sim', MULTIPOSITION)])
def test_an_unknown_scenario_is_one_fatal_line_and_exit_2(
        node: str, known: dict[str, object], tmp_path: Path) -> None:
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    env['PYTHONPATH'] = str(ROOT)
    done = subprocess.run([sys.executable, '-m', NODE_MODULES[node],
                           *ros_args({'scenario': 'no_such_bench'})],
                          env=env, capture_output=True, text=True, timeout=60, cwd=tmp_path)
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and 'Traceback' not in done.stderr and not done.stdout
    assert lines[0].endswith(f"{node}: scenario 'no_such_bench' is not one of "
                             f'{", ".join(known)}.'), lines[0]


@pytest.mark.parametrize('name', ['triad_remount_bench_py', 'multiposition_hand_turned'])
def test_the_node_parameters_give_the_scenario_simulate_writes(name: str) -> None:
    """Seed −1 and rate 0 keep the scenario's; others are simulate's overrides."""
    assert with_node_parameters(name, -1, 0.0) == with_overrides(name, {})
    assert with_node_parameters(name, 5, 40.0) == with_overrides(
        name, {'seed': 5, 'sample_rate_hz': 40.0})
