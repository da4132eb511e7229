"""The navigation benefit rests on the real triad estimator (issue 41 §1; reduced bench).

``benchmarks/navigation_benefit.py``'s own bench generator (written there from the
kinematics, not sim_nodes) records a short two-axis run of one triad (one inner pair of
2 turns, three stations, 200 Hz pulses); the real :class:`TriadSession` calibrates it (the
ARW stated, as a noise run gives it); the
hand-off's ``imu:`` section goes through imu_corrector's reader
(:func:`~gyro_calib.imu_body_rate.triad_rate_model`); a separate manoeuvring trajectory of the
same sensor is navigated. The calibrated heading and tilt drift stay far below the user's
baseline (datasheet K, nominal axes, start-up bias), which the misalignment and the scale
factor errors drive under manoeuvres, and the calibrated error is consistent with the
calibration's own stated covariance. A triad estimator that breaks (wrong M, or an
uncertainty that no longer covers its error) fails here.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from triad_coverage_helpers import run_session

from gyro_calib.imu_body_rate import triad_rate_model

ROOT = Path(__file__).resolve().parents[1]
ARW_DEG_SQRT_H = 0.002


@pytest.fixture(scope='module')
def bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        'navigation_benefit', ROOT / 'benchmarks' / 'navigation_benefit.py')
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look themselves up there
    spec.loader.exec_module(module)
    return module


def calibrated(bench: ModuleType, sensor: object, seed: int) -> object:
    """The sensor's short bench through the real session → what the hand-off hands on."""
    plan = bench.BenchPlan(inner_pairs=1, inner_turns=2, stations_deg=(0.0, 120.0, 240.0),
                           sample_hz=200.0)
    chunk = bench.bench_record(sensor, plan, np.random.default_rng(seed))
    from triad_bench_physics import Recording

    rec = Recording(chunk.pulse_t_ns, chunk.pulse_counts, chunk.rate_table[0],
                    np.column_stack(chunk.rate_table[1:]), chunk.rate_zero_index_ns,
                    chunk.position_table[0], np.column_stack(chunk.position_table[1:]),
                    chunk.position_zero_index_ns)
    session = run_session(rec, bench.plan_settings(plan),
                          {'angle_random_walk_deg_sqrt_h': ARW_DEG_SQRT_H})  # a noise run's
    imu = session.imu_calibration()
    assert imu is not None, session.missing()
    model = triad_rate_model(imu)
    gyro_cov = np.eye(3) * sensor.arw ** 2  # type: ignore[attr-defined]
    return bench.Calibrated(model.m, model.m_covariance, model.bias_rad_s, model.bias_std,
                            gyro_cov, np.zeros((3, 3)), np.zeros(3), True)


def test_calibrated_triad_beats_the_users_baseline_under_manoeuvres_and_is_consistent(
        bench: ModuleType) -> None:
    seeds = [3, 4]
    sensors = [bench.draw_sensor(s, ARW_DEG_SQRT_H) for s in seeds]
    cals = [calibrated(bench, s, seed) for s, seed in zip(sensors, seeds, strict=True)]
    for sensor, cal in zip(sensors, cals, strict=True):
        # the estimated M within 5 of its stated u of the truth, element by element
        m_std = np.sqrt(np.diag(cal.m_cov)).reshape(3, 3)
        assert np.all(np.abs(cal.m - sensor.m) <= 5 * m_std), (cal.m - sensor.m) / m_std
    nav = bench.navigate('manoeuvring', 240.0, 0.1, sensors, cals, seeds)
    for what in ('heading_deg', 'tilt_deg'):
        got = {s: math.sqrt(float(np.mean(np.square(getattr(nav, what)[s]))))
               for s in bench.STREAMS}
        assert got['calibrated'] < got['baseline'] / 5, (what, got)
    assert max(nav.nees) < 16.3 / 3  # χ²₃ at 99.9 %, over 3 axes
