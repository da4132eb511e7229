"""The dither method over DDS.

The dither method over DDS: the live bench (vibration_table_sim, Z then Y) and a replay of
the committed bags into dither_calibration_node give the offline numbers bit for bit,
publish a on /gyro_calib/dither/misalignment and write the hand-off file.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
import yaml

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import bag_info
from gyro_calib.dither.calibrator import KEY_A, calibrate_dither
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.estimate import Estimate
from gyro_calib.session import CalibrationOptions
from sim_nodes.dither.bag_scenarios import SCENARIOS, write_scenario_bag
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.scenarios import simulate_dither_run

from .dds_harness import NodeProcess, ResultListener, launch

GYRO = SCENARIOS['dither_z'].gyro
TABLE = SCENARIOS['dither_z'].table
K = GYRO.scale_factor_rad_per_pulse


class DitherListener(ResultListener):
    """Also listens to /gyro_calib/dither/misalignment and the ``gyro_calib: dither`` status."""

    def __init__(self) -> None:
        super().__init__()
        from std_msgs.msg import Float64

        from gyro_calib.nodes.ros_io import RESULT_QOS

        self.misalignment: list[float] = []
        self.dither: dict[str, str] = {}
        self.node.create_subscription(Float64, topics.DITHER_MISALIGNMENT,
                                      lambda m: self.misalignment.append(m.data), RESULT_QOS)

    def _on_diag(self, msg: Any) -> None:
        for status in msg.status:
            if status.name == 'gyro_calib: dither':
                self.dither = {kv.key: kv.value for kv in status.values}


@pytest.fixture
def dither_listener() -> Any:
    lst = DitherListener()
    yield lst
    lst.close()


def _diagnostics(results: dict[str, Estimate]) -> dict[str, str]:
    """The /diagnostics values the node publishes for these results (repr strings)."""
    out = {}
    for key, est in results.items():
        out[key] = repr(float(est.value))
        out[key + '_std'] = repr(float(est.std_uncertainty))
        out[key + '_n'] = str(est.n_used)
    return out


def _check(listener: DitherListener, expected: dict[str, str], nodes: list[NodeProcess],
           source: NodeProcess, output: Path) -> None:
    done = listener.spin_until(lambda: all(listener.dither.get(k) == v
                                           for k, v in expected.items()), 150.0,
                               source=source, grace_s=30.0)
    logs = '\n'.join(n.log() for n in nodes)
    got = {k: listener.dither.get(k) for k in expected}
    assert done, f'diagnostics {got} != offline {expected}\n{logs}'
    assert listener.spin_until(lambda: bool(listener.misalignment), 5.0), logs
    assert repr(listener.misalignment[-1]) == expected[KEY_A]
    record = yaml.safe_load(output.read_text())
    assert repr(record['gyro'][KEY_A]) == expected[KEY_A]
    assert record['methods']['dither']['source'] == 'live'


def test_live_bench_z_then_y_gives_the_offline_numbers_bit_for_bit(
        dither_listener: DitherListener, nodes: list[NodeProcess], tmp_path: Path) -> None:
    duration = 10.0  # five 2 s blocks per orientation: ends on a block edge (no flush live)
    bench = DitherBenchConfig(sample_rate_hz=2000.0, table_decimation=10, duration_s=duration)
    y_start = int((duration + 1.0) * 1e9)
    runs = [(TABLE, GYRO, bench),
            (dataclasses.replace(TABLE, axis='y'), dataclasses.replace(GYRO, seed=GYRO.seed + 1),
             dataclasses.replace(bench, start_time_ns=y_start))]
    recordings = [simulate_dither_run(g, t, b) for t, g, b in runs]
    offline = calibrate_dither(*recordings,
                               settings=DitherSettings(scale_factor_rad_per_pulse=K)).results()
    assert KEY_A in offline
    expected = _diagnostics(offline)
    output = tmp_path / 'gyro.yaml'
    nodes.append(launch('dither_calibration_node', {'scale_factor_rad_per_pulse': K,
                                                    'output_file': str(output)}))
    sim = None
    for table, gyro, b in runs:
        sim = launch('vibration_table_sim', {
            'orientation': table.axis, 'seed': gyro.seed, 'start_time_ns': b.start_time_ns,
            'duration_s': duration, 'table_decimation': b.table_decimation,
            'misalignment_arcmin': gyro.misalignment_arcmin,
            'ia_azimuth_deg': gyro.ia_azimuth_deg,
            'table.rate_amplitude_rad_s': table.rate_amplitude_rad_s,
            'table.frequency_hz': table.frequency_hz, 'real_time_factor': 0.0})
        nodes.append(sim)
        sim.proc.wait(timeout=120)  # it exits once the node acknowledged every sample
        assert sim.proc.returncode == 0, sim.log()
    assert sim is not None
    _check(dither_listener, expected, nodes, sim, output)
    assert 're-mounted' in nodes[0].log()


def test_replayed_bags_give_exactly_the_offline_numbers(
        dither_listener: DitherListener, nodes: list[NodeProcess], tmp_path: Path) -> None:
    # the committed dither_z / dither_y benches cut to 10 s each (5 blocks, as the live
    # bench): the node's per-message cost, not the estimator, sets this test's time
    bags = []
    for name, start_s in (('dither_z', 0.0), ('dither_y', 11.0)):
        scenario = SCENARIOS[name]
        bench = dataclasses.replace(scenario.bench, duration_s=10.0,
                                    start_time_ns=int(start_s * 1e9))
        bags.append(write_scenario_bag(dataclasses.replace(scenario, name=f'{name}_10s',
                                                           bench=bench),
                                       tmp_path / f'{name}_10s'))
    offline = calibrate_bags(bags, methods=['dither'],
                             options=CalibrationOptions(scale_factor_rad_per_pulse=K))
    expected = _diagnostics(offline.sessions['dither'].results())
    assert KEY_A in expected
    output = tmp_path / 'gyro.yaml'
    nodes.append(launch('dither_calibration_node', {'scale_factor_rad_per_pulse': K,
                                                    'output_file': str(output)}))
    player = None
    for bag in bags:
        player = launch('bag_player', {'bag': str(bag), 'rate': 0.0})
        nodes.append(player)
        player.proc.wait(timeout=120)
        n_messages = sum(t.count for t in bag_info(bag).topics.values())
        assert player.proc.returncode == 0 and f'played {n_messages} messages' in player.log(), \
            player.log()
    assert player is not None
    _check(dither_listener, expected, nodes, player, output)
