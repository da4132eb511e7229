"""Chamber runs as node parameters and bags.

Chamber runs as node parameters and bags: streamed in chunks they give the offline samples
(faults included), and the bag bytes are what rosbags would write.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gyro_calib.topics import GYRO_PULSES, GYRO_TEMPERATURE
from sim_nodes.thermal.bag_scenarios import SCENARIOS, TemperatureMessages, run_messages
from sim_nodes.thermal.scenarios import ChamberRunConfig, continuous_ramp_scenario

FAULTY = ChamberRunConfig(programme='continuous_ramp', gyro_id='C-1', seed=8, low_c=-5.0,
                          high_c=5.0, rate_c_per_min=1.0, dwell_s=300.0, stuck_sensor='shell',
                          stuck_from_s=700.0, dropout_sensor='cavity_a', dropout_start_s=333.3,
                          dropout_end_s=401.0)


@pytest.mark.parametrize('chunk_s', [3.7, 61.0, 600.0])
def test_streamed_run_equals_the_offline_recording_faults_included(chunk_s: float) -> None:
    rec = FAULTY.recording()
    parts = list(FAULTY.run().chunks(chunk_s))
    for name in ('pulse_t_ns', 'pulse_counts', 'temperature_t_ns', 'temperature_c',
                 'temperature_variance_c2', 'temperature_frame_id'):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(rec, name), err_msg=name)
    shell = rec.temperature_c[rec.temperature_frame_id == 'shell']
    t_shell = rec.temperature_t_ns[rec.temperature_frame_id == 'shell']
    stuck = (t_shell - FAULTY.start_time_ns) >= 700 * 10**9
    assert len(set(shell[stuck].tolist())) == 1 and shell[stuck][0] == shell[~stuck][-1]
    rel = (rec.temperature_t_ns - FAULTY.start_time_ns) / 1e9
    assert not np.any((rec.temperature_frame_id == 'cavity_a') & (rel >= 333.3) & (rel < 401))


def test_named_scenario_functions_and_run_configs_give_the_same_samples() -> None:
    cfg = ChamberRunConfig(programme='continuous_ramp', gyro_id='A-2', seed=6, low_c=-20.0,
                           high_c=20.0, rate_c_per_min=0.5, dwell_s=900.0, pulse_rate_hz=10.0)
    a = cfg.recording()
    b = continuous_ramp_scenario('A-2', 6, low_c=-20.0, high_c=20.0, rate_c_per_min=0.5,
                                 dwell_s=900.0)
    np.testing.assert_array_equal(a.pulse_counts, b.pulse_counts)
    np.testing.assert_array_equal(a.temperature_c, b.temperature_c)
    assert a.scenario == b.scenario


@pytest.mark.parametrize('field, value', [('programme', 'sweep'), ('gyro_id', 'Z-9'),
                                          ('stuck_sensor', 'cavity_c')])
def test_run_config_refuses_names_the_simulator_does_not_know(field: str, value: str) -> None:
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(ChamberRunConfig(), **{field: value})


def test_hand_packed_cdr_is_byte_for_byte_what_rosbags_writes() -> None:
    cdr = TemperatureMessages()
    rng = np.random.default_rng(17)
    for _ in range(300):
        t = int(rng.integers(0, 2**31 * 10**9))
        c, v = float(rng.normal(0, 50)), float(rng.uniform(0, 1))
        for sensor in ('cavity_a', 'cavity_b', 'shell', 'x'):
            assert cdr.temperature(t, sensor, c, v) == cdr.temperature_rosbags(t, sensor, c, v)
        n = float(np.floor(rng.uniform(-1e12, 1e12)))
        assert cdr.pulses(t, n) == cdr.contract.joint_state(t, 'gyro', n)


def test_bag_messages_are_in_stamp_order_pulse_first_at_equal_stamps() -> None:
    msgs = list(run_messages(dataclasses.replace(FAULTY, duration_s=30.0).run(), chunk_s=7.0))
    stamps = [m.log_time_ns for m in msgs]
    assert stamps == sorted(stamps)
    first_at = {}
    for m in msgs:
        first_at.setdefault(m.log_time_ns, m.topic)
    assert all(topic == GYRO_PULSES for t, topic in first_at.items()
               if any(m.topic == GYRO_TEMPERATURE and m.log_time_ns == t for m in msgs))


def test_committed_scenarios_are_small_hours_long_runs() -> None:
    for scenario in SCENARIOS.values():
        cfg = scenario.config
        assert cfg.pulse_rate_hz <= 2.0 and cfg.temperature_rate_hz <= 1.0
        assert scenario.config.run().scenario['duration_s'] >= 3 * 3600
        assert scenario.expected_results()['gyro_id'] == cfg.gyro_id
