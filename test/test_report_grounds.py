"""No verdict without grounds, and the 95 % the certificate claims (issue 25 §1, §2).

Each test is a mistake a new user makes, or a number a reader checks, on the committed
K̃ bench (3 window pairs: ν = 2, k₉₅ = t₀.₉₇₅(2) = 4.303):

* a spec naming a quantity the hand-off does not know (``bias_rad_sec``) or a unit the
  quantity cannot be given in is refused, naming the nearest key — in ``report`` and
  ``batch``, before any work;
* a hand-off with nothing measured is refused; a spec quantity that was not measured makes the
  unit's verdict NO VERDICT, never PASS;
* a hand-off value (or u) the given bags contradict is refused, naming it and by how many
  u, unless ``--accept-handoff-values``;
* from the hand-off alone k is Student t at the ν the file states (``<key>_dof``), the same
  k as with the bags; a file without ``_dof`` gets k = 2 with the reason in the row;
* the dither misalignment is quoted with its method's asymmetric interval and judged by it;
* ν never exceeds n − 1 and prints as '> 1000' / '∞' where k no longer changes;
* K̃'s u reads 3.4e-9 ″/pulse (and 0.0040 ppm), data spans read as UTC times.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import pytest
import scipy.stats
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.cli import main
from gyro_calib.errors import ConfigError
from gyro_calib.estimate import Estimate
from gyro_calib.handoff import (
    Calibration,
    HandoffError,
    Provenance,
    calibration_from_yaml_dict,
    calibration_to_yaml_dict,
    load_calibration,
    write_calibration,
)
from gyro_calib.registry import handoff_schema
from gyro_calib.report.certificate import build_certificate, render_html
from gyro_calib.report.spec import CONDITIONAL, FAIL, PASS, spec_from_dict
from gyro_calib.report.uncertainty import BudgetLine, expanded_uncertainty, format_dof
from gyro_calib.report.units import user_unit
from gyro_calib.session import CalibrationOptions

BAGS = Path(__file__).resolve().parent.parent / 'bags'
K_TILDE = 'k_tilde_rad_per_pulse'
ARCMIN = user_unit('dither_axis_misalignment_rad').factor  # ′ per rad


@functools.cache
def _k_tilde_bench() -> Calibration:
    """The hand-off record of the committed K̃ bench (3 window pairs), as calibrate makes it."""
    outcome = calibrate_bags([BAGS / 'k_tilde_bench'],
                             options=CalibrationOptions(gyro_id='K-1'))
    record = outcome.sessions['rbrlg'].handoff(outcome.source, gyro_id='K-1')
    assert record is not None
    return record


def _one_line_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    assert len(captured.err.strip().splitlines()) == 1, captured.err
    return captured.err


# --- §1 No verdict without grounds ---------------------------------------------------------


@pytest.mark.parametrize('command', ['report', 'batch'])
def test_a_spec_quantity_the_hand_off_does_not_know_is_refused_naming_the_nearest(
        command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / 'spec.yaml'
    spec.write_text('quantities:\n  k_tilde_rad_per_pulse: {max: 1.0}\n'
                    '  bias_rad_sec: {unit: °/h, max: 0.001}\n', encoding='utf-8')
    out = tmp_path / 'out'
    if command == 'report':
        handoff = write_calibration(tmp_path / 'h.yaml', _k_tilde_bench())
        argv = ['report', str(handoff), '--spec', str(spec), '--out', str(out)]
    else:
        manifest = tmp_path / 'fleet.yaml'
        manifest.write_text(yaml.safe_dump({'gyros': [
            {'id': 'K-1', 'bags': [str(BAGS / 'k_tilde_bench')]}]}), encoding='utf-8')
        argv = ['batch', str(manifest), '--spec', str(spec), '--out', str(out)]
    err = _one_line_exit_2(argv, capsys)
    assert 'bias_rad_sec' in err and 'did you mean bias_rad_s?' in err
    assert not out.exists()


@pytest.mark.parametrize('quantities, named', [
    ({'bias_rad_sec': {'max': 1.0}}, 'bias_rad_s'),              # misspelt
    ({'window_pairs': {'min': 3}}, 'window_pairs'),              # a count: nothing to judge
    ({'bias_rad_s': {'unit': '″/pulse', 'max': 1.0}}, '°/h'),    # a unit it cannot be in
    ({'fog_nonlinearity_ppm': {'unit': '°/h', 'max': 1.0}}, 'ppm'),
])
def test_spec_refusals_name_what_to_write_instead(quantities: dict[str, object],
                                                  named: str) -> None:
    with pytest.raises(ConfigError) as info:
        spec_from_dict({'quantities': quantities}, source='s.yaml')
    assert named in str(info.value) and 's.yaml' in str(info.value)


def test_a_hand_off_with_nothing_measured_gets_no_certificate(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    handoff = tmp_path / 'empty.yaml'
    handoff.write_text('format_version: 3\ngyro_id: E-1\ngyro: {}\nmethods: {}\n',
                       encoding='utf-8')
    spec = tmp_path / 'spec.yaml'
    spec.write_text('quantities:\n  bias_rad_s: {max: 0.001}\n', encoding='utf-8')
    out = tmp_path / 'out'
    err = _one_line_exit_2(['report', str(handoff), '--spec', str(spec), '--out', str(out)],
                           capsys)
    assert 'no measured value' in err
    assert not out.exists()


def test_a_spec_quantity_not_measured_makes_the_unit_no_verdict_never_pass() -> None:
    record = _k_tilde_bench()
    k = record.values[K_TILDE] * user_unit(K_TILDE).factor
    passing = {K_TILDE: {'min': k - 1e-6, 'max': k + 1e-6}}
    cert = build_certificate(record, None, spec_from_dict({'quantities': passing}))
    assert cert.overall == PASS  # the ground: K̃ ± 2u well inside
    # θ: the rbrlg ran on a plain rate table and could not measure it
    spec = spec_from_dict({'quantities': {**passing, 'fix_error_angle_rad': {'max': 30.0}}})
    cert = build_certificate(record, None, spec)
    assert cert.overall == 'NO VERDICT (not measured: fix_error_angle_rad)'
    assert 'θ needs the position-table stations' in cert.spec_missing[0]  # and why
    assert ('<span class="overall verdict NOVERDICT" id="overall">NO VERDICT (not measured: '
            'fix_error_angle_rad)</span>') in render_html(cert)
    # the only quantity of the spec is of a method that did not run: nothing was judged
    cert = build_certificate(record, None, spec_from_dict({'quantities': {
        'fog_nonlinearity_ppm': {'max': 20.0}}}))
    assert cert.overall.startswith('NO VERDICT')
    # a FAIL stands on its own ground
    failing = {K_TILDE: {'max': k - 1e-6}, 'fix_error_angle_rad': {'max': 30.0}}
    assert build_certificate(record, None, spec_from_dict({'quantities': failing})).overall == FAIL


@pytest.mark.parametrize('edit', ['value 10x', 'u / 10'])
def test_a_hand_off_value_the_bags_contradict_is_refused_unless_accepted(
        edit: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    record = _k_tilde_bench()
    values = dict(record.values)
    if edit == 'value 10x':
        values[K_TILDE] *= 10.0
    else:
        values[K_TILDE + '_std'] /= 10.0
    handoff = write_calibration(tmp_path / 'edited.yaml', dataclasses.replace(record,
                                                                              values=values))
    out = tmp_path / 'out'
    argv = ['report', str(handoff), str(BAGS / 'k_tilde_bench'), '--out', str(out), '--no-pdf']
    err = _one_line_exit_2(argv, capsys)
    assert K_TILDE in err and '--accept-handoff-values' in err
    if edit == 'value 10x':  # 9·K̃ / u ≈ 5e8 standard uncertainties
        z = 9.0 * record.values[K_TILDE] / math.hypot(values[K_TILDE + '_std'],
                                                      record.values[K_TILDE + '_std'])
        assert f'{z:.3g} combined standard uncertainties' in err
    else:
        assert '0.1 times theirs' in err
    assert not out.exists()
    assert main([*argv, '--accept-handoff-values']) == 0
    capsys.readouterr()
    html = (out / 'K-1.html').read_text(encoding='utf-8')
    assert '--accept-handoff-values' in html and 'but the bags give' in html


# --- §2 The 95 % the page claims -------------------------------------------------------------


def test_k_from_the_hand_off_alone_is_student_t_at_the_dof_it_records(tmp_path: Path) -> None:
    path = write_calibration(tmp_path / 'h.yaml', _k_tilde_bench())
    data = yaml.safe_load(path.read_text(encoding='utf-8'))
    assert data['gyro'][K_TILDE + '_dof'] == 2  # 3 window pairs
    k95 = float(scipy.stats.t.ppf(0.975, 2))
    row = next(r for r in build_certificate(load_calibration(path), None).rows
               if r.key == K_TILDE)
    assert row.dof == '2' and row.dof_value == 2 and row.k == f'{k95:.2f}' == '4.30'
    assert row.expanded_si == pytest.approx(k95 * data['gyro'][K_TILDE + '_std'])
    # a file written before ν was recorded still loads: k = 2, and the row says why
    old = {k: v for k, v in data['gyro'].items() if not k.endswith('_dof')}
    cal = calibration_from_yaml_dict({**data, 'gyro': old}, schema=handoff_schema())
    row = next(r for r in build_certificate(cal, None).rows if r.key == K_TILDE)
    assert row.k == '2.00' and 'k = 2 assumed' in row.note
    assert 'k = 2 assumed: the hand-off file states no degrees of freedom' in render_html(
        build_certificate(cal, None))


@pytest.mark.parametrize('bad', [-1, 'two', None])
def test_hand_off_dof_is_checked_and_travels_with_its_value(bad: object) -> None:
    data = dict(calibration_to_yaml_dict(_k_tilde_bench()))
    gyro = {**data['gyro'], K_TILDE + '_dof': bad}
    with pytest.raises(HandoffError, match=f'{K_TILDE}_dof'):
        calibration_from_yaml_dict({**data, 'gyro': gyro}, schema=handoff_schema())
    orphan = {k: v for k, v in data['gyro'].items() if k not in (K_TILDE, K_TILDE + '_std')}
    with pytest.raises(HandoffError, match=f'{K_TILDE}_dof'):
        calibration_from_yaml_dict({**data, 'gyro': orphan}, schema=handoff_schema())
    inf = calibration_from_yaml_dict({**data, 'gyro': {**data['gyro'], K_TILDE + '_dof':
                                                       math.inf}}, schema=handoff_schema())
    assert next(r for r in build_certificate(inf, None).rows if r.key == K_TILDE).dof == '∞'
    record = _k_tilde_bench()
    newer = dataclasses.replace(record, values={**record.values, K_TILDE + '_dof': 7})
    merged = newer.merged_into(record, handoff_schema(), replace=True)
    assert merged.values[K_TILDE + '_dof'] == 7


def test_dither_misalignment_is_quoted_and_judged_with_its_method_interval() -> None:
    """53′ with u = 19.5′: ±2u gives 14 … 92′, the method's interval is 34.2 … 95.7′."""
    a, u, lower, upper = 53.0, 19.5, 34.2, 95.7
    values = {'dither_axis_misalignment_rad': a / ARCMIN,
              'dither_axis_misalignment_rad_std': u / ARCMIN,
              'dither_axis_misalignment_rad_dof': 39,
              'dither_axis_misalignment_lower_rad': lower / ARCMIN,
              'dither_axis_misalignment_upper_rad': upper / ARCMIN}
    cal = Calibration(values, {'dither': Provenance('generated', 0, 1)}, 'D-1')
    for limits, expected in (({'max': 94.0}, CONDITIONAL), ({'max': 100.0}, PASS),
                             ({'min': 96.0}, FAIL), ({'max': 30.0}, FAIL)):
        spec = spec_from_dict({'quantities': {'dither_axis_misalignment_rad': limits}})
        row = next(r for r in build_certificate(cal, None, spec).rows
                   if r.key == 'dither_axis_misalignment_rad')
        assert row.expanded == '[34.2, 95.7]' and row.verdict == expected, limits
    assert "the method's own interval" in row.note and row.k == '—'
    unbounded = {k: v for k, v in values.items() if 'upper' not in k}
    row = next(r for r in build_certificate(dataclasses.replace(cal, values=unbounded),
                                            None).rows if r.key == 'dither_axis_misalignment_rad')
    assert row.expanded == '[34.2, ∞]'


def test_dof_never_exceeds_what_the_data_support_and_always_fits_its_cell() -> None:
    # 40 blocks; the sideband fits state 79 822 dof; a Type B allowance taken as exact
    budget = (BudgetLine('statistical', 2.0, 79_822.0), BudgetLine('rocking', 5.0, math.inf))
    assert expanded_uncertainty(5.4, budget).dof > 1e5  # Welch–Satterthwaite alone
    capped = expanded_uncertainty(5.4, budget, 40)
    assert capped.dof == 39 and 'n − 1 = 39' in capped.note
    assert capped.k == pytest.approx(scipy.stats.t.ppf(0.975, 39), abs=1e-4)
    est = Estimate(1.0, 0.1, n_used=40, dof=79_822)
    assert est.supported_dof == 39 and Estimate(1.0, 0.1, 139_000, 5).supported_dof == 5
    assert [format_dof(x) for x in (2, 3.4, 39, 999.6, 79_822, 2.22e8, math.inf, None)] == [
        '2', '3.4', '39', '1000', '> 1000', '> 1000', '∞', '—']
    # beyond 1000 the printed k no longer moves
    assert f'{scipy.stats.t.ppf(0.975, 1001):.2f}' == f'{scipy.stats.norm.ppf(0.975):.2f}'


def test_numbers_read_in_the_unit_a_reader_checks() -> None:
    record = _k_tilde_bench()
    cert = build_certificate(record, None)
    row = next(r for r in cert.rows if r.key == K_TILDE)
    assert row.value == '0.8427948012' and row.unit == '″/pulse'
    assert row.std == '3.4e-9' and row.std_relative == '0.0040 ppm'
    assert row.expanded == '1.45e-8'  # 4.30 × 3.37e-9
    noise = Calibration({'angle_random_walk_rad_per_sqrt_s': 8.5e-7,
                         'angle_random_walk_rad_per_sqrt_s_std': 2.0e-8},
                        {'noise': Provenance('bags/n', 1_767_225_600_000_000_000,
                                             1_767_225_879_998_000_000)}, 'N-1')
    span = build_certificate(noise, None).methods[0].span
    assert span == '2026-01-01 00:00:00.000 → 00:04:39.998 UTC (279.998 s)'
    html = render_html(build_certificate(noise, None))
    assert '1767225600' not in html


def test_a_spec_that_lists_no_quantity_or_misspells_a_field_is_refused(tmp_path: Path) -> None:
    """A spec that lists no quantity, or misspells a field, is refused with a hint.

    The README walk: ``quantities: {}`` gave a certificate saying NO VERDICT; a typo gave no
    hint.
    """
    from gyro_calib.errors import ConfigError
    from gyro_calib.report.spec import load_spec

    empty = tmp_path / 'empty_spec.yaml'
    empty.write_text('quantities: {}\n')
    with pytest.raises(ConfigError, match='lists no quantities.*leave --spec out'):
        load_spec(empty)
    typo = tmp_path / 'typo_spec.yaml'
    typo.write_text('decison_rule: simple\nquantities: {k_tilde_rad_per_pulse: {min: 0}}\n')
    with pytest.raises(ConfigError, match='did you mean decision_rule for decison_rule'):
        load_spec(typo)
