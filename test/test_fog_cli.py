"""The FOG through ``gyro-calib calibrate`` and ``info``.

The FOG through ``gyro-calib calibrate`` and ``info`` (issue 10 "Bad input"): each bad input
gets a clear reason, never a wrong number, and what was measured is kept; the summary speaks
a FOG laboratory's units.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from gyro_calib import topics
from gyro_calib.cli import main as gyro_calib_main
from sim_nodes.fog import SelfCalLadder, TableSettings, simulate_mapping_and_self_cal
from sim_nodes.fog.bag_scenarios import write_recording_bag
from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.scenarios import FogRecording, simulate_turntable

BAGS = Path(__file__).resolve().parents[1] / 'bags'
TABLE = TableSettings(output_rate_hz=200.0, lead_s=1.0, seed=3)
RATES = (5.0, -5.0, 20.0, -20.0, 40.0, -40.0)
K = 'fog_scale_factor_counts_per_rad'
SELF_CAL = 'fog_self_cal_scale_factor_counts_per_rad'
BENCH = {'bench': {'latitude_deg': FogConfig().latitude_deg}}


def _calibrate(bag: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[dict, str]:
    """Run ``gyro-calib calibrate BAG --json``; return the FOG section and the human summary."""
    assert gyro_calib_main(['calibrate', str(bag), '--json', '--no-progress', *extra]) == 0
    captured = capsys.readouterr()
    return json.loads(captured.out)['methods']['fog'], captured.err


def _limiting(bag: Path, capsys: pytest.CaptureFixture[str]) -> str:
    assert gyro_calib_main(['info', str(bag)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith('limits the result: ')
    return last


@pytest.fixture(scope='module')
def turntable() -> FogRecording:
    return simulate_turntable(FogConfig(seed=4), rates_deg_s=RATES, hold_s=12.0, table=TABLE)


@pytest.fixture(scope='module')
def clean_bag(turntable: FogRecording, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_recording_bag(turntable, tmp_path_factory.mktemp('fog') / 'clean',
                               scenario=BENCH)


@pytest.fixture(scope='module')
def ladder_without_mapping() -> FogRecording:
    """Turntable rates that are no mapping rates, then a ladder on the stopped table."""
    return simulate_mapping_and_self_cal(FogConfig(seed=8), mapping_rates_deg_s=(5.0, -5.0, 40.0),
                                         mapping_hold_s=12.0,
                                         ladder=SelfCalLadder(plateau_count=6, plateau_s=5.0),
                                         table=TABLE)


def test_cli_summary_quotes_a_fog_lab_units(clean_bag: Path, turntable: FogRecording,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    fog, text = _calibrate(clean_bag, capsys)
    k = fog['results'][K]
    rows = {line.split('  ')[0]: line.split() for line in text.splitlines()}
    per_deg = rows['K turntable ((counts/s)/(°/s))']
    assert float(per_deg[-3]) == pytest.approx(k['value'] * math.pi / 180, abs=1e-7)
    bias = fog['results']['fog_bias_rad_s']
    assert float(rows['bias (°/h)'][-3]) == pytest.approx(bias['value'] / (math.pi / 180)
                                                          * 3600, abs=1e-4)
    assert float(rows['ARW (°/√h)'][-3]) == pytest.approx(
        fog['results']['fog_angle_random_walk_rad_per_sqrt_s']['value'] * 180 / math.pi * 60,
        abs=1e-5)
    for label in ('K turntable (counts/rad)', 'nonlinearity (ppm)', 'asymmetry (ppm)',
                  'quadratic (ppm/(°/s))'):
        assert label in rows
    assert abs(k['value'] - turntable.truth['turntable_k_counts_per_rad']) < 5 * k['std']
    assert 'segments measured: 6 (in the turntable fit: 6, rejected: 0)' in text


def test_cli_without_mapping_phase_keeps_turntable_k_and_says_why_no_self_cal(
        ladder_without_mapping: FogRecording, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    bag = write_recording_bag(ladder_without_mapping, tmp_path / 'bag', scenario=BENCH)
    fog, text = _calibrate(bag, capsys)
    assert K in fog['results'] and SELF_CAL not in fog['results']
    assert 'no equivalence mapping' in fog['missing'][SELF_CAL]
    assert 'run the mapping rates on the turntable' in text
    truth = ladder_without_mapping.truth['turntable_k_counts_per_rad']
    assert abs(fog['results'][K]['value'] - truth) < 5 * fog['results'][K]['std']
    assert 'no equivalence mapping, so no self-calibrated K: run the table at the mapping ' \
           'rates (20, 20.01, 20.1, 21 °/s)' in _limiting(bag, capsys)


def test_cli_without_injection_topic_gives_turntable_results_and_a_line_for_self_cal(
        ladder_without_mapping: FogRecording, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """An unrecorded injection ladder is rejected, not fitted.

    The ladder ran but /fog/injection was not recorded: the static segment under it has a
    jumping output, which is rejected rather than fitted as a 0 °/s point.
    """
    bag = write_recording_bag(ladder_without_mapping, tmp_path / 'bag', scenario=BENCH,
                              omit=(topics.FOG_INJECTION,))
    fog, text = _calibrate(bag, capsys)
    assert 'no /fog/injection messages' in fog['missing'][SELF_CAL]
    assert any('segment at +0.0000 °/s' in r and 'not recorded on /fog/injection' in r
               for r in fog['rejections'])
    k, bias = fog['results'][K], fog['results']['fog_bias_rad_s']
    truth = ladder_without_mapping.truth
    assert k['n'] == 3
    assert abs(k['value'] - truth['turntable_k_counts_per_rad']) < 5 * k['std']
    assert abs(bias['value'] - truth['bias_rad_s']) < 5 * bias['std']
    assert 'K self-cal' not in text


def test_cli_rate_excursion_rejects_that_segment_and_keeps_the_others(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec = simulate_turntable(FogConfig(seed=9), rates_deg_s=(5.0, -5.0, 40.0, 20.0, 30.0, 20.0,
                                                             -40.0),
                             hold_s=(12.0, 12.0, 12.0, 12.0, 0.2, 12.0, 12.0), table=TABLE)
    bag = write_recording_bag(rec, tmp_path / 'bag', scenario=BENCH)
    fog, text = _calibrate(bag, capsys)
    assert any('rate excursion' in r and 'repeat this rate' in r for r in fog['rejections'])
    assert 'rate excursion' in text
    k = fog['results'][K]
    assert k['n'] == 4  # 5, −5, 40, −40 °/s
    assert abs(k['value'] - rec.truth['turntable_k_counts_per_rad']) < 5 * k['std']


def test_cli_non_finite_samples_are_dropped_counted_and_never_enter_a_result(
        turntable: FogRecording, clean_bag: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    counts = turntable.output_counts.copy()
    counts[np.arange(500, 15000, 700)] = np.nan
    counts[7777] = np.inf
    rate = turntable.table_rate_rad_s.copy()
    rate[[100, 900]] = np.nan
    bad = dataclasses.replace(turntable, output_counts=counts, table_rate_rad_s=rate)
    fog, text = _calibrate(write_recording_bag(bad, tmp_path / 'bag', scenario=BENCH), capsys)
    clean, _ = _calibrate(clean_bag, capsys)
    assert 'note: /fog/output: 22 non-finite sample(s) dropped' in text
    assert any('/rate_table/joint_states: 2 non-finite' in n for n in fog['notices'])
    k, k_clean = fog['results'][K], clean['results'][K]
    assert math.isfinite(k['value']) and k['n'] == 6
    assert abs(k['value'] - k_clean['value']) < k_clean['std']


def test_cli_duplicate_and_out_of_order_stamps_give_the_clean_numbers(
        turntable: FogRecording, clean_bag: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    t, c = turntable.output_t_ns.copy(), turntable.output_counts.copy()
    swap = np.arange(1000, 15000, 97)
    t[swap], t[swap + 1] = t[swap + 1].copy(), t[swap].copy()
    c[swap], c[swap + 1] = c[swap + 1].copy(), c[swap].copy()
    dup = np.arange(50, 15000, 333)
    t, c = np.insert(t, dup, t[dup]), np.insert(c, dup, c[dup])
    index = turntable.zero_index_ns
    bad = dataclasses.replace(turntable, output_t_ns=t, output_counts=c,
                              zero_index_ns=np.insert(index, [1], index[[1]]))
    fog, text = _calibrate(write_recording_bag(bad, tmp_path / 'bag', scenario=BENCH), capsys)
    clean, _ = _calibrate(clean_bag, capsys)
    assert fog['results'] == clean['results']  # bit for bit
    note = next(n for n in fog['notices'] if n.startswith('/fog/output'))
    assert 'duplicate-stamp' in note and 're-sorted out-of-order' in note
    assert 'note: /rate_table/zero_index: 1 duplicate-stamp' in text


def test_cli_plateau_too_short_to_settle_is_named_and_the_rest_kept(
        capsys: pytest.CaptureFixture[str]) -> None:
    fog, text = _calibrate(BAGS / 'fog_fault_short_plateau', capsys)
    assert 'shorter than the loop needs to settle' in text
    assert any('lasted 0.2 s' in r for r in fog['rejections'])
    assert SELF_CAL in fog['results'] and K in fog['results']


def test_cli_output_alone_calibrates_nothing_and_says_what_is_missing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec = simulate_turntable(FogConfig(seed=2), rates_deg_s=(), table=TABLE)
    bag = write_recording_bag(rec, tmp_path / 'bag', omit=(topics.RATE_TABLE_JOINT_STATES,
                                                            topics.RATE_TABLE_ZERO_INDEX))
    assert gyro_calib_main(['calibrate', str(bag), '--json', '--no-progress']) == 1
    captured = capsys.readouterr()
    fog = json.loads(captured.out)['methods']['fog']
    assert fog['results'] == {}
    assert '/rate_table/joint_states messages' in fog['missing'][K]
    assert 'nothing could be calibrated' in captured.err
