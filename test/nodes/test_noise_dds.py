"""noise_node over DDS.

noise_node over DDS: a replayed IMU bag gives the offline ``gyro-calib noise`` terms bit for
bit on /diagnostics, and SIGINT leaves complete files (Kalibr imu.yaml, figure, hand-off).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import signal
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.noise.keys import imu_key
from sim_nodes.noise.bag_scenarios import SCENARIOS, write_scenario_bag

from .dds_harness import NodeProcess, ResultListener, launch

STATUS = 'gyro_calib: noise'


class NoiseListener(ResultListener):
    """Keeps the latest /diagnostics status of the noise node."""

    def _on_diag(self, msg: Any) -> None:
        for status in msg.status:
            if status.name == STATUS:
                self.diagnostics = {kv.key: kv.value for kv in status.values}


def _offline(bag: Path, out: Path) -> dict[str, Any]:
    """``gyro-calib noise`` on the bag: its JSON, with the Kalibr and hand-off files in out/."""
    out.mkdir()
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        status = gyro_calib_main(['noise', str(bag), '--json', '--no-progress',
                                  '--kalibr', str(out / 'imu.yaml'),
                                  '--out', str(out / 'handoff.yaml')])
    assert status == 0, stderr.getvalue()
    return json.loads(stdout.getvalue())  # type: ignore[no-any-return]


def test_replayed_imu_bag_gives_the_offline_terms_and_sigint_leaves_complete_files(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    # the committed noise_imu_static scenario (disorder included) cut to 100 s: the node's
    # per-message cost, not the analysis, sets this test's time
    bag = write_scenario_bag(dataclasses.replace(SCENARIOS['noise_imu_static'],
                                                 name='noise_imu_100s', duration_s=100.0),
                             tmp_path / 'noise_imu_100s')
    doc = _offline(bag, tmp_path / 'offline')
    expected = {imu_key(axis, key): r for axis, a in doc['methods']['noise']['axes'].items()
                for key, r in a['results'].items()}
    # N of all six axes, and B of a gyro and of an accelerometer axis
    assert {k for k in expected if 'random_walk' in k} == {
        imu_key(f'{sensor}_{axis}', f'{walk}_random_walk_{unit}') for axis in 'xyz'
        for sensor, walk, unit in (('gyro', 'angle', 'rad_per_sqrt_s'),
                                   ('accel', 'velocity', 'm_s_per_sqrt_s'))}
    assert any(k.startswith('imu_gyro') and 'bias_instability' in k for k in expected)
    assert any(k.startswith('imu_accel') and 'bias_instability' in k for k in expected)

    live = tmp_path / 'live'
    live.mkdir()
    listener = NoiseListener()
    try:
        node = launch('noise_node', {
            'topic': '/imu/data', 'results_period_s': 3.0,
            'kalibr_file': str(live / 'imu.yaml'), 'plot_file': str(live / 'adev.png'),
            'output_file': str(live / 'handoff.yaml')})
        nodes.append(node)
        player = launch('bag_player', {'bag': str(bag), 'rate': 0.0})
        nodes.append(player)

        def same() -> bool:
            d = listener.diagnostics
            return all(d.get(k) == repr(r['value']) and d.get(k + '_std') == repr(r['std'])
                       and d.get(k + '_n') == str(r['n']) for k, r in expected.items())

        done = listener.spin_until(lambda: same() or node.proc.poll() is not None, 300,
                                   source=player, grace_s=60)
        logs = '\n'.join(n.log() for n in nodes)
        assert done and node.proc.poll() is None, (listener.diagnostics, logs)
        d = listener.diagnostics
        measured = {k for k in d if k.startswith('imu_') and not k.endswith(
            ('_std', '_n', '_missing'))}
        assert measured == set(expected), logs  # no term more, none fewer
        assert all(k + '_missing' in d for k in (
            'imu_gyro_x_rate_random_walk_rad_per_s_sqrt_s', 'imu_gyro_x_rate_ramp_rad_per_s2'))
        assert player.proc.wait(timeout=120) == 0, player.log()
    finally:
        listener.close()

    node.send_signal(signal.SIGINT)
    assert node.proc.wait(timeout=90) == 0, node.log()
    offline = tmp_path / 'offline'
    assert (live / 'imu.yaml').read_text() == (offline / 'imu.yaml').read_text(), node.log()
    live_values = yaml.safe_load((live / 'handoff.yaml').read_text())['gyro']
    offline_values = yaml.safe_load((offline / 'handoff.yaml').read_text())['gyro']
    assert live_values == offline_values
    png = (live / 'adev.png').read_bytes()
    assert png.startswith(b'\x89PNG\r\n\x1a\n') and png.rstrip().endswith(b'IEND\xaeB`\x82')
    assert not [p.name for p in live.iterdir() if p.name.startswith('.')]  # no temporary left
    assert f'hand-off written: {live / "handoff.yaml"}' in node.log()
