"""Multiposition over the space of hand-turned benches (hypothesis; physics in the test).

Any legal bench — 13 to 24 poses, 25 to 400 Hz, rests of 2.2 to 6 s, turns of 0.5 to 3 s,
MEMS noise levels and scales off by a few % — gives both fits, every pose found, and every
parameter within the Student-t bound at its ν that a correct u breaks once in 10⁴.
A rest must outlast the 1-s variance window by the 1-s minimum (the window trims half of
itself at each end): shorter rests are rejected, each named, and the method says how many
poses it still needs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from multiposition_physics import random_unit, record
from scipy import stats

from gyro_calib.multiposition.calibrator import calibrate
from gyro_calib.multiposition.recording import Recording

TAIL = 1e-4
"""Two-sided probability a correct u exceeds the bound, per parameter."""


def _bound(dof: np.ndarray) -> np.ndarray:
    """Student t quantile at ν per parameter: 3.9 at ν = ∞, 15 at ν = 4 (13 poses)."""
    return np.asarray(stats.t.ppf(1 - TAIL / 2, np.minimum(dof, 1e6)))


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), poses=st.integers(13, 24),
       rate_hz=st.sampled_from([25.0, 50.0, 100.0, 200.0, 400.0]),
       rest_s=st.floats(2.2, 6.0), turn_s=st.floats(0.5, 3.0),
       noise_scale=st.floats(0.2, 3.0))
def test_any_hand_turned_bench_is_calibrated_within_its_uncertainty(
        seed: int, poses: int, rate_hz: float, rest_s: float, turn_s: float,
        noise_scale: float) -> None:
    """Every pose found, both fits, |estimate − truth| ≤ 5u for every parameter."""
    rng = np.random.default_rng(seed)
    unit = random_unit(rng)
    unit = dataclasses.replace(unit, acc_noise=unit.acc_noise * noise_scale,
                               gyro_noise=unit.gyro_noise * noise_scale)
    t, acc, gyro, mean_bias = record(unit, rng, poses=poses, rate_hz=rate_hz,
                                     rest_s=(rest_s, rest_s * 1.3),
                                     turn_s=(turn_s, turn_s * 1.3))
    r = calibrate(Recording(t, acc, gyro, 'm/s²', 'rad/s'), gravity_m_s2=9.80665,
                  gravity_std_m_s2=0.0)
    assert len(r.detection.intervals) == poses, [x.reason for x in r.detection.rejected]
    assert r.accelerometer is not None and r.gyro is not None, r.problem
    truth = unit.gyro_truth()
    truth[9:] = mean_bias
    za = np.abs(r.accelerometer.values - unit.acc_truth()) / r.accelerometer.std
    zg = np.abs(r.gyro.values - truth) / r.gyro.std
    assert np.all(za < _bound(r.accelerometer.dof)), (za, r.accelerometer.dof)
    assert np.all(zg < _bound(r.gyro.dof)), (zg, r.gyro.dof)


def test_rests_too_short_are_named_and_the_shortfall_said() -> None:
    """1.5-s rests at 25 Hz: each rejected with its length, and the poses still needed said."""
    rng = np.random.default_rng(0)
    unit = random_unit(rng)
    t, acc, gyro, _ = record(unit, rng, poses=13, rate_hz=25.0, rest_s=(1.5, 1.9),
                             turn_s=(1.0, 1.3))
    r = calibrate(Recording(t, acc, gyro, 'm/s²', 'rad/s'), gravity_m_s2=9.80665,
                  gravity_std_m_s2=0.0)
    assert r.accelerometer is None
    assert len(r.detection.rejected) >= 8
    assert all('shorter than 1 s' in x.reason for x in r.detection.rejected)
    assert 'needs at least 12' in r.problem
