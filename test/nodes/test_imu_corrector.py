"""imu_corrector over DDS.

imu_corrector: pulse counts become K·Δn/Δt − bias with the documented variance, and a new
hand-off file is picked up while running.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gyro_calib.errors import StreamError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import (
    Calibration,
    HandoffError,
    Provenance,
    method_calibration,
    write_calibration,
)
from gyro_calib.imu_conversion import (
    UNKNOWN_AXIS_VARIANCE_RAD2_S2,
    ImuAngularVelocity,
    PulseCalibration,
    PulseRateConverter,
    angular_velocity_from_pulses,
    pulse_calibration,
)
from gyro_calib.registry import handoff_schema
from gyro_calib.units import RAD_PER_ARCSEC

from .dds_harness import NodeProcess, launch, spin_watched

K_RAD = 0.84279066 * RAD_PER_ARCSEC
T0_NS = 1_795_426_200_000_000_000


def _handoff(k_rad: float = K_RAD, bias_rad_s: float | None = 7.3e-6,
             arw: float | None = 2.9e-7, with_theta: bool = True) -> Calibration:
    """A hand-off file's content: RBRLG values (and the noise method's ARW)."""
    prov = Provenance('test', T0_NS - 600 * 10**9, T0_NS - 10**9)
    values = dict(k_tilde_rad_per_pulse=k_rad / math.cos(646.75 * RAD_PER_ARCSEC),
                  k_tilde_rad_per_pulse_std=5e-14, window_pairs=3, stations=4)
    if with_theta:
        values.update(scale_factor_rad_per_pulse=k_rad, scale_factor_rad_per_pulse_std=6e-14,
                      fix_error_angle_rad=646.75 * RAD_PER_ARCSEC, fix_error_angle_rad_std=2e-6)
    if bias_rad_s is not None:
        values.update(bias_rad_s=bias_rad_s, bias_rad_s_std=3e-9)
    cal = method_calibration('rbrlg', values, prov)
    if arw is not None:
        noise = method_calibration('noise', {'angle_random_walk_rad_per_sqrt_s': arw,
                                             'angle_random_walk_rad_per_sqrt_s_std': 1e-8}, prov)
        cal = noise.merged_into(cal, handoff_schema())
    return cal


def _calibration(k_rad: float = K_RAD, bias_rad_s: float = 7.3e-6,
                 arw: float | None = 2.9e-7) -> PulseCalibration:
    return pulse_calibration(_handoff(k_rad, bias_rad_s, arw))


def _expected_variance(cal: PulseCalibration, pulses: float, dt_s: float) -> float:
    k, u_k = cal.scale_factor_rad_per_pulse, cal.scale_factor_std
    arw = cal.angle_random_walk_rad_per_sqrt_s
    return (arw**2 / dt_s + k**2 / (6 * dt_s**2) + (pulses / dt_s * u_k) ** 2
            + cal.bias_std**2)


@pytest.mark.parametrize('arw', [2.9e-7, None])
@pytest.mark.parametrize('pulses, dt_ns', [(412.0, 1_000_000), (-3201.0, 8_000_000),
                                           (0.0, 250_000)])
def test_rate_is_k_times_count_rate_minus_bias_with_documented_variance(
        pulses: float, dt_ns: int, arw: float | None) -> None:
    cal = _calibration(arw=arw)
    out = angular_velocity_from_pulses(T0_NS, 1e8, T0_NS + dt_ns, 1e8 + pulses, cal)
    dt_s = dt_ns / 1e9
    assert out.stamp_ns == T0_NS + dt_ns
    assert out.angular_velocity_rad_s[:2] == (0.0, 0.0)
    assert out.angular_velocity_rad_s[2] == pytest.approx(
        K_RAD * pulses / dt_s - cal.bias_rad_s, rel=1e-12, abs=1e-18)
    cov = np.array(out.covariance_rad2_s2).reshape(3, 3)
    assert cov[2, 2] == pytest.approx(_expected_variance(cal, pulses, dt_s), rel=1e-12)
    assert cov[0, 0] == cov[1, 1] == UNKNOWN_AXIS_VARIANCE_RAD2_S2
    assert np.count_nonzero(cov - np.diag(np.diag(cov))) == 0


def test_quantisation_variance_matches_uniform_rounding_at_both_ends() -> None:
    rng = np.random.default_rng(145)
    true_angle_pulses = rng.uniform(0, 1e6, size=(2, 200_000))
    rounded = np.round(true_angle_pulses)
    error = (rounded[1] - rounded[0]) - (true_angle_pulses[1] - true_angle_pulses[0])
    assert np.var(error) == pytest.approx(1 / 6, rel=0.02)


def test_conversion_without_scale_factor_is_refused_naming_the_key() -> None:
    k_tilde_only = _handoff(with_theta=False)
    with pytest.raises(HandoffError, match='no scale_factor_rad_per_pulse .*use_k_tilde'):
        pulse_calibration(k_tilde_only)
    with_k_tilde = pulse_calibration(k_tilde_only, use_k_tilde=True)
    assert with_k_tilde.scale_factor_key == 'k_tilde_rad_per_pulse'
    assert with_k_tilde.scale_factor_rad_per_pulse == k_tilde_only.get('k_tilde_rad_per_pulse')
    rbrlg = {k: v for k, v in k_tilde_only.values.items() if not k.startswith('k_tilde')}
    nothing = dataclasses.replace(k_tilde_only, values=rbrlg)
    with pytest.raises(HandoffError, match='no k_tilde_rad_per_pulse .*told to use K̃'):
        pulse_calibration(nothing, use_k_tilde=True)


def test_file_without_bias_converts_without_bias_and_says_so() -> None:
    cal = pulse_calibration(_handoff(bias_rad_s=None))
    assert not cal.bias_known and cal.bias_rad_s == 0.0
    out = angular_velocity_from_pulses(T0_NS, 0.0, T0_NS + 1_000_000, 412.0, cal)
    assert out.angular_velocity_rad_s[2] == pytest.approx(K_RAD * 412e3, rel=1e-12)


def test_streaming_converter_equals_pairwise_function_and_skips_bad_samples() -> None:
    cal = _calibration()
    stream: list[tuple[int, float]] = [
        (T0_NS, 10.0), (T0_NS + 1_000_000, 422.0), (T0_NS + 2_000_000, math.nan),
        (T0_NS + 3_000_000, 1246.0), (T0_NS + 3_000_000, 1246.0),  # duplicate stamp
        (T0_NS + 4_000_000, 1658.0)]
    converter = PulseRateConverter(cal)
    outs = [converter.add(t, n) for t, n in stream]
    assert outs[0] is None
    assert isinstance(outs[2], Rejection) and 'not finite' in outs[2].reason
    assert isinstance(outs[4], Rejection) and 'not after the previous' in outs[4].reason
    assert outs[1] == angular_velocity_from_pulses(*stream[0], *stream[1], cal)
    assert outs[3] == angular_velocity_from_pulses(*stream[1], *stream[3], cal)  # across NaN
    assert outs[5] == angular_velocity_from_pulses(*stream[4], *stream[5], cal)
    with pytest.raises(StreamError, match='stamps must increase'):
        angular_velocity_from_pulses(*stream[4], *stream[3], cal)


def test_streaming_converter_follows_a_source_whose_stamps_jumped_back() -> None:
    converter = PulseRateConverter(_calibration())
    converter.add(T0_NS + 10**9, 5e5)
    assert isinstance(converter.add(T0_NS, 0.0), Rejection)  # restarted source
    out = converter.add(T0_NS + 1_000_000, 412.0)
    assert isinstance(out, ImuAngularVelocity)
    assert out.angular_velocity_rad_s[2] == pytest.approx(K_RAD * 412e3 - 7.3e-6, rel=1e-12)


# ---------------------------------------------------------------------------- over DDS


class PulseBench:
    """Publishes /gyro/pulses and collects /gyro/imu in this test process."""

    def __init__(self, pulses_per_sample: float, dt_ns: int) -> None:
        import rclpy
        from sensor_msgs.msg import Imu, JointState

        from gyro_calib import topics
        from gyro_calib.nodes.imu_corrector_node import GYRO_IMU
        from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor

        self._rclpy, self._joint_state = rclpy, JointState
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('test_pulse_bench', context=self.context)
        self.pub = self.node.create_publisher(JointState, topics.GYRO_PULSES, SENSOR_QOS)
        self.imu: list[Any] = []
        self.node.create_subscription(Imu, GYRO_IMU, self.imu.append, SENSOR_QOS)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)
        self.pulses_per_sample, self.dt_ns = pulses_per_sample, dt_ns
        self.i = 0

    def publish(self, n: int) -> None:
        from gyro_calib.nodes.ros_io import ns_to_stamp, publish_paced

        for _ in range(n):
            msg = self._joint_state(name=['gyro'],
                                    position=[1e8 + self.i * self.pulses_per_sample])
            ns_to_stamp(T0_NS + self.i * self.dt_ns, msg.header.stamp)
            publish_paced(self.pub, msg)
            self.i += 1
            spin_watched(self.executor, timeout_sec=0.002)  # ~ 300 samples/s of wall time

    def spin_until(self, done: Any, timeout_s: float, *, publishing: bool = False) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if publishing:
                self.publish(10)
            spin_watched(self.executor, timeout_sec=0.05)
            if done():
                return True
        return False

    def stamps(self) -> list[int]:
        """Header stamps of the Imu messages received, int ns."""
        return [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in self.imu]

    def close(self) -> None:
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)


@pytest.fixture
def bench() -> Iterator[PulseBench]:
    b = PulseBench(pulses_per_sample=412.0, dt_ns=1_000_000)  # 412 000 pulses/s at 1 kHz
    yield b
    b.close()


@pytest.fixture
def corrector(tmp_path: Path) -> Iterator[tuple[NodeProcess, Path]]:
    path = tmp_path / 'gyro.yaml'  # written by the test once the node runs
    node = launch('imu_corrector', {'calibration_file': str(path), 'frame_id': 'rlg_z'})
    yield node, path
    node.stop()


def _check(msgs: list[Any], cal: PulseCalibration) -> None:
    k, rate_pulses_s, dt_s = cal.scale_factor_rad_per_pulse, 412_000.0, 1e-3
    expected = k * rate_pulses_s - cal.bias_rad_s
    variance = _expected_variance(cal, 412.0, dt_s)
    for m in msgs:
        assert abs(m.angular_velocity.z / expected - 1) < 1e-9
        assert (m.angular_velocity.x, m.angular_velocity.y) == (0.0, 0.0)
        assert m.header.frame_id == 'rlg_z'
        cov = list(m.angular_velocity_covariance)
        assert cov[8] == pytest.approx(variance, rel=1e-9)
        assert cov[0] == cov[4] == UNKNOWN_AXIS_VARIANCE_RAD2_S2
        assert cov[1:4] + cov[5:8] == [0.0] * 6
        assert m.orientation_covariance[0] == -1.0
        assert m.linear_acceleration_covariance[0] == -1.0


def test_node_publishes_calibrated_imu_and_follows_a_rewritten_file(
        bench: PulseBench, corrector: tuple[NodeProcess, Path]) -> None:
    node, path = corrector
    assert bench.spin_until(lambda: bench.pub.get_subscription_count() > 0
                            and 'cannot read calibration file' in node.log(), 60), node.log()
    bench.publish(50)  # no file yet: nothing may come out
    bench.spin_until(lambda: False, 1.0)
    assert bench.imu == [], node.log()

    first = _calibration()
    write_calibration(path, _handoff())
    assert bench.spin_until(lambda: len(bench.imu) > 0, 10, publishing=True), node.log()
    bench.publish(300)
    last_ns = T0_NS + (bench.i - 1) * 1_000_000
    assert bench.spin_until(lambda: bench.stamps()[-1] == last_ns, 30), node.log()
    # one Imu per sample after the first, stamped with the later sample's stamp, none lost
    assert bench.stamps() == list(range(bench.stamps()[0], last_ns + 1, 1_000_000))
    assert len(bench.imu) > 300
    _check(bench.imu, first)

    second = _calibration(k_rad=K_RAD * (1 + 2e-4), bias_rad_s=-4.1e-6, arw=None)
    n_before = len(bench.imu)
    # picked up within reload_period_s (1 s) + delivery
    write_calibration(path, _handoff(k_rad=K_RAD * (1 + 2e-4), bias_rad_s=-4.1e-6, arw=None))
    assert bench.spin_until(lambda: abs(bench.imu[-1].angular_velocity.z / (
        K_RAD * (1 + 2e-4) * 412e3 + 4.1e-6) - 1) < 1e-9, 10, publishing=True), node.log()
    switch = next(i for i in range(n_before, len(bench.imu))
                  if bench.imu[i].angular_velocity.z != bench.imu[n_before - 1].angular_velocity.z)
    _check(bench.imu[:switch], first)
    _check(bench.imu[switch:], second)
    assert f'K = {K_RAD * (1 + 2e-4)!r}' in node.log()
    assert 'no angle_random_walk_rad_per_sqrt_s' in node.log()

    path.write_text('format_version: 2\ngyro: {bias_rad_s: [\n')  # a bad file: keep `second`
    assert bench.spin_until(lambda: 'Keeping the calibration in use' in node.log(), 10,
                            publishing=True), node.log()
    bench.publish(20)
    last_ns = T0_NS + (bench.i - 1) * 1_000_000
    assert bench.spin_until(lambda: bench.stamps()[-1] == last_ns, 10), node.log()
    _check(bench.imu[switch:], second)
    assert f'calibration file {path} is not valid YAML' in node.log()


# ------------------------------------------------------ thermal compensation (METHODS §D)


def _thermal_model(gyro_id: str = 'T-1', k_rad: float = K_RAD, slope_deg_h_per_c: float = 0.02,
                   terms: tuple[str, ...] = ('H',)) -> Any:
    """A hand-made model: bias = 0.3 °/h + slope·(H − 0 °C), calibrated −10…10 °C ± 2 °C."""
    from gyro_calib.thermal.model import ThermalBiasModel
    from gyro_calib.thermal.terms import VariableScaling

    deg_h = math.pi / 180 / 3600
    coef = (0.3 * deg_h,) + tuple(slope_deg_h_per_c * 10 * deg_h for _ in terms)
    p = len(coef)
    cov = tuple(tuple((1e-3 * deg_h) ** 2 if i == j else 0.0 for j in range(p)) for i in range(p))
    return ThermalBiasModel(
        gyro_id=gyro_id, terms=terms, coefficients_rad_s=coef, covariance_rad2_s2=cov,
        scaling=VariableScaling({'H': 0.0, 'Hdot': 0.0, 'dTab': 0.0, 'dTcs': 0.0},
                                {'H': 10.0, 'Hdot': 1e-3, 'dTab': 1.0, 'dTcs': 1.0}),
        h_range_c=(-10.0, 10.0), hdot_range_c_s=(-1e-3, 1e-3), extrapolation_margin_c=2.0,
        hdot_margin_fraction=0.5, scale_factor_rad_per_pulse=k_rad, latitude_deg=34.26,
        sense_axis_elevation_deg=90.0, sense_axis_azimuth_deg=0.0,
        earth_rate_along_axis_rad_s=15.041 * deg_h * math.sin(math.radians(34.26)),
        averaging_interval_s=1.0, hdot_window_s=60.0, sensors=('cavity_a', 'cavity_b', 'shell'),
        residual_std_rad_s=1e-8, fit_block_s=10.0, calibration_style='continuous',
        covariance_kind='allan', n_used=100, dof=90)


def _thermal_handoff(model: Any, *, file_gyro_id: str | None = None,
                     rbrlg: Calibration | None = None) -> Calibration:
    prov = Provenance('test', T0_NS - 600 * 10**9, T0_NS - 10**9)
    cal = method_calibration('thermal', {'thermal_model': model.to_dict(),
                                         'thermal_residual_std_rad_s': 1e-8}, prov,
                             gyro_id=model.gyro_id if file_gyro_id is None else file_gyro_id)
    return cal if rbrlg is None else cal.merged_into(rbrlg, handoff_schema())


def _feed(converter: PulseRateConverter, start_s: int, stop_s: int, celsius: float,
          pulses_per_s: float = 3.7, sent: list[Any] | None = None) -> list[Any]:
    """Temperatures at 1 Hz and pulses at 2 Hz; the outputs released meanwhile, in order.

    All three sensors read within ±0.01 °C of ``celsius`` (a real sensor's last digit
    moves; one reading exactly the same for long is waited on, test_thermal_live).

    The messages go to ``sent`` too: ('p', t, count) and ('t', t, °C, sensor).
    """
    outs: list[Any] = []
    for i in range(2 * start_s, 2 * stop_s):
        t = T0_NS + i * 500_000_000
        if i % 2 == 0:
            for j, sensor in enumerate(('cavity_a', 'cavity_b', 'shell')):
                c = celsius + 0.01 * ((i // 2 + j) % 3 - 1)
                outs += converter.add_temperature(t, c, sensor)
                if sent is not None:
                    sent.append(('t', t, c, sensor))
        count = float(math.floor(i * pulses_per_s / 2))
        outs += converter.add_pulse(t, count)
        if sent is not None:
            sent.append(('p', t, count))
    return outs


def _offline_rates(model: Any, cal: PulseCalibration, sent: list[Any]) -> dict[int, Any]:
    """What gyro-calib compensate --out gives for the same messages, by stamp."""
    from gyro_calib.thermal.compensate import CompensatedPair, offline_pairs

    p = [m for m in sent if m[0] == 'p']
    t = [m for m in sent if m[0] == 't']
    pairs = offline_pairs(model, [m[1] for m in p], [m[2] for m in p], [m[1] for m in t],
                          [m[2] for m in t], [m[3] for m in t])
    return {o.t1_ns: angular_velocity_from_pulses(
        o.t0_ns, o.count0, o.t1_ns, o.count1,
        dataclasses.replace(cal, bias_rad_s=o.bias_rad_s, bias_std=o.bias_std))
        for o in pairs if isinstance(o, CompensatedPair)}


def test_thermal_model_file_alone_gives_k_and_the_bias_at_the_current_temperature() -> None:
    model = _thermal_model()
    cal = pulse_calibration(_thermal_handoff(model), gyro_id='T-1')
    assert cal.scale_factor_key == 'thermal_model'
    assert cal.scale_factor_rad_per_pulse == K_RAD and cal.scale_factor_std == 0.0
    assert cal.thermal_model == model
    converter = PulseRateConverter(cal)
    sent: list[Any] = []
    outs = _feed(converter, 0, 90, 5.0, sent=sent)
    rates = [o for o in outs if isinstance(o, ImuAngularVelocity)]
    offline = _offline_rates(model, cal, sent)
    assert rates == [offline[r.stamp_ns] for r in rates]  # the offline numbers, bit for bit
    # only the first half Ḣ window (no rate offline either) and the held tail give none
    assert len(rates) >= 2 * 90 - 2 * 31 - 2 * 6
    bias, bias_std = model.bias_rad_s(5.0)
    for r in rates:
        assert r.covariance_rad2_s2[8] == pytest.approx(
            K_RAD**2 / (6 * 0.25) + bias_std[0] ** 2, rel=1e-6)
        i = (r.stamp_ns - T0_NS) // 500_000_000
        dn = math.floor(i * 3.7 / 2) - math.floor((i - 1) * 3.7 / 2)
        used = K_RAD * dn / 0.5 - r.angular_velocity_rad_s[2]
        # the model at H = 5 °C ± 0.01 °C (0.02 °/h per °C)
        assert abs(used - bias[0]) <= 0.02 * 0.011 * math.pi / 180 / 3600


def test_thermal_bias_is_refused_without_temperatures_outside_the_range_and_when_stale() -> None:
    model = _thermal_model()
    converter = PulseRateConverter(pulse_calibration(_thermal_handoff(model)),
                                   thermal_max_age_s=5.0)
    silent = []
    for i in range(40):  # 20 s of pulses, no temperature yet: held (the topic may be late)
        silent += converter.add_pulse(T0_NS - 30 * 10**9 + i * 500_000_000, 2.0 * i)
    assert silent == [] and converter.held == 39
    inside = _feed(converter, 0, 60, 9.0)  # temperatures from 30 s later: none for those
    refused = [o for o in inside if o.stamp_ns < T0_NS - 10 * 10**9]
    assert len(refused) == 39 and all(isinstance(o, Rejection) for o in refused)
    assert 'thermal_max_age_s = 5 s' in refused[0].reason
    assert isinstance(inside[-1], ImuAngularVelocity)
    outside = _feed(converter, 60, 100, 13.5)  # 10 °C + 2 °C margin exceeded
    assert isinstance(outside[-1], Rejection)
    assert 'outside the calibrated range' in outside[-1].reason
    assert 'H 13.5' in outside[-1].reason
    back = _feed(converter, 100, 160, -11.0)  # within the margin
    assert isinstance(back[-1], ImuAngularVelocity)
    n_held = converter.held
    stale = [o for i in range(40)  # no temperature after 160 s: nothing more comes out
             for o in converter.add_pulse(T0_NS + 180 * 10**9 + i * 500_000_000, 1e6 + i)]
    assert not [o for o in stale if isinstance(o, ImuAngularVelocity)]
    assert converter.held >= n_held + 40 - len(stale)


def test_thermal_model_of_another_gyro_is_refused() -> None:
    from gyro_calib.thermal.errors import ModelMismatchError

    model = _thermal_model(gyro_id='T-1')
    with pytest.raises(ModelMismatchError, match="fitted on gyro 'T-1'.*from gyro 'T-2'"):
        pulse_calibration(_thermal_handoff(model), gyro_id='T-2')
    with pytest.raises(ModelMismatchError, match='the file is inconsistent'):
        pulse_calibration(_thermal_handoff(model, file_gyro_id='T-9'))


def test_thermal_model_needs_the_k_it_was_fitted_with_and_replaces_the_constant_bias() -> None:
    model = _thermal_model(k_rad=K_RAD)
    same = pulse_calibration(_thermal_handoff(model, rbrlg=_handoff()))
    assert same.scale_factor_key == 'scale_factor_rad_per_pulse'
    assert same.scale_factor_std == 6e-14 and same.thermal_model is not None
    assert same.bias_rad_s == 0.0  # the file's bias_rad_s is not used: the model holds it
    other = _thermal_model(k_rad=K_RAD * (1 + 5e-4))
    with pytest.raises(HandoffError, match='differs from the .* thermal_model was fitted with'):
        pulse_calibration(_thermal_handoff(other, rbrlg=_handoff()))


def test_a_k_tilde_beside_a_model_of_another_k_is_refused() -> None:
    """A K̃ beside a model of another K is refused.

    Issue 17 item 6: K̃ = 4.086e-06 beside a model fitted with K = 1.115e-05 was taken
    without a word (the model's K was used); a file mixing two scale factors is refused.
    """
    model = _thermal_model(k_rad=1.115e-05).to_dict()
    mixed = Calibration({'k_tilde_rad_per_pulse': 4.086e-6, 'k_tilde_rad_per_pulse_std': 1e-13,
                         'window_pairs': 3, 'thermal_model': model},
                        {'rbrlg': Provenance('bench', 0, 1),
                         'thermal': Provenance('chamber', 0, 1)})
    with pytest.raises(HandoffError, match=r'k_tilde_rad_per_pulse = 4\.086e-06 rad/pulse '
                       r'differs from the 1\.115e-05 rad/pulse its thermal_model'):
        pulse_calibration(mixed)


def test_converter_without_thermal_model_ignores_temperatures() -> None:
    converter = PulseRateConverter(_calibration())
    converter.add(T0_NS, 0.0)
    converter.add_temperature(T0_NS, 99.0, 'cavity_a')
    out = converter.add(T0_NS + 1_000_000, 412.0)
    assert isinstance(out, ImuAngularVelocity)
    assert out.angular_velocity_rad_s[2] == pytest.approx(K_RAD * 412e3 - 7.3e-6, rel=1e-12)
