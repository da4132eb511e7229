"""A live triad bench over DDS writes the hand-off `gyro-calib calibrate` writes offline (§F).

triad_sim (the two-axis scenario at 200 Hz, as fast as the reader acknowledges) →
triad_calibration_node, given the scenario's bench settings in its config file (the node only
names those /sim/scenario offers: its results depend on the data and settings); the ``imu:``
section of its hand-off equals, key for key and bit for bit, the one of
``gyro-calib calibrate --method triad --out`` on the bag ``gyro-calib simulate`` writes for
the same scenario, seed and rate — before and after the node is stopped.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from gyro_calib.cli import main as gyro_calib
from sim_nodes.triad.triad_node import scenario_with

from .dds_harness import NodeProcess, launch

SCENARIO, SEED, RATE_HZ = 'triad_two_axis_bench', 11, 200.0


def _imu_section(path: Path) -> dict[str, Any] | None:
    try:
        doc = yaml.safe_load(path.read_text(encoding='utf-8')) if path.exists() else None
    except yaml.YAMLError:  # the node replaces it atomically; a torn read is not expected
        return None
    return doc.get('imu') if isinstance(doc, dict) else None


def test_live_triad_bench_writes_the_offline_imu_section(
        nodes: list[NodeProcess], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag, offline = tmp_path / 'bag', tmp_path / 'offline.yaml'
    assert gyro_calib(['simulate', SCENARIO, '--seed', str(SEED), '--sample-rate-hz',
                       str(RATE_HZ), '--out', str(bag)]) == 0
    assert gyro_calib(['calibrate', str(bag), '--method', 'triad', '--out', str(offline)]) == 0
    capsys.readouterr()
    expected = _imu_section(offline)
    assert expected is not None and 'pulses_to_body_rad' in expected, expected
    assert 'not_measurable' not in expected and 'missing' not in expected

    bench = scenario_with(SCENARIO, SEED, RATE_HZ).bench_settings()
    assert bench.pop('fixture_rotation') == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    live = tmp_path / 'live.yaml'
    config = tmp_path / 'triad.yaml'
    config.write_text(yaml.safe_dump({'triad_calibration_node': {'ros__parameters': {
        **bench, 'analysis_period_s': 2.0}}}), encoding='utf-8')
    node = launch('triad_calibration_node', {'config_file': str(config),
                                             'output_file': str(live)})
    nodes.append(node)
    sim = launch('triad_sim', {'scenario': SCENARIO, 'seed': SEED, 'sample_rate_hz': RATE_HZ,
                               'real_time_factor': 0.0})
    nodes.append(sim)
    assert sim.proc.wait(timeout=120) == 0, sim.log()
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and _imu_section(live) != expected:
        time.sleep(1.0)
    logs = f'{sim.log()[-2000:]}\n--- node:\n{node.log()[-4000:]}'
    got = _imu_section(live)
    assert got == expected, (got, logs)
    assert 'not taken' not in node.log(), node.log()  # every bench setting was given
    node.send_signal(signal.SIGINT)  # the end of the data: judged again, written again
    assert node.proc.wait(timeout=60) == 0, logs
    assert _imu_section(live) == expected, node.log()[-4000:]
    written = yaml.safe_load(live.read_text(encoding='utf-8'))
    assert written['format_version'] == 4 and written['methods']['triad']['source'] == 'live'
    conditions = yaml.safe_load(offline.read_text(encoding='utf-8'))['methods']['triad'][
        'conditions']
    assert written['methods']['triad']['conditions'] == conditions
