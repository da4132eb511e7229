"""The streaming FOG calibrator.

The streaming FOG calibrator: chunking never changes a result; bad input gets a reason,
never a wrong number, and what was measured before is kept (issue 10 "Bad input").
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from gyro_calib.fog import FogCalibrator, FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import (
    KEY_BIAS,
    KEY_BIAS_PLUS_EARTH,
    KEY_MAPPING,
    KEY_SCALE_FACTOR,
    KEY_SELF_CAL,
    SELF_CAL_KEYS,
)
from gyro_calib.fog.self_cal import SelfCalFit
from sim_nodes.fog import SelfCalLadder, TableSettings, simulate_mapping_and_self_cal
from sim_nodes.fog.scenarios import FogRecording, simulate_turntable

TABLE = TableSettings(output_rate_hz=200.0, lead_s=1.0)
SHORT_LADDER = SelfCalLadder(plateau_count=8, plateau_s=8.0)


def _calibrate(rec: FogRecording, **changes: object) -> FogCalibrator:
    return calibrate_fog(rec.output_t_ns, rec.output_counts,
                         injection_t_ns=rec.injection_t_ns,
                         injection_counts_s=rec.injection_counts_s,
                         table_t_ns=rec.table_t_ns, table_angle_rad=rec.table_angle_rad,
                         table_rate_rad_s=rec.table_rate_rad_s,
                         zero_index_ns=rec.zero_index_ns, settings=FogSettings(**changes))


def _reasons(cal: FogCalibrator) -> str:
    return ' | '.join(r.reason for r in cal.rejections)


@pytest.fixture(scope='module')
def combined() -> FogRecording:
    """Mapping and three more rates on the turntable, then a short ladder on a static base."""
    return simulate_mapping_and_self_cal(
        mapping_rates_deg_s=(-50.0, 5.0, 20.0, 20.01, 20.1, 21.0), mapping_hold_s=15.0,
        ladder=SHORT_LADDER, table=TABLE)


@pytest.fixture(scope='module')
def combined_cal(combined: FogRecording) -> FogCalibrator:
    return _calibrate(combined)


@pytest.fixture(scope='module')
def turntable() -> FogRecording:
    return simulate_turntable(rates_deg_s=(10.0, -10.0, 40.0, -40.0), hold_s=12.0, table=TABLE)


def _feed_in_windows(rec: FogRecording, cal: FogCalibrator, seed: int) -> list[str]:
    """Streams in random time windows, each stream lagging by up to 10 s, in random order."""
    rng = np.random.default_rng(seed)
    streams = [(rec.output_t_ns, (rec.output_counts,), cal.extend_output),
               (rec.injection_t_ns, (rec.injection_counts_s,), cal.extend_injection),
               (rec.table_t_ns, (rec.table_angle_rad, rec.table_rate_rad_s),
                cal.extend_table_states),
               (rec.zero_index_ns, (), cal.extend_zero_index)]
    pos = [0] * len(streams)
    t = int(rec.output_t_ns[0])
    lines = []
    while any(p < len(s[0]) for p, s in zip(pos, streams)):
        t += int(rng.uniform(0.5, 30.0) * 1e9)
        for k in rng.permutation(len(streams)):
            ts, values, extend = streams[k]
            j = int(np.searchsorted(ts, t - int(rng.uniform(0, 10) * 1e9), side='right'))
            if t > rec.output_t_ns[-1] + 20e9:
                j = len(ts)
            if j > pos[k]:
                extend(ts[pos[k]:j], *(v[pos[k]:j] for v in values))
                pos[k] = j
        lines += cal.process()
    return lines + cal.process(flush=True)


@pytest.mark.parametrize('seed', [1, 2])
def test_calibrator_results_do_not_depend_on_chunking_or_stream_lag(
        combined: FogRecording, combined_cal: FogCalibrator, seed: int) -> None:
    cal = FogCalibrator()
    _feed_in_windows(combined, cal, seed)
    assert cal.results() == combined_cal.results()
    assert cal.missing() == combined_cal.missing()
    assert sorted(r.reason for r in cal.rejections) == sorted(
        r.reason for r in combined_cal.rejections)


def test_calibrator_single_messages_equal_batch(turntable: FogRecording) -> None:
    cal = FogCalibrator()
    table = iter(zip(turntable.table_t_ns.tolist(), turntable.table_angle_rad.tolist(),
                     turntable.table_rate_rad_s.tolist()))
    index = iter(turntable.zero_index_ns.tolist())
    next_table, next_index = next(table, None), next(index, None)
    for i, (t, c) in enumerate(zip(turntable.output_t_ns.tolist(),
                                   turntable.output_counts.tolist())):
        cal.add_output(t, c)
        while next_table is not None and next_table[0] <= t:
            cal.add_table_state(*next_table)
            next_table = next(table, None)
        while next_index is not None and next_index <= t:
            cal.add_zero_index(next_index)
            next_index = next(index, None)
        if i % 500 == 0:
            cal.process()
    cal.process(flush=True)
    assert cal.results() == _calibrate(turntable).results()


def test_calibrator_measures_combined_run(combined: FogRecording,
                                          combined_cal: FogCalibrator) -> None:
    res = combined_cal.results()
    assert {KEY_SCALE_FACTOR, KEY_BIAS_PLUS_EARTH, KEY_MAPPING, KEY_SELF_CAL} <= set(res)
    k = res[KEY_SCALE_FACTOR]
    assert abs(k.value - combined.truth['turntable_k_counts_per_rad']) < 4 * k.std_uncertainty
    assert k.n_used == 6  # the static segment under the injections is left out
    assert 'overlaps a self-calibration injection' in _reasons(combined_cal)
    assert len(combined_cal.plateaus) == SHORT_LADDER.plateau_count + 1  # + the final zero


def test_calibrator_bias_key_follows_latitude(turntable: FogRecording) -> None:
    without = _calibrate(turntable)
    with_lat = _calibrate(turntable, latitude_deg=45.75)
    assert KEY_BIAS_PLUS_EARTH in without.results() and KEY_BIAS not in without.results()
    assert KEY_BIAS in with_lat.results() and KEY_BIAS_PLUS_EARTH not in with_lat.missing()
    bias = with_lat.results()[KEY_BIAS]
    assert abs(bias.value - turntable.truth['bias_rad_s']) < 4 * bias.std_uncertainty


def test_calibrator_without_data_says_what_is_missing() -> None:
    cal = FogCalibrator()
    assert cal.process(flush=True) == []
    assert cal.results() == {}
    missing = cal.missing()
    assert '/rate_table/joint_states' in missing[KEY_SCALE_FACTOR]
    assert '/fog/injection' in missing[KEY_SELF_CAL]


# -- bad input ---------------------------------------------------------------------------------
def test_no_mapping_phase_self_cal_says_so_and_turntable_stands() -> None:
    rec = simulate_mapping_and_self_cal(mapping_rates_deg_s=(5.0, -5.0, 50.0),
                                        mapping_hold_s=12.0, ladder=SHORT_LADDER, table=TABLE)
    cal = _calibrate(rec)
    res, missing = cal.results(), cal.missing()
    assert KEY_SCALE_FACTOR in res and KEY_MAPPING not in res
    for key in SELF_CAL_KEYS:
        assert key not in res
    assert 'no equivalence mapping' in missing[KEY_SELF_CAL]
    fit = cal.fits().self_cal
    assert isinstance(fit, SelfCalFit) and fit.linear is not None  # plateaus in counts remain


def test_no_injection_topic_gives_turntable_results_and_a_line_for_self_cal(
        turntable: FogRecording) -> None:
    cal = _calibrate(turntable)
    assert KEY_SCALE_FACTOR in cal.results()
    for key in SELF_CAL_KEYS:
        assert 'no /fog/injection messages' in cal.missing()[key]


def test_rate_excursion_rejects_that_segment_only() -> None:
    rec = simulate_turntable(rates_deg_s=(20.0, 30.0, 20.0, -20.0, 40.0),
                             hold_s=(12.0, 0.2, 12.0, 12.0, 12.0), table=TABLE)
    cal = _calibrate(rec)
    assert 'rate excursion' in _reasons(cal) and 'repeat this rate' in _reasons(cal)
    assert len(cal.segments) == 2  # −20 and 40 °/s
    assert cal.missing()[KEY_SCALE_FACTOR].startswith('2 distinct table rate(s)')


def test_non_finite_values_are_dropped_counted_and_never_enter_a_result(
        turntable: FogRecording) -> None:
    counts = turntable.output_counts.copy()
    counts[np.arange(300, 9000, 400)] = np.nan
    counts[5555] = np.inf
    rate = turntable.table_rate_rad_s.copy()
    rate[[100, 700, 1500]] = np.nan
    bad = dataclasses.replace(turntable, output_counts=counts, table_rate_rad_s=rate)
    cal = FogCalibrator()
    cal.extend_output(bad.output_t_ns, bad.output_counts)
    cal.extend_table_states(bad.table_t_ns, bad.table_angle_rad, bad.table_rate_rad_s)
    cal.extend_zero_index(bad.zero_index_ns)
    lines = cal.process(flush=True)
    assert any('/fog/output: 23 non-finite' in line for line in lines)
    assert any('/rate_table/joint_states: 3 non-finite' in line for line in lines)
    k, clean = cal.results()[KEY_SCALE_FACTOR], _calibrate(turntable).results()[KEY_SCALE_FACTOR]
    assert np.isfinite(k.value)
    assert abs(k.value - clean.value) < clean.std_uncertainty


def test_duplicate_and_out_of_order_stamps_give_the_clean_result(
        turntable: FogRecording) -> None:
    t, c = turntable.output_t_ns.copy(), turntable.output_counts.copy()
    swap = np.arange(1000, 8000, 97)
    t[swap], t[swap + 1] = t[swap + 1].copy(), t[swap].copy()
    c[swap], c[swap + 1] = c[swap + 1].copy(), c[swap].copy()
    dup = np.arange(50, 8000, 333)
    t, c = np.insert(t, dup, t[dup]), np.insert(c, dup, c[dup])
    cal = FogCalibrator()
    cal.extend_output(t, c)
    cal.extend_table_states(turntable.table_t_ns, turntable.table_angle_rad,
                            turntable.table_rate_rad_s)
    index = turntable.zero_index_ns
    cal.extend_zero_index(np.insert(index, [1, 3], index[[1, 3]]))
    lines = cal.process(flush=True)
    assert any('duplicate-stamp' in line and 're-sorted' in line for line in lines)
    assert cal.results() == _calibrate(turntable).results()


def test_plateau_too_short_to_settle_is_rejected_and_the_rest_kept() -> None:
    durations = (8.0, 8.0, 8.0, 0.2, 8.0, 8.0, 8.0, 8.0, 8.0)
    ladder = SelfCalLadder(plateau_count=9, plateau_durations_s=durations)
    cal = _calibrate(simulate_mapping_and_self_cal(mapping_hold_s=12.0, ladder=ladder,
                                                   table=TABLE))
    assert 'shorter than the loop needs to settle' in _reasons(cal)
    assert len(cal.plateaus) == 9  # 8 of the ladder + the final zero
    assert KEY_SELF_CAL in cal.results()


def test_injection_without_output_response_is_rejected() -> None:
    ladder = dataclasses.replace(SHORT_LADDER, silent_plateaus=(4,))
    cal = _calibrate(simulate_mapping_and_self_cal(mapping_hold_s=12.0, ladder=ladder,
                                                   table=TABLE))
    assert 'the output does not follow the injection' in _reasons(cal)
    assert len(cal.plateaus) == SHORT_LADDER.plateau_count  # one rejected, final zero in
    assert KEY_SELF_CAL in cal.results()


def test_saturating_staircase_rejects_plateaus_beyond_lock_and_keeps_the_linear_range() -> None:
    ladder = SelfCalLadder(plateau_count=63, plateau_s=1.5)
    cal = _calibrate(simulate_mapping_and_self_cal(mapping_hold_s=12.0, ladder=ladder,
                                                   table=TABLE))
    reasons = _reasons(cal)
    assert 'does not follow the injection' in reasons or 'did not hold' in reasons
    assert 'did not return to the same state' in reasons  # relocked on another fringe
    assert 55 <= len(cal.plateaus) < 63
    assert KEY_SELF_CAL in cal.results()


def test_plateau_while_the_table_turns_is_rejected(combined: FogRecording) -> None:
    shift = int(combined.injection_t_ns[0] - combined.table_t_ns[0]) - int(20e9)
    rec = dataclasses.replace(combined, injection_t_ns=combined.injection_t_ns - shift)
    cal = _calibrate(rec)
    assert 'self-calibration needs a static base' in _reasons(cal)


FOG_CORE_MODULES = (
    'gyro_calib.fog', 'gyro_calib.fog.calibrator', 'gyro_calib.fog.counts',
    'gyro_calib.fog.fits', 'gyro_calib.fog.plots', 'gyro_calib.fog.segments',
    'gyro_calib.fog.self_cal', 'gyro_calib.fog.settings', 'gyro_calib.fog.topics',
    'gyro_calib.fog.turntable', 'sim_nodes.fog', 'sim_nodes.fog.config',
    'sim_nodes.fog.equivalent', 'sim_nodes.fog.front_end', 'sim_nodes.fog.gyro',
    'sim_nodes.fog.loop', 'sim_nodes.fog.paper', 'sim_nodes.fog.scenarios',
    'sim_nodes.fog.sensing')


def test_fog_core_modules_import_without_ros_or_matplotlib() -> None:
    code = ("import importlib, sys\n"
            "for name in ('rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'):\n"
            "    sys.modules[name] = None\n"
            f"for module in {FOG_CORE_MODULES!r}:\n"
            "    importlib.import_module(module)\n"
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported eagerly'\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
