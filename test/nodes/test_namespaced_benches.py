"""Many benches on one graph (issue 19 part 2).

Many benches on one graph (issue 19 part 2): two benches with different gyros, each in its
own namespace (``-r __ns:=/benchN``), run at once on one DDS domain; each calibration node
measures its own gyro, and one bag recorded from both is calibrated per namespace.
"""

from __future__ import annotations

import time
from pathlib import Path

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import bag_info
from gyro_calib.handoff import load_calibration
from gyro_calib.rbrlg.calibrator import calibrate_k_tilde
from gyro_calib.units import RAD_PER_ARCSEC
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import simulate_rate_bias_bench
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig

from .dds_harness import NodeProcess, launch

DURATION_S, RATE_HZ, SPEED = 60.0, 250.0, 10.0
"""Two window pairs per bench at 250 Hz (K̃ needs two), ten times real time."""
BENCHES = {'/bench1': (31, 0.84279066), '/bench2': (32, 0.8391)}
"""namespace → (seed, the gyro's true scale factor, ″/pulse): two different gyros."""


def _offline_k_tilde_rad(seed: int, scale_arcsec: float) -> float:
    run = simulate_rate_bias_bench(
        RateTableConfig(duration_s=DURATION_S, seed=seed, sample_rate_hz=RATE_HZ),
        RingLaserGyroConfig(seed=seed, scale_factor_arcsec_per_pulse=scale_arcsec))
    cal = calibrate_k_tilde(run.pulse_t_ns, run.pulse_counts, run.table_t_ns,
                            run.table_angle_rad, run.table_rate_rad_s, run.zero_index_ns)
    return cal.k_tilde().value * RAD_PER_ARCSEC


def _wait_for(node: NodeProcess, text: str, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while text not in node.log():
        assert time.monotonic() < deadline and node.proc.poll() is None, node.log()
        time.sleep(0.1)


def test_two_namespaced_benches_at_once_each_calibrate_their_own_gyro(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    lab = tmp_path / 'lab'
    recorder = launch('bag_recorder', {'out': str(lab), 'namespaces': list(BENCHES)})
    nodes.append(recorder)
    calibrators = {}
    for ns, (seed, scale) in BENCHES.items():
        out = tmp_path / f'{ns.strip("/")}.yaml'
        calibrators[ns] = launch('calibration_node', {'output_file': str(out)}, namespace=ns)
        nodes.append(calibrators[ns])
        nodes.append(launch('rlg_sim', {'seed': seed, 'scale_factor_arcsec_per_pulse': scale,
                                        'min_subscribers': 2},  # the recorder hears it all too
                            namespace=ns))
    _wait_for(recorder, 'recording /bench1/gyro/pulses')
    for node in calibrators.values():
        _wait_for(node, 'calibrating K̃')
    tables = [launch('rate_table_sim', {'duration_s': DURATION_S, 'seed': seed,
                                        'sample_rate_hz': RATE_HZ, 'real_time_factor': SPEED,
                                        # the recorder and the calibration node both read
                                        # every table topic: neither may miss its start
                                        'min_subscribers': 2},
                     namespace=ns) for ns, (seed, _) in BENCHES.items()]
    nodes.extend(tables)
    for table in tables:
        assert table.proc.wait(timeout=DURATION_S / SPEED + 300) == 0, table.log()
    for node in (*calibrators.values(), recorder):
        node.stop(timeout_s=60)
    logs = '\n'.join(n.log() for n in nodes)
    expected = {ns: _offline_k_tilde_rad(*bench) for ns, bench in BENCHES.items()}
    assert expected['/bench1'] != expected['/bench2']
    for ns in BENCHES:
        live = load_calibration(tmp_path / f'{ns.strip("/")}.yaml')
        assert live.values.get('k_tilde_rad_per_pulse') == expected[ns], logs  # its own gyro
        recorded = calibrate_bags([lab], methods=['rbrlg'], namespace=ns)
        k = recorded.sessions['rbrlg'].results()['k_tilde_rad_per_pulse']
        assert k.value == expected[ns]
    info = bag_info(lab)
    assert {'/bench1/gyro/pulses', '/bench2/gyro/pulses'} <= set(info.topics)
    assert not any(t.startswith('/gyro') for t in info.topics)  # nothing left at the root
    assert info.in_namespace('/bench2').scenario  # each bench's scenario stored for it
