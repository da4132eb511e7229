"""The triad method over DDS.

A replayed bag into triad_calibration_node gives the offline hand-off (K_i, sense axes and M
of the imu: section) bit for bit.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import HandoffError, load_calibration
from gyro_calib.triad.session import TriadSession

from .dds_harness import NodeProcess, launch


def test_replayed_triad_bag_gives_the_offline_imu_section(nodes: list[NodeProcess],
                                                           tmp_path: Path) -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from test_triad_session import _write_bag
    from triad_bench_physics import Bench, random_triad, record

    bench = Bench(inner_pairs=1, inner_turns=1, pulse_hz=500.0,
                  outer_rate_rad_s=math.radians(150.0), outer_accel_rad_s2=math.radians(300.0),
                  stations_rad=(0.0, 2 * math.pi / 3, 4 * math.pi / 3))
    triad = random_triad(np.random.default_rng(4))
    bag = tmp_path / 'triad_bag'
    _write_bag(bag, record(bench, triad, np.random.default_rng(4)), bench)
    offline = calibrate_bags([bag], methods=['triad']).sessions['triad']
    assert isinstance(offline, TriadSession)
    expected = offline.imu_calibration()
    assert expected is not None and expected.scale_factor_rad_per_pulse is not None
    config = tmp_path / 'triad.yaml'
    config.write_text(yaml.safe_dump({'triad_calibration_node': {'ros__parameters': {
        'tilt_deg': 45.0, 'tilt_std_arcsec': 60.0, 'position_table_revolutions': 1,
        'revolutions_per_window': 1, 'analysis_period_s': 5.0}}}))
    out = tmp_path / 'imu.yaml'
    node = launch('triad_calibration_node', {
        'config_file': str(config), 'output_file': str(out), 'latitude_deg': 40.0,
        'heading_deg': 20.0})
    nodes.append(node)
    time.sleep(3.0)
    nodes.append(launch('bag_player', {'bag': str(bag), 'rate': 0.0}))
    got = None
    deadline = time.monotonic() + 150.0
    while time.monotonic() < deadline:
        try:
            imu = load_calibration(out).imu if out.exists() else None
        except HandoffError:
            imu = None
        if imu is not None and imu.scale_factor_rad_per_pulse is not None and np.array_equal(
                imu.scale_factor_rad_per_pulse, expected.scale_factor_rad_per_pulse):
            got = imu
            break
        time.sleep(1.0)
    assert got is not None, node.log()[-3000:]
    assert got.pulses_to_body_rad is not None and expected.pulses_to_body_rad is not None
    np.testing.assert_array_equal(got.pulses_to_body_rad, expected.pulses_to_body_rad)
    assert got.channels == ('gx', 'gy', 'gz')
