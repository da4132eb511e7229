"""A constant rate is a constant: a gyro turning steadily has the noise it has at rest.

A rate-biased RLG is operated (and its noise measured) on a table turning at a constant
rate Ω: its angle is Ω·t plus its noise, and every Allan-family deviation removes the linear
phase Ω·t exactly (second differences of a line vanish). The table gate therefore analyses
each span at a constant rate as a segment and leaves out only the changes of rate between
spans (METHODS §E.1). With the table's encoder angle subtracted (``table_reference =
gyro_minus_table``) a wobble of the table's rate about Ω is removed as well.

Everything here is generated from the physics, not from the project's simulators: the table
runs through spans of constant commanded rate joined by ramps of constant acceleration, with
a sinusoidal rate wobble; its encoder reads the angle (quantised to 2²³ counts per revolution,
or exactly) and differences it for the rate; the gyro (a FOG-like continuous count, SF
counts/rad) reads SF·(table angle + bias·t + angle random walk). Its twin at rest reads
SF·(bias·t + the same random walk).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from gyro_calib.noise.calibrator import NoiseCalibrator
from gyro_calib.noise.settings import NoiseSettings

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
SF = 1.0e6                      # counts/rad
GYRO_HZ = 200
N_TRUE = 2.0e-4                 # angle random walk, rad/√s
BIAS = 5.0e-5                   # rad/s (Earth rate and bias: a constant)
ENCODER_RAD = 2 * math.pi / 2**23
START_NS = 2_000_000_000_000
DEG = math.pi / 180.0

Span = tuple[float, float]  # (rate rad/s, duration s)


def profile(spans: list[Span], accel: float, t_s: np.ndarray) -> tuple[np.ndarray, list[
        tuple[float, float, float]], list[tuple[float, float]]]:
    """Angle at t_s of a table running through ``spans`` joined by ramps at |accel|.

    Returns (angle rad, ramps as (start s, end s, |accel|), constant spans as (start, end)).
    """
    angle = np.zeros(len(t_s))
    ramps, steady = [], []
    t0, theta0 = 0.0, 0.0
    for k, (rate, duration) in enumerate(spans):
        t1 = t0 + duration
        steady.append((t0, t1))
        inside = (t_s >= t0) & (t_s < t1) if k < len(spans) - 1 else t_s >= t0
        angle = np.where(inside, theta0 + rate * (t_s - t0), angle)
        theta0 += rate * duration
        if k < len(spans) - 1:
            nxt = spans[k + 1][0]
            a = math.copysign(accel, nxt - rate)
            ramp = (nxt - rate) / a
            s = t_s - t1
            on = (s >= 0) & (s < ramp)
            angle = np.where(on, theta0 + rate * s + 0.5 * a * s**2, angle)
            ramps.append((t1, t1 + ramp, accel))
            theta0 += rate * ramp + 0.5 * a * ramp**2
            t0 = t1 + ramp
    return angle, ramps, steady


def record(spans: list[Span], accel: float, wobble: tuple[float, float], table_hz: int,
           quantised: bool, seed: int) -> dict[str, Any]:
    """The gyro on the turning table, its twin at rest, and the table's states."""
    rng = np.random.default_rng(seed)
    total = sum(d for _, d in spans) + sum(abs(b[0] - a[0]) / accel
                                           for a, b in zip(spans[:-1], spans[1:]))
    n = int(total * GYRO_HZ) + 1
    tg = np.arange(n, dtype=np.int64) * (1_000_000_000 // GYRO_HZ)
    w, f = wobble
    phase = rng.uniform(0.0, 2 * math.pi)

    def table_angle(t_s: np.ndarray) -> tuple[np.ndarray, list[tuple[float, float, float]],
                                               list[tuple[float, float]]]:
        angle, ramps, steady = profile(spans, accel, t_s)
        if w:
            angle = angle - w / (2 * math.pi * f) * (np.cos(2 * math.pi * f * t_s + phase)
                                                     - math.cos(phase))
        return angle, ramps, steady

    ts = tg / 1e9
    table, ramps, steady = table_angle(ts)
    noise = BIAS * ts + np.concatenate(([0.0], np.cumsum(
        rng.normal(0.0, N_TRUE / math.sqrt(GYRO_HZ), n - 1))))
    m = int(total * table_hz) + 1
    tt = np.arange(m, dtype=np.int64) * (1_000_000_000 // table_hz)
    true = table_angle(tt / 1e9)[0]
    encoder = np.round(true / ENCODER_RAD) * ENCODER_RAD if quantised else true
    rate = np.concatenate(([spans[0][0]], np.diff(encoder) * table_hz))
    return {'t_gyro': START_NS + tg, 'turning': SF * (table + noise), 'rest': SF * noise,
            't_table': START_NS + tt, 'angle': encoder, 'rate': rate, 'ramps': ramps,
            'steady': steady}


def gated(b: dict[str, Any], reference: str, chunk: int) -> NoiseCalibrator:
    """The turning gyro and the table fed in interleaved chunks (the table's states first)."""
    cal = NoiseCalibrator(NoiseSettings(fog_scale_factor_counts_per_rad=SF,
                                        table_reference=reference))
    t_gyro, t_table = b['t_gyro'], b['t_table']
    for a in range(0, len(t_gyro), chunk):
        z = min(a + chunk, len(t_gyro))
        lo = t_gyro[a - 1] if a else t_table[0] - 1
        hi = t_gyro[z - 1] if z < len(t_gyro) else t_table[-1]
        k = (t_table > lo) & (t_table <= hi)
        cal.extend_table(t_table[k], b['angle'][k], b['rate'][k])
        cal.extend_fog_output(t_gyro[a:z], b['turning'][a:z])
        cal.process()
    cal.process(flush=True)
    return cal


def spans_strategy() -> st.SearchStrategy[list[Span]]:
    """One span of 20–40 s, or 2–3 spans of 8–20 s at rates ≥ 10 °/s apart.

    Each at rest or at 1–200 °/s either way (20 s or more in all, for N).
    """
    turning = st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(1.0, 200.0)).map(
        lambda sr: sr[0] * sr[1] * DEG)
    rate = st.one_of(st.just(0.0), turning)
    single = st.tuples(rate, st.floats(20.0, 40.0)).map(lambda span: [span])
    several = st.lists(st.tuples(rate, st.floats(8.0, 20.0)), min_size=2, max_size=3).filter(
        lambda s: all(abs(a[0] - b[0]) >= 10.0 * DEG for a, b in zip(s[:-1], s[1:])))
    return st.one_of(single, several)


@settings(max_examples=100 if STRESS else 10, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(spans=spans_strategy(), accel_deg_s2=st.floats(20.0, 500.0),
       wobble_rad_s=st.one_of(st.just(0.0), st.floats(1e-5, 2e-4)),
       wobble_hz=st.floats(3.0, 8.0), reference=st.sampled_from(['gyro', 'gyro_minus_table']),
       table_hz=st.sampled_from([50, GYRO_HZ]), quantised=st.booleans(),
       chunk=st.integers(100, 3000), seed=st.integers(0, 2**16))
@example(spans=[(37.9 * DEG, 30.0)], accel_deg_s2=100.0, wobble_rad_s=0.0, wobble_hz=3.0,
         reference='gyro', table_hz=50, quantised=True, chunk=997, seed=1)
@example(spans=[(-150.0 * DEG, 25.0)], accel_deg_s2=100.0, wobble_rad_s=2e-4, wobble_hz=5.0,
         reference='gyro_minus_table', table_hz=GYRO_HZ, quantised=False, chunk=512, seed=2)
def test_the_terms_at_constant_rate_are_those_at_rest_and_the_changes_are_left_out(
        spans: list[Span], accel_deg_s2: float, wobble_rad_s: float, wobble_hz: float,
        reference: str, table_hz: int, quantised: bool, chunk: int, seed: int) -> None:
    # the gyro alone keeps a wobble in its angle: only the table's angle removes it
    wobble = (wobble_rad_s if reference == 'gyro_minus_table' else 0.0, wobble_hz)
    b = record(spans, accel_deg_s2 * DEG, wobble, table_hz, quantised, seed)
    cal = gated(b, reference, chunk)
    s = cal.settings
    t = b['t_gyro']
    n, seg = cal.gate.decide(t, final=True)
    left_out = np.any(seg == -1, axis=1)
    # 1. the changes of rate are left out; the constant spans are analysed
    ts = (t - START_NS) / 1e9
    state_s = 1.0 / table_hz
    theta_tol = s.table_rest_angle_rad + 3.5 * s.table_stamp_jitter_s
    for lo, hi, a in b['ramps']:
        d = np.minimum(ts - lo, hi - ts) - state_s  # into the ramp, judged one state later
        seen = (0.5 * a * d**2 > 2 * theta_tol) | (a * d > 2 * s.table_rest_rate_rad_s)
        assert not np.any(~left_out & (ts > lo) & (ts < hi) & (d > 0) & seen)
    for lo, hi in b['steady']:
        if hi - lo >= s.table_min_steady_s + 4 * state_s:
            first = lo + 2 * state_s if lo > 0 else -math.inf
            last = hi - 2 * state_s if hi < ts[-1] else math.inf
            assert not np.any(left_out & (ts > first) & (ts < last))
    motion = cal.table_record()
    assert motion is not None
    assert motion['samples_left_out'] == {'/fog/output': int(np.count_nonzero(left_out))}
    assert motion['changes'] == ['start' if abs(x) < 1e-9 else 'stop' if abs(y) < 1e-9 else
                                 'reversal' if x * y < 0 else 'change of rate'
                                 for (x, _), (y, _) in zip(spans[:-1], spans[1:])]
    assert motion['steady_rates_rad_s'] == pytest.approx(
        [r for r, _ in spans], abs=1e-3)
    assert motion['reference'] == reference
    # 2. the twin at rest, cut where the gate cut: the same noise
    twin = NoiseCalibrator(NoiseSettings(fog_scale_factor_counts_per_rad=SF))
    twin.extend_fog_output(t[~left_out], b['rest'][~left_out])
    twin.process(flush=True)
    got, want = cal.json_section()['axes']['gyro'], twin.json_section()['axes']['gyro']
    assert got['tau_s'] == want['tau_s']
    # a change of rate too small for the thresholds (a ramp's first few ms) may be analysed:
    # then the record holds a trace of it, and the twin only agrees within uncertainty
    in_ramp = np.zeros(len(ts), dtype=bool)
    for lo, hi, _ in b['ramps']:
        in_ramp |= (ts > lo) & (ts < hi)
    exact = ((reference == 'gyro' or (not quantised and table_hz == GYRO_HZ))
             and not np.any(in_ramp & ~left_out))
    if len(spans) == 1:  # one constant rate throughout: nothing left out
        assert not left_out.any() and motion['moved'] is False
    event(f'ADEV equal to the twin\'s to 1e-6: {exact}')
    if exact:  # Ω·t (and the wobble, subtracted at the gyro's own stamps) cancel exactly
        np.testing.assert_allclose(got['adev'], want['adev'], rtol=1e-6)
    key = 'angle_random_walk_rad_per_sqrt_s'
    got_terms, want_terms = cal.results().get('gyro', {}), twin.results().get('gyro', {})
    assert (key in got_terms) == (key in want_terms)
    event(f'N resolved: {key in got_terms}')
    if key not in got_terms:  # too few τ in the steady spans for either: said the same way
        assert cal.missing()['gyro'][key] == twin.missing()['gyro'][key]
        return
    n_got, n_want = got_terms[key], want_terms[key]
    assert abs(n_got.value - n_want.value) <= 3 * math.hypot(n_got.std_uncertainty,
                                                             n_want.std_uncertainty)
    assert abs(n_got.value - N_TRUE) < 4 * n_got.std_uncertainty


def test_the_table_angle_subtracted_live_gives_the_offline_numbers_bit_for_bit() -> None:
    """gyro_minus_table fed in a node's chunks (the table's states first) = all at once."""
    b = record([(37.9 * DEG, 12.0), (-37.9 * DEG, 12.0)], 100.0 * DEG, (1e-4, 5.0), 50, True,
               seed=4)
    offline = NoiseCalibrator(NoiseSettings(fog_scale_factor_counts_per_rad=SF,
                                            table_reference='gyro_minus_table'))
    offline.extend_table(b['t_table'], b['angle'], b['rate'])
    offline.extend_fog_output(b['t_gyro'], b['turning'])
    offline.process(flush=True)
    live = gated(b, 'gyro_minus_table', 211)
    assert live.json_section()['axes'] == offline.json_section()['axes']
    record_ = live.table_record()
    assert record_ is not None and record_['reference'] == 'gyro_minus_table'
    assert record_['changes'] == ['reversal']
    assert "reference: the gyro angle minus the rate table's encoder angle (counts/SF − " \
        'encoder angle) for ' in live.table_line()


def test_a_gyro_counting_against_the_table_is_refused_with_gyro_minus_table() -> None:
    """The sense axis down the table's axis: refused in one line naming the setting.

    The gyro's angle minus the table's is then 2·Ω·t plus twice the wobble, not its noise.
    """
    from gyro_calib.errors import ConfigError

    b = record([(37.9 * DEG, 12.0)], 100.0 * DEG, (0.0, 5.0), 50, True, seed=5)
    b['turning'] = -b['turning']
    with pytest.raises(ConfigError, match='table_reference = gyro_minus_table: /fog/output '
                                          'turns at -37.9'):
        gated(b, 'gyro_minus_table', 997)
    assert gated(b, 'gyro', 997).results()['gyro']  # the gyro alone: a constant rate removed


def test_gyro_minus_table_without_a_rate_table_says_the_gyro_alone_was_used() -> None:
    b = record([(0.0, 20.0)], 100.0 * DEG, (0.0, 5.0), 50, True, seed=6)
    cal = NoiseCalibrator(NoiseSettings(fog_scale_factor_counts_per_rad=SF,
                                        table_reference='gyro_minus_table'))
    cal.extend_fog_output(b['t_gyro'], b['rest'])
    cal.process(flush=True)
    assert cal.table_line() == ('table_reference = gyro_minus_table, but no '
                                '/rate_table/joint_states state was recorded: reference: the '
                                'gyro alone.')
    assert cal.table_record() is None and cal.results()['gyro']
