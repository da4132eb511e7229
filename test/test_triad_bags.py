"""The committed triad bags through the front door give their truth within its stated u (§F).

`gyro-calib calibrate BAGS --method triad --out H.yaml` on the two-axis bag alone and on the
six remount bags together: every K_i, every sense-axis component, every element of M, every
bias and (two-axis) the fitted tilt agree with the truth in the bags' ``expected.yaml``
within its tolerances AND within :data:`SIGMAS` of their own stated standard uncertainty; the
hand-off is format 4, reloads, and holds the session's numbers. A failing check prints the
whole table of normalised errors. A remount set with a mount missing is solved when its
mounts still span 3-D (±x, +y, +z) and is not measurable, with the reason, when they do not.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.cli import main as gyro_calib
from gyro_calib.handoff import load_calibration
from gyro_calib.triad.kinematics import TILT
from gyro_calib.triad.session import TriadSession
from gyro_calib.units import RAD_PER_ARCSEC

BAGS = Path(__file__).resolve().parents[1] / 'bags'
REMOUNTS = ('px', 'mx', 'py', 'my', 'pz', 'mz')
SIGMAS = 4.0
"""A single run's error is checked within this many of its stated standard uncertainties."""


def _calibrate(names: list[str], out: Path, capsys: pytest.CaptureFixture[str]
               ) -> TriadSession:
    """The CLI writes ``out``; the same bags through calibrate_bags give the session."""
    paths = [str(BAGS / n) for n in names]
    assert gyro_calib(['calibrate', *paths, '--method', 'triad', '--out', str(out)]) == 0
    capsys.readouterr()
    session = calibrate_bags(paths, methods=['triad']).sessions['triad']
    assert isinstance(session, TriadSession)
    return session


class _Table:
    """Rows of (quantity, error, u, tolerance); checked all at once, printed on failure."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, float, float, float]] = []

    def add(self, name: str, error: float, u: float, tolerance: float = math.inf) -> None:
        self.rows.append((name, error, u, tolerance))

    def check(self) -> None:
        lines = [f'{n:<22} error {e: .4g}  u {u:.4g}  error/u {e / u: .2f}  tol {t:.4g}'
                 for n, e, u, t in self.rows]
        bad = [line for line, (_, e, u, t) in zip(lines, self.rows, strict=True)
               if not (abs(e) <= SIGMAS * u and abs(e) <= t)]
        assert not bad, ('outside tolerance or 4u:\n' + '\n'.join(bad)
                         + '\n-- all:\n' + '\n'.join(lines))


def _check_against_truth(session: TriadSession, handoff: Path, expected: dict[str, Any]
                         ) -> _Table:
    truth, tol = expected['truth'], expected['tolerance']
    res = session.triad_result
    assert res is not None and res.pulses_to_body_rad is not None and \
        res.bias_body_rad_s is not None, session.not_measurable
    table = _Table()
    for i, ch in enumerate(res.channels):
        k, s, beta = ch.scale_factor_rad_per_pulse, ch.sense_axis, ch.bias_rad_s
        assert k is not None and s is not None and beta is not None, ch
        k_true = truth['scale_factor_rad_per_pulse'][i]
        table.add(f'K_{ch.name} (rel)', k.value / k_true - 1, k.std_uncertainty / k_true,
                  tol['scale_factor_relative'][i])
        for j in range(3):
            if j != i:  # s_ii = √(1 − Σ s_ij²): second order, its u ~ 0
                table.add(f's_{ch.name}·e_{"xyz"[j]} (″)',
                          (s[j].value - truth['sense_axes'][i][j]) / RAD_PER_ARCSEC,
                          s[j].std_uncertainty / RAD_PER_ARCSEC, tol['sense_axis_arcsec'])
        table.add(f'bias_{ch.name} along s (°/h)',
                  (beta.value / RAD_PER_ARCSEC) - truth['bias_deg_h_along_sense_axes'][i],
                  beta.std_uncertainty / RAD_PER_ARCSEC, tol['bias_deg_h'])
        table.add(f'b_{ch.name} body (rad/s)', res.bias_body_rad_s[i].value
                  - truth['bias_rad_s'][i], res.bias_body_rad_s[i].std_uncertainty)
        for j in range(3):
            m = res.pulses_to_body_rad[i][j]
            table.add(f'M[{i}][{j}] (rad/pulse)', m.value - truth['pulses_to_body_rad'][i][j],
                      m.std_uncertainty)
    if 'tilt_deg' in truth:  # the fit's correction to the stated α against the true error
        stated = float(session.conditions()['tilt_deg'])
        table.add('tilt α (″)', res.parameters[TILT].value / RAD_PER_ARCSEC
                  - (truth['tilt_deg'] - stated) * 3600.0,
                  res.parameters[TILT].std_uncertainty / RAD_PER_ARCSEC, tol['tilt_arcsec'])
    cal = load_calibration(handoff)
    assert cal.format_version == 4 and cal.imu is not None
    conventions = yaml.safe_load(handoff.read_text(encoding='utf-8'))['conventions']
    assert 'ω_B = M·ṅ − b' in conventions['imu']  # the file says what its matrix is
    imu, expected_imu = cal.imu, session.imu_calibration()
    assert expected_imu is not None
    assert imu.channels == tuple(truth['channels'])
    for key in ('scale_factor_rad_per_pulse', 'scale_factor_rad_per_pulse_std', 'sense_axes',
                'sense_axes_std_rad', 'pulses_to_body_rad', 'pulses_to_body_rad_covariance',
                'bias_rad_s', 'bias_rad_s_std', 'fixture_rotation'):
        np.testing.assert_array_equal(getattr(imu, key), getattr(expected_imu, key), key)
    assert imu.sense_axes is not None and imu.sense_axes_std_rad is not None
    for i, name in enumerate(imu.channels):  # the hand-off's √trace u of each direction
        angle = float(np.linalg.norm(imu.sense_axes[i] - truth['sense_axes'][i]))
        table.add(f'∠s_{name} (″)', angle / RAD_PER_ARCSEC,
                  imu.sense_axes_std_rad[i] / RAD_PER_ARCSEC, tol['sense_axis_arcsec'])
    return table


def test_two_axis_bag_gives_k_axes_m_b_and_tilt_within_tolerance_and_stated_u(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    name = 'triad_two_axis_bench'
    out = tmp_path / 'h.yaml'
    session = _calibrate([name], out, capsys)
    expected = yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text())
    _check_against_truth(session, out, expected).check()


def test_six_remount_bags_give_k_axes_m_b_within_tolerance_and_stated_u(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    names = [f'triad_remount_bench_{m}' for m in REMOUNTS]
    out = tmp_path / 'h.yaml'
    session = _calibrate(names, out, capsys)
    expected = yaml.safe_load((BAGS / f'{names[0]}.expected.yaml').read_text())
    assert len(session.pairs) == 6 * expected['inner_window_pairs']
    _check_against_truth(session, out, expected).check()


def test_a_remount_set_missing_minus_y_and_minus_z_still_spans_and_is_solved(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """+x, −x, +y, +z: three independent directions, so every row is solved (§F eq. (8))."""
    names = [f'triad_remount_bench_{m}' for m in ('px', 'mx', 'py', 'pz')]
    out = tmp_path / 'h.yaml'
    session = _calibrate(names, out, capsys)
    expected = yaml.safe_load((BAGS / f'{names[0]}.expected.yaml').read_text())
    assert len(session.pairs) == 4 * expected['inner_window_pairs']
    _check_against_truth(session, out, expected).check()


def test_a_remount_set_without_a_z_mount_is_not_measurable_and_says_why(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """±x, ±y only: every direction lies in the x–y plane; no row is solvable, nothing written."""
    paths = [str(BAGS / f'triad_remount_bench_{m}') for m in ('px', 'mx', 'py', 'my')]
    out = tmp_path / 'h.yaml'
    assert gyro_calib(['calibrate', *paths, '--method', 'triad', '--out', str(out)]) == 1
    captured = capsys.readouterr()
    assert not out.exists()
    assert 'nothing written' in captured.err
    for channel in 'xyz':
        line = next(x for x in captured.out.splitlines()
                    if x.startswith(f'imu.{channel}.scale_factor_rad_per_pulse: not measured'))
        assert 'do not span 3-D' in line and 'another remount axis' in line, line


@pytest.mark.parametrize('bags, words', [
    (['triad_two_axis_bench', 'triad_remount_bench_px'], 'calibrated separately'),
    (['triad_remount_bench_px', 'triad_remount_bench_px', 'triad_remount_bench_py'],
     'given twice'),
])
def test_mixed_procedures_or_a_bag_given_twice_are_refused_in_one_line(
        bags: list[str], words: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A two-axis bag with a remount bag was a traceback; a bag twice counted its pairs twice."""
    out = tmp_path / 'imu.yaml'
    code = gyro_calib(['calibrate', *(str(BAGS / b) for b in bags), '--method', 'triad',
                       '--out', str(out), '--no-progress'])
    run = capsys.readouterr()
    assert code == 2 and run.out == '' and len(run.err.strip().splitlines()) == 1, run.err
    assert words in run.err and not out.exists()


def test_the_site_latitude_and_heading_flags_reach_the_triad(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--latitude-deg / --heading-deg were refused for the triad although it uses them."""
    out = tmp_path / 'imu.yaml'
    assert gyro_calib(['calibrate', str(BAGS / 'triad_two_axis_bench'), '--method', 'triad',
                       '--latitude-deg', '28.2', '--heading-deg', '0', '--out', str(out),
                       '--no-progress']) == 0
    conditions = yaml.safe_load(out.read_text(encoding='utf-8'))['methods']['triad']['conditions']
    assert conditions['latitude_deg'] == 28.2 and conditions['heading_deg'] == 0.0
