"""Live thermal compensation gives the offline numbers, whatever the arrival order.

imu_corrector judged each pulse against the newest temperature that had arrived, so its
numbers depended on how DDS interleaved /gyro/pulses and /gyro/temperature (issue 24
§5b, a flaky DDS test). :class:`OrderedThermalCompensator` holds each pulse sample by its
stamp until the temperatures that decide its bias have arrived:

- any interleaving of the same stamped messages (each topic in its own order, one
  lagging the other by less than ``thermal_max_age_s`` of stamps) gives the same output;
- every pair it releases is the one ``gyro-calib compensate --out`` writes
  (:func:`offline_pairs`), bit for bit, and it gives a rate wherever offline does;
- what it holds is bounded (a silent temperature topic does not make it hoard pulses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.estimate import Rejection
from gyro_calib.thermal.compensate import CompensatedPair, offline_pairs
from gyro_calib.thermal.live import OrderedThermalCompensator
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.terms import VariableScaling
from gyro_calib.units import RAD_PER_ARCSEC

K_RAD = 0.84279066 * RAD_PER_ARCSEC
T0_NS = 1_795_426_200_000_000_000
DEG_H = math.pi / 180 / 3600
SENSORS = ('cavity_a', 'cavity_b', 'shell')


def model_of(terms: tuple[str, ...]) -> ThermalBiasModel:
    """Bias = 0.3 °/h + 0.2 °/h per scaled unit of each term; H calibrated −10…10 ± 2 °C."""
    coef = (0.3 * DEG_H,) + tuple(0.2 * DEG_H for _ in terms)
    p = len(coef)
    cov = tuple(tuple((1e-3 * DEG_H) ** 2 if i == j else 0.0 for j in range(p))
                for i in range(p))
    return ThermalBiasModel(
        gyro_id='T-1', terms=terms, coefficients_rad_s=coef, covariance_rad2_s2=cov,
        scaling=VariableScaling({'H': 0.0, 'Hdot': 0.0, 'dTab': 0.0, 'dTcs': 0.0},
                                {'H': 10.0, 'Hdot': 1e-2, 'dTab': 1.0, 'dTcs': 1.0}),
        h_range_c=(-10.0, 10.0), hdot_range_c_s=(-0.05, 0.05), extrapolation_margin_c=2.0,
        hdot_margin_fraction=0.5, scale_factor_rad_per_pulse=K_RAD, latitude_deg=34.26,
        sense_axis_elevation_deg=90.0, sense_axis_azimuth_deg=0.0,
        earth_rate_along_axis_rad_s=15.041 * DEG_H * math.sin(math.radians(34.26)),
        averaging_interval_s=1.0, hdot_window_s=20.0, sensors=SENSORS,
        residual_std_rad_s=1e-8, fit_block_s=10.0, calibration_style='continuous',
        covariance_kind='allan', n_used=100, dof=90, max_temperature_gap_s=30.0)


@dataclass
class Recording:
    """Stamp-ordered messages of one run: ('p', t, count) and ('t', t, °C, sensor)."""

    pulses: list[tuple[int, float]]
    temps: list[tuple[int, float, str]]

    def offline(self, model: ThermalBiasModel) -> list[CompensatedPair | Rejection]:
        """What gyro-calib compensate --out gives, one outcome per pulse pair."""
        t = [m[0] for m in self.temps]
        out = offline_pairs(model, [p[0] for p in self.pulses], [p[1] for p in self.pulses],
                            t, [m[1] for m in self.temps], [m[2] for m in self.temps])
        return [o for o in out if o is not None]


def recording(seed: int, *, duration_s: int = 150, h_start: float = 4.0,
              h_rate_c_s: float = 0.02, periods_s: tuple[float, ...] = (1.0, 1.0, 2.0),
              pulse_hz: float = 4.0, dropout: tuple[str, float, float] | None = None,
              glitches: bool = False) -> Recording:
    """A short chamber run, in stamp order.

    Cavities and shell around H(t) = h_start + rate·t (noise, 0.01 °C LSB), each on its
    own clock; pulses at ``pulse_hz`` (a NaN count and a repeated stamp with ``glitches``).
    """
    rng = np.random.default_rng(seed)
    offset = {'cavity_a': 0.3, 'cavity_b': -0.3, 'shell': 1.0}
    temps: list[tuple[int, float, str]] = []
    for sensor, period in zip(SENSORS, periods_s):
        phase = rng.uniform(0, period)
        for t_s in np.arange(phase, duration_s, period):
            if dropout and dropout[0] == sensor and dropout[1] <= t_s < dropout[2]:
                continue
            c = h_start + h_rate_c_s * t_s + offset[sensor] + rng.normal(0, 0.02)
            temps.append((T0_NS + int(t_s * 1e9), round(c, 2), sensor))
    temps.sort(key=lambda m: m[0])
    rate = 7.3e-6 / K_RAD + 40.0  # pulses/s: Earth rate + a constant turn
    pulses = []
    count = 1e6
    dt_ns = int(1e9 / pulse_hz)
    t = T0_NS + int(rng.uniform(0, dt_ns))
    while t < T0_NS + duration_s * 10**9:
        count += rate / pulse_hz + rng.normal(0, 1)
        pulses.append((t, float(math.floor(count))))
        t += dt_ns
    if glitches:
        i = len(pulses) // 3
        pulses[i] = (pulses[i][0], math.nan)
        pulses.insert(2 * len(pulses) // 3, pulses[2 * len(pulses) // 3])  # same stamp twice
    return Recording(pulses, temps)


Message = tuple[str, int, float, str]


def interleave(rec: Recording, rng: np.random.Generator, max_lag_s: float) -> list[Message]:
    """A random merge of the two topics.

    Each topic in its own order, arriving up to ``max_lag_s`` (of stamps) late, in bursts.
    """
    def arrivals(stamps: list[int]) -> list[float]:
        delay = 0.0
        out, last = [], -math.inf
        for t in stamps:
            if rng.random() < 0.05:  # the topic stalls or catches up
                delay = float(rng.uniform(0, max_lag_s)) * 1e9
            last = max(last + 1.0, t - T0_NS + delay)  # a topic arrives in its own order
            out.append(last)
        return out

    msgs = [(a, 0, ('p', t, c, '')) for a, (t, c) in zip(
        arrivals([p[0] for p in rec.pulses]), rec.pulses)]
    msgs += [(a, 1, ('t', t, c, s)) for a, (t, c, s) in zip(
        arrivals([m[0] for m in rec.temps]), rec.temps)]
    msgs.sort(key=lambda m: (m[0], rng.random()))
    return [m[2] for m in msgs]


def in_stamp_order(rec: Recording) -> list[Message]:
    msgs = [('p', t, c, '') for t, c in rec.pulses] + [('t', t, c, s) for t, c, s in rec.temps]
    return sorted(msgs, key=lambda m: m[1])


def run(model: ThermalBiasModel, msgs: list[Message], max_wait_s: float = 15.0
        ) -> tuple[list[CompensatedPair | Rejection], OrderedThermalCompensator]:
    comp = OrderedThermalCompensator(model, max_wait_s=max_wait_s)
    out: list[CompensatedPair | Rejection] = []
    for kind, t, v, sensor in msgs:
        out += comp.add_pulse(t, v) if kind == 'p' else comp.add_temperature(t, v, sensor)
    return out, comp


def stamp(o: CompensatedPair | Rejection) -> int:
    """The stamp of the rate (the later sample's) or of the rejected sample."""
    return o.t1_ns if isinstance(o, CompensatedPair) else o.stamp_ns


def key(o: CompensatedPair | Rejection) -> Any:
    """Pairs compared whole; a rejection by its stamp (its words name the cause)."""
    return o if isinstance(o, CompensatedPair) else ('no rate', o.stamp_ns)


def assert_is_offline_prefix(live: list[CompensatedPair | Rejection],
                             offline: list[CompensatedPair | Rejection],
                             every_rate_before_ns: int | None = None) -> None:
    """Every live pair is offline's, bit for bit; none of offline's is missing.

    Up to the last stamp released (the tail is still held), and before
    ``every_rate_before_ns`` when given.
    """
    off = {o.t1_ns: o for o in offline if isinstance(o, CompensatedPair)}
    mine = {o.t1_ns: o for o in live if isinstance(o, CompensatedPair)}
    for t, pair in mine.items():
        assert off.get(t) == pair, f'live {pair} != offline {off.get(t)}'
    if not live:
        return
    upto = max(stamp(o) for o in live)
    if every_rate_before_ns is not None:
        upto = min(upto, every_rate_before_ns - 1)
    missing = sorted(t for t in off if t <= upto and t not in mine)
    assert not missing, f'{len(missing)} offline rate(s) not given live, first {off[missing[0]]}'


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), terms=st.sampled_from([('H',), ('H', 'Hdot'),
                                                          ('H', 'dTcs')]),
       periods=st.sampled_from([(1.0, 1.0, 1.0), (1.0, 2.0, 5.0), (0.5, 3.0, 1.0)]),
       pulse_hz=st.sampled_from([2.0, 5.0]), h_rate=st.sampled_from([0.02, 0.06]),
       lag_s=st.floats(0.0, 12.0))
def test_any_interleaving_gives_the_offline_pairs(seed: int, terms: tuple[str, ...],
                                                  periods: tuple[float, ...], pulse_hz: float,
                                                  h_rate: float, lag_s: float) -> None:
    model = model_of(terms)
    # H from 6 °C upwards: with 0.06 °C/s it leaves the calibrated range (12 °C) mid-run
    rec = recording(seed, periods_s=periods, pulse_hz=pulse_hz, h_start=6.0,
                    h_rate_c_s=h_rate, glitches=seed % 2 == 0,
                    dropout=('cavity_b', 60.0, 70.0) if seed % 3 == 0 else None)
    offline = rec.offline(model)
    assert sum(isinstance(o, CompensatedPair) for o in offline) > 100
    reference, comp = run(model, in_stamp_order(rec))
    assert_is_offline_prefix(reference, offline)
    # only the tail the data cannot decide yet is held: ⌊15 s / T⌋ + 1 intervals and the
    # reorder window
    assert comp.held <= (15 + 1 + 1 + 1) * pulse_hz + 2
    rng = np.random.default_rng(seed)
    for _ in range(2):
        live, _ = run(model, interleave(rec, rng, lag_s))
        assert [key(o) for o in live] == [key(o) for o in reference]


def test_temperatures_arriving_after_the_pulses_change_nothing() -> None:
    """The flaky DDS case: the pulses of the next seconds arrive before the temperatures."""
    model = model_of(('H', 'Hdot'))
    rec = recording(7, duration_s=120, h_rate_c_s=0.05)
    ordered, _ = run(model, in_stamp_order(rec))
    pulses_first = [m for m in in_stamp_order(rec) if m[0] == 'p'] + [
        m for m in in_stamp_order(rec) if m[0] == 't']
    late, comp = run(model, pulses_first)  # 120 s behind: more than the 15 s wait
    assert comp.held < len(rec.pulses) // 10
    assert [key(o) for o in late[:len(ordered)]] == [key(o) for o in ordered]
    n_pairs = sum(isinstance(o, CompensatedPair) for o in ordered)
    assert n_pairs > 0.8 * len(rec.pulses)


def test_newest_temperature_is_not_what_a_pulse_gets() -> None:
    """A pulse is compensated with the temperature of its own interval, not the newest."""
    model = model_of(('H',))
    rec = recording(3, duration_s=90, h_rate_c_s=0.05)
    offline = rec.offline(model)
    live, _ = run(model, in_stamp_order(rec))
    pairs = [o for o in live if isinstance(o, CompensatedPair)]
    assert len(pairs) > 100
    assert_is_offline_prefix(live, offline)
    # H rises 0.05 °C/s: the biases of consecutive seconds differ, so a newest-temperature
    # rule (several seconds ahead once temperatures lead) would be told apart
    assert len({p.bias_rad_s for p in pairs}) > 50


def test_a_silent_temperature_topic_does_not_make_it_hoard_pulses() -> None:
    """Past max_held samples held, the oldest are given up on the pulse stamps alone."""
    model = model_of(('H',))
    rec = recording(11, duration_s=200)
    stop = T0_NS + 80 * 10**9
    rec.temps = [m for m in rec.temps if m[0] < stop]
    comp = OrderedThermalCompensator(model, max_wait_s=10.0, max_held=60)
    out: list[CompensatedPair | Rejection] = []
    for kind, t, v, sensor in in_stamp_order(rec):
        out += comp.add_pulse(t, v) if kind == 'p' else comp.add_temperature(t, v, sensor)
        assert comp.held <= max(61, (10 + 2 + 10 + 1) * 4 + 2)
    after = [o for o in out if stamp(o) > stop + 2 * 10**9]
    refused = [o for o in after if isinstance(o, Rejection)]
    assert after and refused == after
    assert 'thermal_max_age_s = 10 s' in refused[-1].reason
    # offline reads the last temperatures to the end; live cannot tell the last seconds
    # before them apart from a late topic
    assert_is_offline_prefix(out, rec.offline(model), every_rate_before_ns=stop - 5 * 10**9)
    # below max_held nothing is given up: the same run holds everything after the stop
    waiting, comp = run(model, in_stamp_order(rec), max_wait_s=10.0)
    assert all(stamp(o) < stop for o in waiting)
    assert comp.held >= 110 * 4


def test_a_sensor_reading_exactly_the_same_longer_than_the_wait_gives_no_rate() -> None:
    """A run of identical readings longer than the wait: no rate, never another number.

    Offline blanks a whole run of identical readings once it proves stuck; live cannot
    know that before the run ends, so it publishes nothing rather than a number offline
    might not give (documented; thermal_max_age_s sets how long a run may be).
    """
    model = model_of(('H',))
    rec = recording(5, duration_s=150)
    rec.temps = [(t, 7.0 if s == 'cavity_a' and t > T0_NS + 40 * 10**9 else c, s)
                 for t, c, s in rec.temps]
    out, _ = run(model, in_stamp_order(rec), max_wait_s=10.0)
    late = [o for o in out if stamp(o) > T0_NS + 60 * 10**9]
    refused = [o for o in late if isinstance(o, Rejection)]
    assert late and refused == late
    assert 'reading exactly the same value' in refused[-1].reason
    # not stuck by the end (110 s < sensor_stuck_s): offline gives rates there, live none
    assert_is_offline_prefix(out, rec.offline(model), every_rate_before_ns=T0_NS + 40 * 10**9)


@pytest.mark.parametrize('max_wait_s', [5.0, 30.0])
def test_latency_is_a_few_intervals_at_1_hz_sensors(max_wait_s: float) -> None:
    """Fed in stamp order, a pair comes out a few intervals after its stamp.

    Once its interval's temperatures are known: within about T + reorder window + the runs
    of equal readings, not the wait.
    """
    model = model_of(('H',))
    rec = recording(2, duration_s=100, periods_s=(1.0, 1.0, 1.0), h_rate_c_s=0.05)
    comp = OrderedThermalCompensator(model, max_wait_s=max_wait_s)
    lags = []
    for kind, t, v, sensor in in_stamp_order(rec):
        out = comp.add_pulse(t, v) if kind == 'p' else comp.add_temperature(t, v, sensor)
        lags += [(t - stamp(o)) / 1e9 for o in out]
    assert len(lags) > 300
    assert np.median(lags) < 4.0 and max(lags) < min(max_wait_s, 10.0) + 3.0
