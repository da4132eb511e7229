"""The live thermal bias for Autoware's ``gyro_bias_input`` (issue 27 §2).

Specification: :class:`ThermalBiasPublisher` publishes, once per averaging interval, exactly
the bias ``gyro-calib compensate --out`` subtracts for that interval (the offline pairs), and
nothing — with one log line per kind of reason — while the model cannot give the bias (a
temperature outside the calibrated range, temperatures that stopped); the node turns a bias
into geometry_msgs/Vector3Stamped with z along the sense axis.
"""

from __future__ import annotations

from fake_node import FakeNode
from test_thermal_live import T0_NS, in_stamp_order, model_of, recording

from gyro_calib.thermal.compensate import CompensatedPair
from gyro_calib.thermal.live_bias import LiveBias, ThermalBiasPublisher

TOPIC = '/gyro/thermal_bias'


def feed(pub: ThermalBiasPublisher, msgs: list[tuple[str, int, float, str]]) -> None:
    for kind, t, v, sensor in msgs:
        if kind == 'p':
            pub.add_pulse(t, v)
        else:
            pub.add_temperature(t, v, sensor)


def test_one_bias_per_interval_equal_to_the_offline_compensation() -> None:
    model = model_of(('H', 'Hdot'))
    rec = recording(3, duration_s=120)
    got: list[LiveBias] = []
    node = FakeNode()
    pub = ThermalBiasPublisher(model, node, got.append, topic=TOPIC, max_wait_s=15.0)
    feed(pub, in_stamp_order(rec))
    offline = [o for o in rec.offline(model) if isinstance(o, CompensatedPair)]
    first_of_interval: dict[int, CompensatedPair] = {}
    for o in offline:
        first_of_interval.setdefault((o.t0_ns + (o.t1_ns - o.t0_ns) // 2) // 10**9, o)
    assert len(got) > 60
    expected = [first_of_interval[k] for k in sorted(first_of_interval)][:len(got)]
    assert [(b.stamp_ns, b.bias_rad_s, b.bias_std) for b in got] == [
        (o.t1_ns, o.bias_rad_s, o.bias_std) for o in expected]
    assert len({(b.stamp_ns // 10**9) for b in got}) == len(got)
    # the first intervals lack half the Ḣ window: said once, then once that it resumed
    lines = node.logger.lines
    assert len(lines) == 2 and 'Ḣ' in lines[0] and 'resumed' in lines[1], lines


def test_out_of_range_temperature_publishes_nothing_and_logs_once() -> None:
    model = model_of(('H',))  # calibrated H −10…10 °C ± 2 °C
    rec = recording(4, duration_s=150, h_start=9.0, h_rate_c_s=0.05)  # leaves it at ~60 s
    got: list[LiveBias] = []
    node = FakeNode()
    pub = ThermalBiasPublisher(model, node, got.append, topic=TOPIC, max_wait_s=10.0)
    feed(pub, in_stamp_order(rec))
    # H = 9 °C + 0.05 °C/s·t passes 10 + 2 °C (range + margin) at t = 60 s
    assert all(b.stamp_ns < T0_NS + 62 * 10**9 for b in got)
    assert got and got[-1].stamp_ns > T0_NS + 50 * 10**9
    warned = [line for line in node.logger.lines if 'outside the calibrated range' in line]
    assert len(warned) == 1 and TOPIC in warned[0]


def test_stale_temperatures_publish_nothing_after_they_stop() -> None:
    model = model_of(('H',))
    rec = recording(11, duration_s=200)
    stop = T0_NS + 80 * 10**9
    rec.temps = [m for m in rec.temps if m[0] < stop]
    got: list[LiveBias] = []
    node = FakeNode()
    pub = ThermalBiasPublisher(model, node, got.append, topic=TOPIC, max_wait_s=10.0)
    pub.compensator.max_held = 60
    feed(pub, in_stamp_order(rec))
    assert got and all(b.stamp_ns < stop for b in got)
    stale = [line for line in node.logger.lines if 'thermal_max_age_s' in line]
    assert len(stale) == 1 and 'Publishing nothing on /gyro/thermal_bias' in stale[0]


def test_the_message_carries_the_bias_on_z_with_its_stamp() -> None:
    from gyro_calib.nodes.thermal_bias_node import THERMAL_BIAS, vector3_stamped

    msg = vector3_stamped(LiveBias(T0_NS + 1_500_000_000, 2.5e-6, 1e-8), 'gyro')
    assert THERMAL_BIAS == TOPIC
    assert (msg.vector.x, msg.vector.y, msg.vector.z) == (0.0, 0.0, 2.5e-6)
    assert msg.header.frame_id == 'gyro'
    assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == T0_NS + 1_500_000_000
