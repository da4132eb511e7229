"""Clock-locked pulse quantisation: a vibration frequency that divides the sample rate.

With the table at 20 Hz and pulses at 2 kHz the quantisation error repeats with the table
phase and, with the count drift of a gyro whose IA points north, does not average as white
noise: the Monte Carlo scatter was 1.8× the white-noise σ (±1σ coverage 50 %). The result
must say so and its uncertainty must not be the white-noise one; at 19.90 Hz (half way
between the divisors 2000/100 and 2000/101 Hz) nothing changes.
"""

from __future__ import annotations

import math

import pytest

from gyro_calib.dither.calibrator import (
    CLOCK_LOCK_FACTOR,
    KEY_A,
    KEY_Z,
    calibrate_dither,
    clock_lock,
)
from gyro_calib.dither.settings import DitherSettings
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import simulate_dither_pair
from sim_nodes.dither.vibration_table import VibrationTableConfig

K = math.radians(1 / 3600)


def test_clock_lock_detection() -> None:
    assert clock_lock(20.0, 2000.0, 60.0) == 100
    assert clock_lock(20.01, 2000.0, 60.0) == 100  # within 1/T of a divisor
    assert clock_lock(20.02, 2000.0, 60.0) == 0
    assert clock_lock(19.87, 2000.0, 60.0) == 0
    assert clock_lock(19.87, 2000.0, 12.0) == 101  # 2000/101 = 19.80 Hz: slips < 1 cycle
    assert clock_lock(27.6, 2000.0, 60.0) == 0
    assert clock_lock(25.0, 2000.0, 60.0) == 80
    assert clock_lock(math.nan, 2000.0, 60.0) == 0


def _calibrate(table_hz: float):
    gyro = DitheredGyroConfig(misalignment_arcmin=10.0, ia_azimuth_deg=40.0, seed=3,
                              heading_deg=90.0, rocking_arcsec_per_arcmin=0.0)
    runs = simulate_dither_pair(gyro, VibrationTableConfig(rate_amplitude_rad_s=20.0,
                                                           frequency_hz=table_hz),
                                DitherBenchConfig(duration_s=12.0))
    settings = DitherSettings(scale_factor_rad_per_pulse=K, rocking_treatment='none',
                              max_misalignment_arcmin=60.0)
    return calibrate_dither(runs['z'], runs['y'], settings=settings)


@pytest.fixture(scope='module')
def locked():
    return _calibrate(20.0)


@pytest.fixture(scope='module')
def unlocked():
    return _calibrate(19.90)  # half way between 2000/100 and 2000/101 Hz


def test_locked_bench_says_so_and_widens(locked) -> None:
    comps, _ = locked.components()
    summary = locked.summary()
    res = locked.results()
    for axis, c in comps.items():
        white = c.statistical_std_rad / math.sqrt(
            max(locked.orientations[axis].equations.solve().inflation, 1.0))
        assert c.clock_lock_std_rad > 0 or c.statistical_std_rad >= CLOCK_LOCK_FACTOR * white
        assert c.random_std_rad == pytest.approx(
            max(CLOCK_LOCK_FACTOR * white, c.statistical_std_rad), rel=1e-9)
        assert c.std_rad >= c.random_std_rad
        assert 'divides the 2000 Hz sample rate' in c.clock_lock_note
        assert 'widened' in c.clock_lock_note and '19.90 Hz' in c.clock_lock_note
        assert c.clock_lock_note in summary.notes[axis]
        assert any(c.clock_lock_note == line for line in summary.lines())
    assert 'divides' in res[KEY_Z].basis and 'divides' in res[KEY_A].basis
    m = summary.misalignment
    assert m is not None and m.clock_lock_std_rad > 0
    assert res[KEY_A].std_uncertainty == pytest.approx(m.std_rad)
    assert m.std_rad > m.statistical_std_rad


def test_unlocked_bench_unchanged(unlocked) -> None:
    comps, _ = unlocked.components()
    summary = unlocked.summary()
    res = unlocked.results()
    for c in comps.values():
        assert c.clock_lock_std_rad == 0.0 and c.clock_lock_note == ''
        assert c.random_std_rad == c.statistical_std_rad
        assert c.std_rad == c.statistical_std_rad  # rocking_treatment none
    assert summary.notes == {}
    assert res[KEY_A].basis == '' and res[KEY_Z].basis == ''
    assert summary.misalignment is not None
    assert summary.misalignment.clock_lock_std_rad == 0.0
    assert res[KEY_A].std_uncertainty == pytest.approx(summary.misalignment.statistical_std_rad)
