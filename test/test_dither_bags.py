"""The committed dither bags through the front door.

The committed dither bags through the front door: ``gyro-calib calibrate`` of the Z and Y bags
gives a, both components, θ_d and the coning drift within the expectations written beside
them; one orientation gives its component and says a needs the other; the fault bags give
their reasons and no number; ``--json``, ``--plot``, ``--out`` and ``info`` say what a bench
engineer needs (the floor and the record a target needs).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
import yaml

import gyro_calib
from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import ContractMessages, iter_sample_batches
from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.cli import summary_text
from gyro_calib.dither.calibrator import (
    KEY_A,
    KEY_AMPLITUDE,
    KEY_AMPLITUDE_PULSES,
    KEY_CONING,
    KEY_FREQUENCY,
    KEY_Y,
    KEY_Z,
)
from gyro_calib.dither.session import DitherSession
from gyro_calib.session import CalibrationOptions
from sim_nodes.dither.bag_scenarios import SCENARIOS, JointStateTemplate, simulate_scenario

BAGS = Path(__file__).resolve().parents[1] / 'bags'
ARCMIN = math.pi / 180 / 60


def _expected(name: str) -> dict[str, Any]:
    return yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))


K = _expected('dither_z')['truth']['scale_factor_rad_per_pulse']


def _cli(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = gyro_calib_main([*args, '--no-progress'] if args[0] == 'calibrate' else list(args))
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope='module')
def pair_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One CLI run of both orientations with K, --json, --plot and --out."""
    tmp = tmp_path_factory.mktemp('dither_pair')
    code, out, err = _cli('calibrate', str(BAGS / 'dither_z'), str(BAGS / 'dither_y'),
                          '--method', 'dither', '--scale-factor-rad-per-pulse', repr(K),
                          '--json', '--plot', str(tmp / 'plots'), '--out', str(tmp / 'gyro.yaml'))
    return {'code': code, 'doc': json.loads(out), 'human': err, 'dir': tmp}


def test_both_orientations_give_a_components_theta_d_and_coning_within_expectations(
        pair_run: dict[str, Any]) -> None:
    assert pair_run['code'] == 0, pair_run['human']
    dither = pair_run['doc']['methods']['dither']
    res, exp = dither['results'], _expected('dither_z')
    truth, tol = exp['truth'], exp['tolerance']
    assert dither['rejections'] == [] and dither['missing'] == {}
    for axis in ('z', 'y'):
        comp = dither['components'][axis]
        assert comp['n_blocks'] == _expected(f'dither_{axis}')['blocks_accepted']
        # what the output carries (the misalignment shifted by the in-phase rocking): at the floor
        assert abs(comp['signed_rad'] - truth[f'effective_{axis}_rad']) \
            < tol['effective_component_rad']
        assert 0.8 < comp['statistical_std_rad'] / exp['predicted']['floor_rad'] < 1.5
        key = KEY_Z if axis == 'z' else KEY_Y
        assert abs(res[key]['value'] - truth[f'misalignment_{axis}_rad']) < tol['component_rad']
        assert abs(res[key]['value'] - truth[f'misalignment_{axis}_rad']) < 2 * res[key]['std']
    a = res[KEY_A]
    assert abs(a['value'] - truth['misalignment_rad']) < tol['misalignment_rad']
    assert abs(a['value'] - truth['misalignment_rad']) < 2 * a['std']  # the stated u covers it
    assert a['n'] == 40
    theta_d = res[KEY_AMPLITUDE]
    assert abs(theta_d['value'] / truth['dither_amplitude_rad'] - 1) \
        < tol['dither_amplitude_relative']
    assert abs(res[KEY_FREQUENCY]['value'] - truth['dither_frequency_hz']) \
        < tol['dither_frequency_hz']
    eps = res[KEY_CONING]
    assert abs(eps['value'] - truth['coning_eq24_worst_case_rad_s']) < tol['coning_eq24_rad_s']
    assert abs(eps['value'] - truth['coning_eq24_worst_case_rad_s']) < 2 * eps['std']
    verdict = dither['verdict']
    assert verdict['decided'] and verdict['accepted'] is False
    assert exp['with_pair']['verdict'] == 'reject' and 'reject' in verdict['sentence']


def test_human_summary_gives_the_paper_units_and_the_floor_beside_each_figure(
        pair_run: dict[str, Any]) -> None:
    text = pair_run['human']
    for label in ('a (′)', 'a·|sin ψ₀|, table along Z (′)', 'a·|cos ψ₀|, table along Y (′)',
                  'θ_d (′)', 'f_d (Hz)', 'ε eq. (24) (°/h)'):
        assert label in text
    lines = text.splitlines()
    for head in ('table along Z: a·|sin ψ₀| =', 'table along Y: a·|cos ψ₀| =', 'a = '):
        line = next(x for x in lines if x.startswith(head))
        assert 'floor' in line, line
    assert any('(k = 2, rocking allowance included): above the 5′ limit: reject.' in x
               for x in lines)
    assert 'K given: K = 1″/pulse' in text


def test_json_document_has_results_components_floor_and_verdict(
        pair_run: dict[str, Any]) -> None:
    dither = pair_run['doc']['methods']['dither']
    assert set(dither) >= {'results', 'missing', 'rejections', 'components', 'misalignment',
                           'verdict', 'scale_factor'}
    for key, value in dither['results'].items():
        if key in (KEY_A, KEY_Z, KEY_Y):  # its parts beside the combined std (issue 16)
            assert set(value) == {'value', 'std', 'n', 'std_statistical', 'systematic_bound',
                                  'systematic_model', 'interval', 'coverage_factor'}
            assert value['std'] == pytest.approx(math.hypot(
                value['std_statistical'], value['systematic_bound'] / math.sqrt(3)))
            assert 'rocking' in value['systematic_model']
            low, high = value['interval']
            assert low < value['value'] < high
        else:
            assert set(value) == {'value', 'std', 'n'}
    verdict = dither['verdict']
    assert verdict['state'] == 'reject' and verdict['lower_rad'] > verdict['limit_rad']
    schema = json.loads((Path(gyro_calib.__file__).parent / 'schema' / 'result.schema.json')
                        .read_text(encoding='utf-8'))
    jsonschema.validate(pair_run['doc'], schema)  # the parts are in the shipped schema
    for comp in dither['components'].values():
        assert comp['reported'] is True and comp['floor_rad'] > 0
    assert dither['misalignment']['floor_rad'] > 0
    assert dither['scale_factor']['rad_per_pulse'] == K


def test_plot_writes_spectra_residuals_and_coning_figures(pair_run: dict[str, Any]) -> None:
    plots = pair_run['dir'] / 'plots'
    names = {p.name for p in plots.iterdir()}
    assert names == {'dither_spectrum_z.png', 'dither_spectrum_y.png', 'dither_residuals_z.png',
                     'dither_residuals_y.png', 'dither_coning.png'}
    for name in names:
        assert (plots / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert 'figure written:' in pair_run['human']


def test_handoff_holds_every_dither_key_with_its_uncertainty(pair_run: dict[str, Any]) -> None:
    record = yaml.safe_load((pair_run['dir'] / 'gyro.yaml').read_text())
    res = pair_run['doc']['methods']['dither']['results']
    assert record['complete'] is True
    for key, value in res.items():
        assert record['gyro'][key] == value['value'] and record['gyro'][key + '_std'] == \
            value['std']
    assert record['methods']['dither']['source'].endswith('dither_y')


def test_one_orientation_gives_its_component_and_says_a_needs_the_other() -> None:
    outcome = calibrate_bags([BAGS / 'dither_z'])  # what `gyro-calib calibrate` prints
    out = summary_text(outcome)
    lines = out.splitlines()
    assert next(x for x in lines if x.startswith('a (′)')).split()[2] == '—'
    assert 'table along Z: a·|sin ψ₀| =' in out
    assert 'dither_axis_misalignment_rad: not measured — a = √(z² + y²) needs both' in out
    assert 'θ_d (pulses; no K given)' in out and 'no scale factor K given' in out
    assert 'NOT bounded' in out  # without K the rocking cannot be bounded: it says so
    session = outcome.sessions['dither']
    # the component is measured and shown; its uncertainty is unbounded (no K, one
    # orientation), so the hand-off leaves it out and says why
    assert set(session.results()) == {KEY_FREQUENCY, KEY_AMPLITUDE_PULSES}
    z = session.json_section()['results'][KEY_Z]
    assert z['std'] is None and z['systematic_bound'] is None and z['std_statistical'] > 0
    assert 'its uncertainty is unbounded' in session.missing()[KEY_Z]
    assert next(x for x in lines if x.startswith('a·|sin ψ₀|')).split()[-2] == 'unbounded'
    exp = _expected('dither_z')
    assert abs(z['value'] - abs(exp['truth']['effective_z_rad'])) \
        < exp['tolerance']['effective_component_rad']


def test_stripped_output_is_refused_with_its_reason_and_no_number() -> None:
    exp = _expected('dither_stripped')
    code, out, err = _cli('calibrate', str(BAGS / 'dither_stripped'))
    assert code == 1 and 'nothing could be calibrated' in err
    session = calibrate_bags([BAGS / 'dither_stripped']).sessions['dither']
    assert session.results() == {}
    assert len(session.rejections()) == exp['rejections']
    for reason in exp['rejection_reasons']:
        assert all(reason in r.reason for r in session.rejections()), reason
    assert 'dither-stripped' in session.limiting()


def test_table_too_small_for_the_floor_reports_the_component_with_what_would_do() -> None:
    exp = _expected('dither_small_table')
    session = calibrate_bags([BAGS / 'dither_small_table'],
                             options=CalibrationOptions(scale_factor_rad_per_pulse=K)
                             ).sessions['dither']
    assert isinstance(session, DitherSession)
    res = session.results()
    assert KEY_FREQUENCY in res and KEY_AMPLITUDE in res  # what it did measure is kept
    z = session.json_section()['results'][KEY_Z]  # measured: reported with its interval
    assert z['interval'][0] == 0.0 and z['std_statistical'] > 0
    why = session.calibrator.summary().unresolved['z']
    for reason in exp['unresolved_reasons']:
        assert reason in why
    assert 'or record' in why
    assert session.calibrator.orientations['z'].equations.n_blocks == exp['blocks_accepted']
    assert session.limiting() == why


def test_info_prints_the_floor_and_the_record_a_target_needs() -> None:
    code, out, _ = _cli('info', str(BAGS / 'dither_z'), str(BAGS / 'dither_y'),
                        '--scale-factor-rad-per-pulse', repr(K))
    assert code == 0
    exp = _expected('dither_z')
    floor_arcmin = exp['predicted']['floor_rad'] / ARCMIN
    assert f'detection floor of this record: σ_c = {floor_arcmin:.2f}′' in out
    assert 'target σ per component: 1.25′ (half the 5′ limit at k = 2)' in out
    assert 'for σ_c = 1.25′: record ' in out and 'or sample at ' in out and 'or A ≥ ' in out
    # σ ∝ 1/√T: the record a target needs is (σ_c/target)² times this one
    need = (floor_arcmin / 1.25) ** 2 * 40.0
    assert f'record {need:.0f} s in this orientation' in out or \
        f'record {need / 60:.0f} min in this orientation' in out
    assert out.rstrip().splitlines()[-1].startswith('limits the result: the rocking allowance')


def test_info_of_a_small_table_names_the_amplitude_that_would_do() -> None:
    code, out, _ = _cli('info', str(BAGS / 'dither_small_table'))
    assert code == 0
    assert 'detection floor of this record: σ_c = ' in out and 'or A ≥ ' in out
    assert 'cannot be told from zero' in out and 'table rate amplitude 1 rad/s' in out


@pytest.mark.parametrize('name', ['dither_y', 'dither_stripped'])
def test_bag_holds_exactly_what_the_simulator_published(name: str) -> None:
    rec = simulate_scenario(SCENARIOS[name])
    batches = list(iter_sample_batches(BAGS / name, batch_messages=10**9))
    assert len(batches) == 1
    pulses = batches[0].joint_state(topics.GYRO_PULSES)
    table = batches[0].columns[topics.VIBRATION_TABLE_JOINT_STATES]
    assert pulses is not None
    np.testing.assert_array_equal(pulses[0], rec.pulse_t_ns)
    np.testing.assert_array_equal(pulses[1], rec.pulse_counts)
    np.testing.assert_array_equal(table.stamp_ns, rec.table_t_ns)
    np.testing.assert_array_equal(table.values['position'], rec.table_angle_rad)
    np.testing.assert_array_equal(table.values['velocity'], rec.table_rate_rad_s)
    assert set(table.frame_id.strings()) == {SCENARIOS[name].orientation}


@pytest.mark.parametrize('t_ns', [0, 999_999_999, 1_795_465_583_667_527_917])
@pytest.mark.parametrize('value', [0.0, -123456.0, 1e300, -0.0])
def test_fast_message_template_is_byte_for_byte_rosbags_serialisation(t_ns: int,
                                                                      value: float) -> None:
    pulses = JointStateTemplate(topics.GYRO_JOINT, topics.GYRO_JOINT, velocity=False)
    assert pulses.cdr(t_ns, value) == ContractMessages().joint_state(t_ns, topics.GYRO_JOINT,
                                                                     value)
    table = JointStateTemplate(topics.VIBRATION_TABLE_JOINT, 'y', velocity=True)
    sec, nsec = divmod(t_ns, 10**9)
    assert table.cdr(t_ns, value, -value / 3) == table.serialise(sec, nsec, value, -value / 3)


def test_issue_16_bench_reports_a_with_its_interval_and_rejects_from_it() -> None:
    """Issue 16's bench: a with its interval, rejected.

    Issue 16's bench (a = 53′, 6.2 rad/s at 8.7 Hz, no rocking, 30 s per orientation): a, both
    components and the coning drift are reported with their intervals, however wide, and the
    verdict is reject because the interval's lower end is above the 5′ limit.
    """
    exp = _expected('dither_53arcmin_z')
    truth = exp['truth']
    session = calibrate_bags(
        [BAGS / 'dither_53arcmin_z', BAGS / 'dither_53arcmin_y'],
        options=CalibrationOptions(scale_factor_rad_per_pulse=truth['scale_factor_rad_per_pulse'])
    ).sessions['dither']
    assert isinstance(session, DitherSession)
    doc = session.json_section()
    res = doc['results']
    assert doc['rejections'] == [] and doc['missing'] == {}
    for key in (KEY_A, KEY_Z, KEY_Y, KEY_CONING):
        assert key in session.results(), key  # nothing measured is withheld
    for axis in ('z', 'y'):
        assert session.calibrator.orientations[axis].equations.n_blocks == \
            _expected(f'dither_53arcmin_{axis}')['blocks_accepted']
        key = KEY_Z if axis == 'z' else KEY_Y
        assert abs(res[key]['value'] - truth[f'misalignment_{axis}_rad']) \
            < exp['tolerance']['component_rad']
    a = res[KEY_A]
    low, high = a['interval']
    assert low < truth['misalignment_rad'] < high
    assert abs(a['value'] - truth['misalignment_rad']) < 2 * a['std']
    verdict = doc['verdict']
    assert exp['with_pair']['verdict'] == 'reject'
    assert verdict['state'] == 'reject' and verdict['lower_rad'] > verdict['limit_rad']
    assert verdict['limit_rad'] == pytest.approx(5 * ARCMIN)
    assert verdict['lower_rad'] == pytest.approx(low)
