"""The thermal method over DDS.

The thermal method over DDS: a live chamber run and a replayed bag calibrate exactly as
offline; imu_corrector subtracts the thermal model's bias live and refuses to extrapolate.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import SampleBatch, bag_info
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.handoff import load_calibration, write_calibration
from gyro_calib.registry import JOINT_STATE, TEMPERATURE
from gyro_calib.session import CalibrationOptions
from gyro_calib.thermal.compensate import CompensatedPair, offline_pairs
from gyro_calib.thermal.session import ThermalSession
from sim_nodes.thermal.scenarios import ChamberRunConfig, ThermalRecording

from .dds_harness import NodeProcess, bench_node, launch, spin_watched

BAGS = Path(__file__).resolve().parents[2] / 'bags'
RAMP = ChamberRunConfig(programme='continuous_ramp', gyro_id='B-1', seed=3, low_c=-10.0,
                        high_c=10.0, rate_c_per_min=1.0, dwell_s=600.0)
"""70 min of chamber time, 21 004 messages: B-1's rate-sensitive law over −10…10 °C."""


def recording_batch(rec: ThermalRecording) -> SampleBatch:
    """A whole recording as one batch of the two contract topics."""
    names = tuple(dict.fromkeys(rec.temperature_frame_id.tolist()))
    codes = np.array([names.index(f) for f in rec.temperature_frame_id.tolist()], np.int32)
    pulses = TopicColumns(topics.GYRO_PULSES, JOINT_STATE, rec.pulse_t_ns, rec.pulse_t_ns,
                          FrameIds(np.zeros(len(rec.pulse_t_ns), np.int32), ('gyro',)),
                          {'position': rec.pulse_counts,
                           'velocity': np.full(len(rec.pulse_t_ns), np.nan)})
    temps = TopicColumns(topics.GYRO_TEMPERATURE, TEMPERATURE, rec.temperature_t_ns,
                         rec.temperature_t_ns, FrameIds(codes, names),
                         {'temperature_degc': rec.temperature_c,
                          'variance_degc2': rec.temperature_variance_c2})
    return SampleBatch({topics.GYRO_PULSES: pulses, topics.GYRO_TEMPERATURE: temps},
                       len(rec.pulse_t_ns) + len(rec.temperature_t_ns),
                       int(rec.pulse_t_ns[-1]))


def offline_session(rec: ThermalRecording, **options: Any) -> ThermalSession:
    session = ThermalSession(CalibrationOptions(**options))
    session.feed(recording_batch(rec))
    session.process(flush=True)
    return session


def expected_diagnostics(session: ThermalSession) -> dict[str, str]:
    """The numbers the node's /diagnostics must carry (repr strings, as MethodNode writes)."""
    out = {'rejected': str(len(session.rejections()))}
    for key, est in session.results().items():
        out[key] = repr(float(est.value))
        out[key + '_std'] = repr(float(est.std_uncertainty))
        out[key + '_n'] = str(est.n_used)
    return out


class ThermalListener:
    """Listens to the thermal node's outputs in this test process.

    /diagnostics (status 'gyro_calib: thermal') and /gyro/imu, in this test process;
    publishes /gyro/pulses and /gyro/temperature when asked.
    """

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import Imu, JointState, Temperature

        from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('thermal_test_listener', context=self.context)
        self.diagnostics: dict[str, str] = {}
        self.imu: list[Any] = []
        self.node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diag, 10)
        self.node.create_subscription(Imu, '/gyro/imu', self.imu.append, SENSOR_QOS)
        self.pulse_pub = self.node.create_publisher(JointState, topics.GYRO_PULSES, SENSOR_QOS)
        self.temp_pub = self.node.create_publisher(Temperature, topics.GYRO_TEMPERATURE,
                                                   SENSOR_QOS)
        self._joint_state, self._temperature = JointState, Temperature
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)

    def _on_diag(self, msg: Any) -> None:
        for status in msg.status:
            if status.name == 'gyro_calib: thermal':
                self.diagnostics = {kv.key: kv.value for kv in status.values}

    def spin_until(self, done: Any, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            spin_watched(self.executor, timeout_sec=0.05)
            if done():
                return True
        return False

    def publish(self, t_ns: int, *, count: float | None = None,
                temperatures: dict[str, float] | None = None) -> None:
        from gyro_calib.nodes.ros_io import ns_to_stamp, publish_paced

        if count is not None:
            msg = self._joint_state(name=['gyro'], position=[float(count)])
            ns_to_stamp(t_ns, msg.header.stamp)
            publish_paced(self.pulse_pub, msg)
        for sensor, celsius in (temperatures or {}).items():
            temp = self._temperature(temperature=float(celsius), variance=1e-4)
            ns_to_stamp(t_ns, temp.header.stamp)
            temp.header.frame_id = sensor
            publish_paced(self.temp_pub, temp)
        spin_watched(self.executor, timeout_sec=0.0)

    def close(self) -> None:
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)


@pytest.fixture
def thermal_listener() -> Any:
    lst = ThermalListener()
    yield lst
    lst.close()


def _wait_for_numbers(lst: ThermalListener, expected: dict[str, str], nodes: list[NodeProcess],
                      timeout_s: float) -> None:
    """Wait until the node's diagnostics carry ``expected``.

    Until the node's diagnostics carry ``expected`` (the calibration node, nodes[0], must
    stay up meanwhile).
    """
    done = lst.spin_until(lambda: all(lst.diagnostics.get(k) == v for k, v in expected.items())
                          or nodes[0].proc.poll() is not None, timeout_s)
    done = done and nodes[0].proc.poll() is None
    logs = '\n'.join(n.log() for n in nodes)
    diff = {k: (lst.diagnostics.get(k), v) for k, v in expected.items()
            if lst.diagnostics.get(k) != v}
    assert done, f'diagnostics differ from offline: {diff}\n{logs}'


def test_live_chamber_run_calibrates_exactly_as_offline(
        thermal_listener: ThermalListener, nodes: list[NodeProcess], tmp_path: Path) -> None:
    rec = RAMP.recording()
    truth = rec.scenario['truth']
    offline = offline_session(rec, scale_factor_rad_per_pulse=truth['scale_factor_rad_per_pulse'],
                              latitude_deg=truth['latitude_deg'], gyro_id='B-1')
    expected = expected_diagnostics(offline)
    assert 'thermal_coefficient_const_rad_s' in expected
    out = tmp_path / 'gyro.yaml'
    nodes.append(launch('thermal_calibration_node', {
        'scale_factor_rad_per_pulse': truth['scale_factor_rad_per_pulse'],
        'latitude_deg': truth['latitude_deg'], 'gyro_id': 'B-1', 'output_file': str(out),
        'fit_after_idle_s': 2.0}))
    params = {f.name: getattr(RAMP, f.name) for f in dataclasses.fields(RAMP)}
    sim = launch('thermal_chamber_sim', {**params, 'real_time_factor': 0.0})
    nodes.append(sim)
    _wait_for_numbers(thermal_listener, expected, nodes, 110.0)
    assert sim.proc.wait(timeout=30) == 0, sim.log()
    assert 'run finished: 21004 messages published' in sim.log()
    assert thermal_listener.spin_until(out.exists, 10.0), nodes[0].log()
    written = load_calibration(out)
    assert written.gyro_id == 'B-1'
    assert written.get('thermal_model') == offline.handoff_values()['thermal_model']


def test_replayed_bag_gives_exactly_the_offline_model_and_rejections(
        thermal_listener: ThermalListener, nodes: list[NodeProcess]) -> None:
    bag = BAGS / 'thermal_fault_stuck_sensor'
    bench = bag_info(bag).scenario['bench']
    session = calibrate_bags([bag], methods=['thermal']).sessions['thermal']
    expected = expected_diagnostics(session)  # type: ignore[arg-type]
    assert int(expected['rejected']) >= 2
    nodes.append(launch('thermal_calibration_node', {
        'scale_factor_rad_per_pulse': bench['scale_factor_rad_per_pulse'],
        'latitude_deg': bench['latitude_deg'], 'gyro_id': bench['gyro_id'],
        'fit_after_idle_s': 2.0}))
    player = launch('bag_player', {'bag': str(bag), 'rate': 0.0})
    nodes.append(player)
    _wait_for_numbers(thermal_listener, expected, nodes, 110.0)
    last = session.rejections()[-1]
    assert last.reason in thermal_listener.diagnostics['last_rejection']


def _model_file(tmp_path: Path, rec: ThermalRecording, gyro_id: str) -> tuple[Path, Any]:
    truth = rec.scenario['truth']
    session = offline_session(rec, scale_factor_rad_per_pulse=truth['scale_factor_rad_per_pulse'],
                              latitude_deg=truth['latitude_deg'], gyro_id=gyro_id)
    record = session.handoff('test')
    assert record is not None
    path = tmp_path / f'{gyro_id}.yaml'
    write_calibration(path, record)
    return path, session.report.model  # type: ignore[union-attr]


def test_imu_corrector_subtracts_the_thermal_bias_live_and_refuses_out_of_range(
        thermal_listener: ThermalListener, nodes: list[NodeProcess], tmp_path: Path) -> None:
    lst = thermal_listener
    rec = RAMP.recording()
    good, model = _model_file(tmp_path, rec, 'B-1')
    other, _ = _model_file(tmp_path, rec, 'B-2')
    path = tmp_path / 'gyro.yaml'
    path.write_bytes(other.read_bytes())  # first a model of another gyro: refused
    node = launch('imu_corrector', {'calibration_file': str(path), 'gyro_id': 'B-1'})
    nodes.append(node)
    assert lst.spin_until(lambda: lst.pulse_pub.get_subscription_count() > 0
                          and "fitted on gyro 'B-2'" in node.log(), 60), node.log()
    path.write_bytes(good.read_bytes())
    assert lst.spin_until(lambda: 'thermal model of gyro B-1' in node.log(), 20), node.log()

    # 15 min of the chamber run (from its 20th minute: on the ramp, Ḣ ≠ 0); the two topics
    # reach the node interleaved as DDS delivers them: each pulse must get exactly what
    # the offline compensation (gyro-calib compensate --out) gives it, not the bias of
    # whatever temperature arrived last (issue 24 §5b)
    t0 = int(rec.pulse_t_ns[0]) + 1200 * 10**9
    t1 = t0 + 900 * 10**9
    p_sel = (rec.pulse_t_ns >= t0) & (rec.pulse_t_ns < t1)
    t_sel = (rec.temperature_t_ns >= t0) & (rec.temperature_t_ns < t1)
    temps = list(zip(rec.temperature_t_ns[t_sel].tolist(), rec.temperature_c[t_sel].tolist(),
                     rec.temperature_frame_id[t_sel].tolist()))
    pulses = list(zip(rec.pulse_t_ns[p_sel].tolist(), rec.pulse_counts[p_sel].tolist()))
    offline = {o.t1_ns: o for o in offline_pairs(
        model, [t for t, _ in pulses], [c for _, c in pulses], [t for t, _, _ in temps],
        [c for _, c, _ in temps], [f for _, _, f in temps]) if isinstance(o, CompensatedPair)}
    by_stamp: dict[int, list[Any]] = {}
    for t, c, f in temps:
        by_stamp.setdefault(t, []).append((f, c))
    counts = dict(pulses)
    for t in sorted(set(counts) | set(by_stamp)):
        lst.publish(t, count=counts.get(t), temperatures=dict(by_stamp.get(t, [])))
    # the last seconds stay held until later temperatures decide them
    settled = [t for t in offline if t <= pulses[-1][0] - 15 * 10**9]
    assert lst.spin_until(lambda: any(_stamp(m) >= settled[-1] for m in lst.imu), 60), \
        node.log()
    lst.spin_until(lambda: False, 1.0)
    got = {_stamp(m): m.angular_velocity.z for m in lst.imu}
    assert set(settled) <= set(got), (len(set(settled) - set(got)), node.log())
    k = model.scale_factor_rad_per_pulse
    for t, z in got.items():
        o = offline[t]
        raw = k * (o.count1 - o.count0) / ((o.t1_ns - o.t0_ns) / 1e9)
        assert z == raw - o.bias_rad_s, (t, z, raw - o.bias_rad_s, node.log())
    assert len(lst.imu) > 0.8 * len(pulses), node.log()
    assert 'outside the calibrated range' not in node.log()

    # the chamber overshoots to 40 °C: beyond the calibrated range → nothing is published
    n_before = len(lst.imu)
    t_hot = t1 + 10 * 10**9
    count = float(pulses[-1][1])
    for i in range(240):
        t = t_hot + i * 500_000_000
        count += 2
        hot = {s: 40.0 + 0.01 * ((i // 2 + j) % 3)  # a real sensor's last digit moves
               for j, s in enumerate(('cavity_a', 'cavity_b', 'shell'))} if i % 2 == 0 else None
        lst.publish(t, count=count, temperatures=hot)
    assert lst.spin_until(lambda: 'outside the calibrated range' in node.log(), 20), node.log()
    lst.spin_until(lambda: False, 1.0)
    hot_imu = [m for m in lst.imu[n_before:] if _stamp(m) >= t_hot + 5 * 10**9]
    assert hot_imu == [], node.log()
    assert 'Publishing nothing on /gyro/imu' in node.log()


def _stamp(msg: Any) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def test_thermal_chamber_sim_publishes_its_scenario(nodes: list[NodeProcess]) -> None:
    """/sim/scenario carries the run (recorders merge it into the bag's metadata)."""
    from std_msgs.msg import String

    from gyro_calib.nodes.ros_io import SCENARIO_READER_QOS

    with bench_node('scenario_reader') as (node, executor):
        got: list[str] = []
        node.create_subscription(String, topics.SIM_SCENARIO, lambda m: got.append(m.data),
                                 SCENARIO_READER_QOS)
        sim = launch('thermal_chamber_sim', {'programme': 'validation', 'duration_s': 60.0,
                                             'wait_for_subscribers': False,
                                             'exit_when_done': False, 'real_time_factor': 0.0})
        nodes.append(sim)
        deadline = time.monotonic() + 60
        while not got and time.monotonic() < deadline:
            spin_watched(executor, timeout_sec=0.1)
        assert got, sim.log()
        scenario = yaml.safe_load(got[0])
        assert scenario['name'] == 'thermal_validation_A-1_1'
        assert scenario['bench']['gyro_id'] == 'A-1'
        assert math.isclose(scenario['truth']['latitude_deg'], 34.26)
