"""A hand-off file never merges values that rest on another scale factor silently.

Dither (θ_d, the angles) and noise (terms in rad) turn the gyro's output into rad with a
scale factor K (a FOG: counts/rad) given by a flag, ``--calibration FILE`` or the bench
settings stored with the bag. Each run states it in its ``conditions`` with where it came
from; merged beside a file whose K (``scale_factor_rad_per_pulse``, else
``k_tilde_rad_per_pulse``; ``fog_scale_factor_counts_per_rad``) differs, the run is refused
when the difference would move any of its K-based values by more than 1/5 of its standard
uncertainty (either side new), else merged with a line giving the ppm and the shift.

The committed bags: k_tilde_bench (K̃ = 4.085984e-06 rad/pulse), dither_z + dither_y (no K
stored: θ_d in rad needs one; its std is 1.2e-4 of it, so 24 ppm is its 1/5 σ), and
noise_rlg_static (K = 4.0860157e-06 stored, 7.6 ppm from that K̃; Q known to 0.74 %).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.handoff import (
    Calibration,
    HandoffError,
    Provenance,
    load_calibration,
    method_calibration,
    update_calibration,
)

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
BAGS = Path(__file__).resolve().parents[1] / 'bags'
DITHER = (str(BAGS / 'dither_z'), str(BAGS / 'dither_y'))
K_DITHER_BENCH = 4.84813681109536e-06
"""1″/pulse: the dither simulator's K, 16 % from k_tilde_bench's K̃ (another gyro's K)."""


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = gyro_calib_main(['calibrate', *args, '--no-progress'])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def k_tilde_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    """A file holding the rbrlg run of k_tilde_bench (its K̃)."""
    path = tmp_path / 'A-1.yaml'
    assert _cli(capsys, str(BAGS / 'k_tilde_bench'), '--out', str(path))[0] == 0
    return path


def _refused_in_one_line(code: int, out: str, err: str) -> str:
    assert code == 2 and out == ''
    assert err.count('\n') == 1 and err.startswith('gyro-calib: error: ')
    return err


def test_a_dither_run_with_another_k_is_refused_and_the_file_is_unchanged(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = k_tilde_file.read_bytes()
    err = _refused_in_one_line(*_cli(capsys, *DITHER, '--scale-factor-rad-per-pulse',
                                     repr(K_DITHER_BENCH), '--out', str(k_tilde_file)))
    assert k_tilde_file.read_bytes() == before
    assert (f'rests on scale_factor_rad_per_pulse = {K_DITHER_BENCH!r} rad/pulse '
            '(--scale-factor-rad-per-pulse)') in err
    assert "the file's k_tilde_rad_per_pulse = 4.0859" in err and 'k_tilde_bench' in err
    assert 'differs from it by 157205 ppm' in err
    assert 'would move its dither_amplitude_rad by' in err and '(more than 0.2)' in err
    assert '--calibration FILE' in err and 'another --out' in err


def test_a_dither_run_with_k_within_tolerance_is_merged_with_a_line_and_its_conditions(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _cli(capsys, *DITHER, '--scale-factor-rad-per-pulse', '4.086e-06',
                        '--out', str(k_tilde_file))
    assert code == 0
    lines = [line.strip() for line in out.splitlines() if 'scale factor: ' in line]
    assert len(lines) == 1
    assert lines[0].startswith('scale factor: the dither run ')
    assert 'differs from it by 3.79 ppm' in lines[0]
    shift = float(lines[0].split('at most ')[1].split(' of their')[0])
    assert 0.02 < shift < 0.05  # 3.79e-6·θ_d / u(θ_d) = 3.79e-6 / 1.19e-4
    data = yaml.safe_load(k_tilde_file.read_text())
    assert data['methods']['dither']['conditions'] == {
        'scale_factor_rad_per_pulse': 4.086e-06,
        'scale_factor_from': '--scale-factor-rad-per-pulse'}
    assert 'dither_amplitude_rad' in data['gyro']


def test_a_dither_run_taking_the_files_k_states_it_and_needs_no_line(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _cli(capsys, *DITHER, '--calibration', str(k_tilde_file),
                        '--out', str(k_tilde_file))
    assert code == 0 and 'scale factor: ' not in out
    written = load_calibration(k_tilde_file)
    conditions = written.methods['dither'].conditions
    assert conditions['scale_factor_rad_per_pulse'] == written.get('k_tilde_rad_per_pulse')
    assert conditions['scale_factor_from'] == f'k_tilde_rad_per_pulse in {k_tilde_file}'


def test_a_dither_run_without_k_states_no_scale_factor(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, *DITHER, '--out', str(path))[0] == 0
    data = yaml.safe_load(path.read_text())
    assert data['methods']['dither']['conditions'] == {}
    assert 'dither_amplitude_pulses' in data['gyro']


def test_a_new_k_beside_a_dither_run_resting_on_another_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The other direction: the file's dither run rests on K1, a new rbrlg run brings K2."""
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, *DITHER, '--scale-factor-rad-per-pulse', repr(K_DITHER_BENCH),
                '--out', str(path))[0] == 0
    before = path.read_bytes()
    err = _refused_in_one_line(*_cli(capsys, str(BAGS / 'k_tilde_bench'), '--out', str(path)))
    assert path.read_bytes() == before
    assert "this run's k_tilde_rad_per_pulse = 4.0859" in err
    assert f'the dither run {DITHER[0]}, {DITHER[1]} rests on' in err
    assert 'write this run to another --out, then re-run dither' in err
    assert 'or give --replace to drop the dither run\'s values' in err


def test_replace_takes_the_new_k_and_drops_the_values_resting_on_the_old_one_with_lines(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'h.yaml'
    assert _cli(capsys, *DITHER, '--scale-factor-rad-per-pulse', repr(K_DITHER_BENCH),
                '--out', str(path))[0] == 0
    dither_keys = [k for k in load_calibration(path).values if not k.endswith(('_std', '_dof'))]
    code, out, _ = _cli(capsys, str(BAGS / 'k_tilde_bench'), '--out', str(path), '--replace')
    assert code == 0
    assert ('dropped (replace asked): the dither run '
            f'{DITHER[0]}, {DITHER[1]} rested on scale_factor_rad_per_pulse') in out
    for key in dither_keys:
        assert f'dropped: {key} = ' in out
    written = load_calibration(path)
    assert not any(k in written.values for k in dither_keys)
    assert set(dither_keys) <= set(written.missing) and not written.complete
    assert 'rested on scale_factor_rad_per_pulse' in written.missing['dither_amplitude_rad']
    # the way back: dither re-run with the file's K
    assert _cli(capsys, *DITHER, '--calibration', str(path), '--out', str(path))[0] == 0
    again = load_calibration(path)
    assert set(dither_keys) <= set(again.values) and again.complete


def test_replace_does_not_take_a_run_resting_on_another_k_than_the_files(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = k_tilde_file.read_bytes()
    err = _refused_in_one_line(*_cli(capsys, *DITHER, '--scale-factor-rad-per-pulse',
                                     repr(K_DITHER_BENCH), '--out', str(k_tilde_file),
                                     '--replace'))
    assert '--replace does not take values resting on another scale factor' in err
    assert k_tilde_file.read_bytes() == before


def test_a_noise_run_with_another_k_is_refused_and_one_within_tolerance_merged(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    noise = (str(BAGS / 'noise_rlg_static'), '--method', 'noise')
    before = k_tilde_file.read_bytes()
    err = _refused_in_one_line(*_cli(capsys, *noise, '--scale-factor-rad-per-pulse', '4.2e-06',
                                     '--out', str(k_tilde_file)))
    assert k_tilde_file.read_bytes() == before
    assert 'the noise run' in err and 'differs from it by 27147 ppm' in err
    assert 'standard uncertainties (more than 0.2)' in err
    code, out, _ = _cli(capsys, *noise, '--out', str(k_tilde_file))  # the bag's stored K
    assert code == 0
    line = next(x.strip() for x in out.splitlines() if 'scale factor: ' in x)
    assert 'the noise run' in line and 'differs from it by 7.64 ppm' in line
    assert line.endswith('merged.')
    data = yaml.safe_load(k_tilde_file.read_text())
    assert data['methods']['noise']['conditions'] == {
        'scale_factor_rad_per_pulse': 4.0860157e-06,
        'scale_factor_from': 'the bench settings stored in the bag',
        'outliers': 'keep', 'outlier_sigma': 8.0, 'outliers_found': 0, 'outliers_report': 'none'}


def test_an_imu_noise_run_states_no_scale_factor(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'imu.yaml'
    assert _cli(capsys, str(BAGS / 'noise_imu_static'), '--method', 'noise',
                '--out', str(path))[0] == 0
    conditions = yaml.safe_load(path.read_text())['methods']['noise']['conditions']
    assert {k: v for k, v in conditions.items() if not k.startswith('outlier')} == {}


# -- the rule itself, on records ------------------------------------------------------------

THETA_D_RAD, THETA_D_STD = 1.47e-3, 1.75e-7


def _dither(k: float, theta: float = THETA_D_RAD, std: float = THETA_D_STD,
            conditions: dict[str, object] | None = None) -> Calibration:
    cond = {'scale_factor_rad_per_pulse': k, 'scale_factor_from': '--scale-factor-rad-per-pulse'}
    return method_calibration('dither', {
        'dither_amplitude_rad': theta, 'dither_amplitude_rad_std': std,
        'dither_frequency_hz': 407.3, 'dither_frequency_hz_std': 1e-6},
        Provenance('dither bench', 100, 200, conditions=cond if conditions is None
                   else conditions))


def _k_tilde(k: float) -> Calibration:
    return method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': k, 'k_tilde_rad_per_pulse_std': 1e-14, 'window_pairs': 3},
        Provenance('rate table', 0, 10))


@settings(max_examples=400 if STRESS else 40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(k=st.floats(1e-6, 1e-5), log_rel=st.floats(-7.0, -1.0), sign=st.sampled_from([-1, 1]),
       rel_std=st.floats(1e-5, 1e-2), rbrlg_first=st.booleans())
def test_refused_exactly_when_the_k_difference_moves_a_value_beyond_a_fifth_of_its_std(
        tmp_path: Path, k: float, log_rel: float, sign: int, rel_std: float,
        rbrlg_first: bool) -> None:
    """A dither run's θ_d ∝ K: K_file/K_run = 1 + ε moves it by |ε|·θ_d; 0.2·u decides."""
    k_file = k * (1.0 + sign * 10 ** log_rel)
    path = tmp_path / 'h.yaml'
    path.unlink(missing_ok=True)
    runs = [_k_tilde(k_file), _dither(k, std=THETA_D_RAD * rel_std)]
    if not rbrlg_first:
        runs.reverse()
    update_calibration(path, runs[0])
    before = path.read_bytes()
    shift_sigmas = abs(k_file / k - 1.0) * THETA_D_RAD / (THETA_D_RAD * rel_std)
    if abs(shift_sigmas - 0.2) < 1e-9:
        return  # at the boundary itself rounding decides
    report: list[str] = []
    if shift_sigmas > 0.2:
        with pytest.raises(HandoffError, match='not merging values that rest on another scale '
                           'factor'):
            update_calibration(path, runs[1], report=report)
        assert path.read_bytes() == before
    else:
        update_calibration(path, runs[1], report=report)
        notes = [line for line in report if line.startswith('scale factor: ')]
        if k_file == k:
            assert notes == []
        else:
            assert len(notes) == 1
            said = float(notes[0].split('at most ')[1].split(' of their')[0])
            assert math.isclose(said, shift_sigmas, rel_tol=0.06, abs_tol=1e-12)


def test_a_fog_noise_run_rests_on_the_fog_scale_factor(tmp_path: Path) -> None:
    """Counts/rad: a term in rad is ∝ 1/SF, so SF_run/SF_file − 1 moves it."""
    fog = method_calibration('fog', {'fog_scale_factor_counts_per_rad': 1.0e6,
                                     'fog_scale_factor_counts_per_rad_std': 1.0},
                             Provenance('turntable', 0, 10))
    path = update_calibration(tmp_path / 'h.yaml', fog)

    def noise(sf: float) -> Calibration:
        return method_calibration('noise', {
            'angle_random_walk_rad_per_sqrt_s': 1e-6,
            'angle_random_walk_rad_per_sqrt_s_std': 1e-8},  # 1 %: 1/5 σ is 2000 ppm
            Provenance('static', 20, 30, conditions={
                'fog_scale_factor_counts_per_rad': sf,
                'scale_factor_from': '--scale-factor-counts-per-rad'}))

    with pytest.raises(HandoffError, match=r'fog_scale_factor_counts_per_rad = 1003000\.0 '
                       r'counts/rad \(--scale-factor-counts-per-rad\)'):
        update_calibration(path, noise(1.003e6))
    report: list[str] = []
    update_calibration(path, noise(1.001e6), report=report)
    assert any(line.startswith('scale factor: the noise run static rests on '
                               'fog_scale_factor_counts_per_rad') and '999 ppm' in line
               for line in report)


def test_a_file_written_before_runs_stated_their_k_still_loads_and_merges(
        tmp_path: Path) -> None:
    """Format 3 files of earlier versions: dither and noise runs with no scale factor stated."""
    path = update_calibration(tmp_path / 'old.yaml', _dither(0.0, conditions={}))
    data = yaml.safe_load(path.read_text())
    assert data['format_version'] == 3 and data['methods']['dither']['conditions'] == {}
    report: list[str] = []
    update_calibration(path, _k_tilde(K_DITHER_BENCH * 0.8), report=report)
    assert not any(line.startswith('scale factor: ') for line in report)
    assert load_calibration(path).get('dither_amplitude_rad') == THETA_D_RAD


def test_gyro_calib_noise_says_the_scale_factor_line_with_the_handoff_it_wrote(
        k_tilde_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``gyro-calib noise --out`` (and the noise node) print no merge report but this line."""
    code = gyro_calib_main(['noise', str(BAGS / 'noise_rlg_static'), '--out', str(k_tilde_file)])
    out = capsys.readouterr().out
    assert code == 0
    assert (f'hand-off written: {k_tilde_file} (scale factor: the noise run ' in out
            and '7.64 ppm' in out)
