"""The committed FOG scenario bags calibrate offline.

The committed FOG scenario bags calibrate offline to their expected results, through the
shared front door (``calibrate_bags`` and ``gyro-calib calibrate``): truth within the stated
uncertainties (which may not exceed the predicted floor), counts, rejection reasons.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
from pathlib import Path

import pytest
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import bag_info
from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.fog.self_cal import SelfCalFit
from gyro_calib.fog.session import FogSession
from sim_nodes.fog.bag_scenarios import SCENARIOS

BAGS = Path(__file__).resolve().parents[1] / 'bags'

TRUTH_KEYS = {
    'fog_scale_factor_counts_per_rad': ('line_k_counts_per_rad', 'turntable_k_counts_per_rad'),
    'fog_bias_rad_s': ('bias_rad_s',),
    'fog_asymmetry_ppm': ('asymmetry_ppm',),
    'fog_nonlinearity_ppm': ('nonlinearity_ppm',),
    'fog_scale_factor_quadratic_s_per_rad': ('quadratic_seen_s_per_rad',),
    'fog_scale_factor_cubic_s2_per_rad2': ('cubic_seen_s2_per_rad2',),
    'fog_angle_random_walk_rad_per_sqrt_s': ('angle_random_walk_rad_sqrt_s',),
    'fog_mapping_scale_factor_counts_per_rad': ('mapping_counts_per_rad',),
    'fog_self_cal_scale_factor_counts_per_rad': ('self_cal_k_counts_per_rad',),
    'fog_self_cal_linear_range_rad_s': ('self_cal_linear_range_rad_s',),
    'fog_self_cal_small_signal_scale_factor_counts_per_rad': (
        'self_cal_small_signal_k_counts_per_rad',),
    'fog_self_cal_minus_turntable_scale_factor_counts_per_rad': (
        'self_cal_minus_turntable_counts_per_rad',),
}
"""Hand-off key → the truth keys it is checked against (the first one present)."""


def _expected(name: str) -> dict:
    return yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))


@functools.cache
def _session(name: str) -> FogSession:
    session = calibrate_bags([BAGS / name]).sessions['fog']
    assert isinstance(session, FogSession)
    return session


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_fog_bag_gives_expected_counts_and_rejection_reasons(name: str) -> None:
    exp, session = _expected(name), _session(name)
    cal = session.calibrator
    reasons = [r.reason for r in session.rejections()]
    assert len(cal.segments) == exp['segments']
    assert len(cal.plateaus) == exp['plateaus']
    assert len(reasons) == exp['rejections'], reasons
    for reason in exp.get('rejection_reasons', []):
        assert any(reason in r for r in reasons), (reason, reasons)
    assert set(exp['results']) <= set(session.results())
    for key, why in exp.get('missing_reasons', {}).items():
        assert why in session.missing()[key]


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_fog_bag_results_cover_the_truth_within_their_stated_uncertainty(name: str) -> None:
    exp, session = _expected(name), _session(name)
    truth, k = exp['truth'], exp['tolerance_sigma']
    checked = []
    for key, est in session.results().items():
        true_key = next((t for t in TRUTH_KEYS.get(key, ()) if t in truth), None)
        if true_key is None:
            continue
        assert math.isfinite(est.value) and est.std_uncertainty > 0, key
        assert abs(est.value - truth[true_key]) <= k * est.std_uncertainty, (
            key, est.value, truth[true_key], est.std_uncertainty)
        checked.append(key)
    assert set(exp['results']) <= set(checked) | {'fog_self_cal_nonlinearity_ppm'}
    for key, limit in exp['max_std'].items():  # no passing by an overstated uncertainty
        assert session.results()[key].std_uncertainty <= limit, key


@pytest.mark.parametrize('name', [n for n, s in SCENARIOS.items()
                                  if s.expected.get('linear_range_levels')])
def test_fog_bag_linear_range_holds_the_expected_injection_levels(name: str) -> None:
    exp, session = _expected(name), _session(name)
    fit = session.calibrator.fits().self_cal
    assert isinstance(fit, SelfCalFit) and fit.linear is not None
    step = exp['truth']['self_cal_step_counts_s']
    used = fit.plateaus[:fit.linear.plateaus]
    assert [round(p.injection_counts_s / step) for p in used] == exp['linear_range_levels']
    assert session.results()['fog_self_cal_nonlinearity_ppm'].value <= 100.0


def test_fog_bag_stores_its_scenario_and_bench_settings() -> None:
    scenario = bag_info(BAGS / 'fog_mapping_self_cal').scenario
    assert scenario['name'] == 'fog_mapping_self_cal'
    assert scenario['kind'] == 'fog_mapping_self_cal'
    assert scenario['bench']['latitude_deg'] == 45.75
    assert scenario['fog']['seed'] == 61 and scenario['fog_table']['output_rate_hz'] == 200.0
    assert len(scenario['fog_procedure']['mapping_rates_deg_s']) == 4


def test_cli_json_of_the_turntable_bag_has_the_issue_shape(capsys) -> None:
    assert gyro_calib_main(['calibrate', str(BAGS / 'fog_turntable'), '--json',
                            '--no-progress']) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    fog = doc['methods']['fog']
    assert set(doc['methods']) == {'fog'}
    assert isinstance(fog['rejections'], list)
    results = fog['results']
    for key in _expected('fog_turntable')['results']:
        assert set(results[key]) == {'value', 'std', 'n'}
        assert results[key]['n'] == 10
    session = _session('fog_turntable')
    k = session.results()['fog_scale_factor_counts_per_rad']
    assert results['fog_scale_factor_counts_per_rad']['value'] == k.value
    why = fog['missing']['fog_self_cal_scale_factor_counts_per_rad']
    assert 'no /fog/injection messages' in why
    assert 'K turntable (counts/rad)' in captured.err  # the human summary goes to stderr
    assert 'asymmetry (ppm)' in captured.err and 'bias (°/h)' in captured.err


def test_cli_plot_writes_the_two_fog_figures(tmp_path: Path, capsys) -> None:
    out = tmp_path / 'figs'
    assert gyro_calib_main(['calibrate', str(BAGS / 'fog_mapping_self_cal'), '--plot', str(out),
                            '--no-progress']) == 0
    text = capsys.readouterr().out
    names = sorted(p.name for p in out.iterdir())
    assert names == ['fog_self_cal_range.png', 'fog_turntable_nonlinearity.png']
    for name in names:
        assert (out / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
        assert f'figure written: {(out / name).resolve()}' in text
    assert '← linear range' in text and 'K self-cal (counts/rad)' in text


def test_cli_out_writes_the_fog_handoff_keys(tmp_path: Path, capsys) -> None:
    out = tmp_path / 'fog.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'fog_mapping_self_cal'), '--out', str(out),
                            '--gyro-id', 'FOG-7', '--no-progress']) == 0
    capsys.readouterr()
    record = yaml.safe_load(out.read_text())
    session = _session('fog_mapping_self_cal')
    for key, est in session.results().items():
        assert record['gyro'][key] == est.value and record['gyro'][key + '_std'] == \
            est.std_uncertainty
    assert record['gyro_id'] == 'FOG-7' and 'fog' in record['methods']
    # a mapping + self-cal bench cannot give the turntable terms: complete, and it says why
    assert record['complete'] is True and record['missing'] == {}
    assert 'both signs' in record['not_measurable']['fog_asymmetry_ppm']


def test_cli_info_lists_segments_mapping_plateaus_and_what_limits(capsys) -> None:
    assert gyro_calib_main(['info', str(BAGS / 'fog_mapping_self_cal')]) == 0
    text = capsys.readouterr().out
    assert 'constant-rate segments measured: 4' in text
    assert 'equivalence mapping: 4 segment(s) at 20, 20.01, 20.1, 21 °/s' in text
    assert 'injection plateaus accepted: 56' in text
    last = text.splitlines()[-1]
    assert last.startswith('limits the result: the self-calibrated K differs from the '
                           'turntable K')


def test_slow_loop_read_at_a_low_rate_is_measured_only_after_it_settled() -> None:
    """A slow loop read at a low rate is measured after it settles.

    fog_slow_loop_low_rate (loop τ ≈ 0.074 s at null, 50 Hz output, 4 s plateaus): after
    every injection step the calibration finds the transient in the data and measures the
    plateau from where the output had settled (a few τ on), still over most of the plateau;
    the ladder's K and its small-signal K then cover the truth within 2 stated σ.
    """
    exp, session = _expected('fog_slow_loop_low_rate'), _session('fog_slow_loop_low_rate')
    tau_s = exp['loop_time_constant_at_null_s']
    plateaus = sorted(session.calibrator.plateaus, key=lambda p: p.start_ns)
    assert len(plateaus) == exp['plateaus']
    for prev, plat in itertools.pairwise(plateaus):
        assert plat.injection_counts_s != prev.injection_counts_s  # a step before each
        waited_s = (plat.settled_ns - plat.start_ns) / 1e9
        assert waited_s >= 2.0 * tau_s, (plat.injection_counts_s, waited_s)  # settling seen
        assert plat.settled_s >= 0.5 * (plat.end_ns - plat.start_ns) / 1e9
    results, truth = session.results(), exp['truth']
    for key, true_key in (('fog_self_cal_scale_factor_counts_per_rad',
                           'self_cal_k_counts_per_rad'),
                          ('fog_self_cal_small_signal_scale_factor_counts_per_rad',
                           'self_cal_small_signal_k_counts_per_rad')):
        est = results[key]
        assert abs(est.value - truth[true_key]) <= 2.0 * est.std_uncertainty, (key, est)
