"""Property: merging runs into a hand-off file loses nothing.

Property (issue 17 item 5): whatever runs of one gyro are merged into its hand-off file, in
whatever order, nothing measured is lost, each quantity is the most precise measurement of it,
the keys that go together come from one run, and the file names that run truthfully.

The runs are drawn here from the physics of repeated measurements of one gyro: each quantity
has one true value; a run measures a random subset of the RBRLG quantity groups (K̃ with its
window pairs; θ with K and its stations; ω′ₑ + ω_B; ω_B), each with its own standard
uncertainty (log-uniform over three decades) and an error of at most 3 of them (so any two
runs agree within the file's 5 combined standard uncertainties). ``GYRO_CALIB_STRESS=1``
raises the example count.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.handoff import (
    HandoffError,
    Provenance,
    load_calibration,
    method_calibration,
    update_calibration,
)

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')

TRUTH = {'k_tilde_rad_per_pulse': 4.0859845e-06, 'fix_error_angle_rad': 3.1355e-3,
         'scale_factor_rad_per_pulse': 4.0859644e-06, 'bias_plus_earth_rate_rad_s': 3.45e-5,
         'bias_rad_s': 5.2e-8}
"""One gyro's true values (rad/pulse, rad, rad/s)."""

GROUPS = {'k_tilde': ('k_tilde_rad_per_pulse', 'window_pairs'),
          'theta': ('fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'stations'),
          'earth': ('bias_plus_earth_rate_rad_s',), 'bias': ('bias_rad_s',)}
"""What one measurement gives together; the first key leads (the counts follow it)."""

RELATIVE_STD = {'k_tilde_rad_per_pulse': 1e-8, 'fix_error_angle_rad': 1e-4,
                'scale_factor_rad_per_pulse': 1e-8, 'bias_plus_earth_rate_rad_s': 1e-3,
                'bias_rad_s': 0.3}


@st.composite
def runs(draw: st.DrawFn) -> list[dict[str, Any]]:
    out = []
    for i in range(draw(st.integers(1, 6), label='runs')):
        groups = draw(st.lists(st.sampled_from(sorted(GROUPS)), min_size=1, unique=True),
                      label='groups')
        values: dict[str, Any] = {}
        for group in groups:
            n = draw(st.integers(2, 40), label='count')
            for key in GROUPS[group]:
                if key in ('window_pairs', 'stations'):
                    values[key] = n
                    continue
                std = abs(TRUTH[key]) * RELATIVE_STD[key] * 10 ** draw(
                    st.floats(0.0, 3.0), label='log_std')
                values[key] = TRUTH[key] + std * draw(st.floats(-3.0, 3.0), label='error')
                values[key + '_std'] = std
        out.append({'values': values, 'source': f'run {i}',
                    'gyro_id': draw(st.sampled_from(['', 'A-1']), label='gyro_id')})
    return out


@settings(max_examples=300 if STRESS else 40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(runs())
def test_merging_runs_keeps_the_best_of_each_quantity_and_names_its_run(
        tmp_path: Path, sequence: list[dict[str, Any]]) -> None:
    path = tmp_path / 'gyro.yaml'
    path.unlink(missing_ok=True)
    for i, run in enumerate(sequence):
        record = method_calibration('rbrlg', run['values'],
                                    Provenance(run['source'], 10 * i, 10 * i + 5),
                                    gyro_id=run['gyro_id'])
        report: list[str] = []
        before = {k for k in (load_calibration(path).values if path.exists() else {})
                  if not k.endswith(('_std', '_dof'))}
        update_calibration(path, record, report=report)
        told = [line.split(':', 1)[1].split('=')[0].strip() for line in report
                if line.startswith(('added', 'replaced', 'kept', 'dropped'))]
        mine = before | {k for k in run['values'] if not k.endswith(('_std', '_dof'))}
        assert sorted(told) == sorted(mine)  # one line per key, every key
    final = load_calibration(path)
    measured = {k for run in sequence for k in run['values']}
    assert set(final.values) == measured  # nothing lost
    for group in GROUPS.values():
        lead = group[0]
        if lead not in final.values:
            continue
        stds = [run['values'][lead + '_std'] for run in sequence if lead in run['values']]
        assert final.values[lead + '_std'] == min(stds)  # the most precise
        source = final.source_of(lead)
        assert source is not None
        run = next(r for r in reversed(sequence) if r['source'] == source.source)
        for key in group:  # the whole group from the run the file names
            assert final.source_of(key) == source
            assert final.values[key] == run['values'][key]
            if key + '_std' in run['values']:
                assert final.values[key + '_std'] == run['values'][key + '_std']
    assert final.gyro_id == ('A-1' if any(r['gyro_id'] for r in sequence) else '')
    assert math.isfinite(final.values.get('k_tilde_rad_per_pulse', 0.0))


# -- the same bag re-run with other settings (issue 35 item 1) --------------------------------

SETTINGS = st.fixed_dictionaries({}, optional={
    'latitude_deg': st.sampled_from([30.0, 45.0, 60.0]),
    'heading_deg': st.sampled_from([0.0, 90.0]),
    'outliers': st.sampled_from(['keep', 'remove']),
    'taus': st.sampled_from(['octave', '1,10,100']),
    'config_file_sha256': st.sampled_from(['0123456789abcdef', 'fedcba9876543210'])})
"""Settings a front door may be given that change a run's numbers."""


@settings(max_examples=300 if STRESS else 60, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(first=SETTINGS, second=SETTINGS, shift_sigma=st.floats(0.0, 50.0).filter(
    lambda z: abs(z - 5.0) > 0.01), replace=st.booleans(),
       key=st.sampled_from(['bias_rad_s', 'fix_error_angle_rad', 'k_tilde_rad_per_pulse']))
def test_the_same_bag_under_other_settings_is_another_run(
        tmp_path: Path, first: dict[str, Any], second: dict[str, Any], shift_sigma: float,
        replace: bool, key: str) -> None:
    """Its values are checked against the file's; a replacement says old and new."""
    path = tmp_path / 'gyro.yaml'
    path.unlink(missing_ok=True)
    std = abs(TRUTH[key]) * RELATIVE_STD[key]
    old, new = TRUTH[key], TRUTH[key] + shift_sigma * math.hypot(std, std)
    update_calibration(path, method_calibration(
        'rbrlg', {key: old, key + '_std': std}, Provenance('bags/b', 100, 200, settings=first)))
    before = path.read_bytes()
    record = method_calibration('rbrlg', {key: new, key + '_std': std},
                                Provenance('bags/b', 100, 200, settings=second))
    report: list[str] = []
    if first != second and shift_sigma > 5.0 and not replace:
        with pytest.raises(HandoffError, match=rf'{key}: .* differ by .*the same data under '
                                               r'other settings \(.* -> .*\).*--replace'):
            update_calibration(path, record, report=report)
        assert path.read_bytes() == before  # nothing written
        return
    update_calibration(path, record, replace=replace, report=report)
    final = load_calibration(path)
    (line,) = [ln for ln in report if f' {key} = ' in ln]
    if first == second or replace:  # the same run, updated; or replace asked: this run's
        assert final.values[key] == new
        assert line.startswith('replaced:') and f'was {old!r}' in line and repr(new) in line
        assert ('same run, updated' in line) == (first == second)
    else:  # as precise, newer: taken, saying so, old and new
        assert final.values[key] == new and 'as precise, newer' in line
        assert f'was {old!r}' in line and 'other settings' in line
    assert dict(final.methods['rbrlg'].settings) == second


# -- another sensor (issue 35 item 2; the gyro technology: round 2) -------------------------

RUN_METHODS = {'single gyro': ('noise',), 'RLG': ('noise', 'rbrlg', 'dither', 'thermal'),
               'FOG': ('noise', 'fog'), 'IMU': ('noise',), 'triad': ('noise',)}
"""The methods that give a run of each sensor ('single gyro': a noise run that does not say
its input, as files written before the technology was recorded)."""

ONE_VALUE = {'rbrlg': ('k_tilde_rad_per_pulse', 4.0859845e-06),
             'dither': ('dither_frequency_hz', 400.0),
             'thermal': ('thermal_holdout_bias_stability_raw_rad_s', 1e-7),
             'fog': ('fog_bias_rad_s', 2.4e-6)}
"""One value each method gives (its unit in the key), for a run of a method other than noise."""

K_RAD_PER_PULSE, SF_COUNTS_PER_RAD = 4.0859845e-06, 43948.3
"""The RLG's scale factor and the FOG's, on which their noise runs rest."""


def _record(kind: str, rate_hz: float, source: str, method: str = 'noise') -> Any:
    """One run of ``method`` on a sensor of ``kind`` (a noise run sampled at ``rate_hz``).

    A white rate noise of density N gives ADEV(τ₀) = N/√τ₀ at the shortest τ, τ₀ = 1/rate.
    An RLG's noise run reads /gyro/pulses with its K, a FOG's /fog/output with its SF.
    """
    import dataclasses

    from gyro_calib.imu_calibration import ImuCalibration

    if method != 'noise':
        key, value = ONE_VALUE[method]
        return method_calibration(method, {key: value, f'{key}_std': value * 1e-3},
                                  Provenance(source, 0, 10))
    n = 1e-6
    tau0 = 1.0 / rate_hz
    table = {'tau_s': [tau0, 2 * tau0], 'm': [1, 2],
             'adev': [n / math.sqrt(tau0), n / math.sqrt(2 * tau0)]}
    if kind in ('single gyro', 'RLG', 'FOG'):
        said: dict[str, Any] = {
            'single gyro': {}, 'RLG': {'settings': {'topic': '/gyro/pulses'}, 'conditions': {
                'scale_factor_rad_per_pulse': K_RAD_PER_PULSE}},
            'FOG': {'settings': {'topic': '/fog/output'}, 'conditions': {
                'fog_scale_factor_counts_per_rad': SF_COUNTS_PER_RAD}}}[kind]
        return method_calibration('noise', {'angle_random_walk_rad_per_sqrt_s': n,
                                            'angle_random_walk_rad_per_sqrt_s_std': n / 10},
                                  Provenance(source, 0, 10, deviations={'gyro': table}, **said))
    if kind == 'IMU':
        return method_calibration('noise', {'imu_gyro_x_angle_random_walk_rad_per_sqrt_s': n,
                                            'imu_gyro_x_angle_random_walk_rad_per_sqrt_s_std':
                                            n / 10},
                                  Provenance(source, 0, 10, deviations={
                                      a: table for a in ('gyro_x', 'gyro_y', 'gyro_z')}))
    channels = ('x', 'y', 'z')
    cal = method_calibration('noise', {}, Provenance(source, 0, 10, deviations={
        c: table for c in channels}))
    return dataclasses.replace(cal, imu=ImuCalibration(channels, noise={
        c: {'angle_random_walk_rad_per_sqrt_s': n, 'angle_random_walk_rad_per_sqrt_s_std':
            n / 10} for c in channels}))


SINGLE = ('single gyro', 'RLG', 'FOG')


@st.composite
def sensor_runs(draw: st.DrawFn) -> tuple[str, str, str, str, float, float]:
    """(file's sensor, its run's method, run's sensor, run's method, file rate, rate ratio)."""
    kinds = ['single gyro', 'RLG', 'FOG', 'IMU', 'triad']
    file_kind = draw(st.sampled_from(kinds), label='file_kind')
    file_method = draw(st.sampled_from(RUN_METHODS[file_kind]), label='file_method')
    run_kind = draw(st.sampled_from(kinds), label='run_kind')
    run_method = draw(st.sampled_from(RUN_METHODS[run_kind]), label='run_method')
    return (file_kind, file_method, run_kind, run_method,
            draw(st.sampled_from([100.0, 200.0, 500.0, 1000.0]), label='file_rate'),
            draw(st.sampled_from([1.0, 1.001, 0.5, 2.5]), label='rate_ratio'))


@settings(max_examples=400 if STRESS else 80, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(drawn=sensor_runs())
def test_a_run_of_another_sensor_is_refused_in_one_line_naming_what_differs(
        tmp_path: Path, drawn: tuple[str, str, str, str, float, float]) -> None:
    """Another kind, another technology (an RLG's pulses, a FOG's counts), another rate."""
    file_kind, file_method, run_kind, run_method, file_rate, rate_ratio = drawn
    path = tmp_path / 'sensor.yaml'
    path.unlink(missing_ok=True)
    update_calibration(path, _record(file_kind, file_rate, 'bags/first', file_method))
    before = path.read_bytes()
    run = _record(run_kind, file_rate * rate_ratio, 'bags/second', run_method)
    single = file_kind in SINGLE and run_kind in SINGLE
    differs = ['sensor kind'] * (not single and run_kind != file_kind) + [
        'gyro technology'] * ('single gyro' not in (file_kind, run_kind) and single
                              and run_kind != file_kind) + [
        'sample rate'] * (abs(rate_ratio - 1) > 0.01 and file_method == run_method == 'noise')
    if not differs:
        update_calibration(path, run)
        return
    with pytest.raises(HandoffError) as refused:
        update_calibration(path, run)
    line = str(refused.value)
    assert '\n' not in line and 'one sensor per file' in line
    assert line.startswith(f'another sensor ({", ".join(differs)} differ'), line
    assert path.read_bytes() == before  # nothing written
