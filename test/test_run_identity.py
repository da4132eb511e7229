"""A re-run is a new run: the same bag under other settings never silently replaces a value.

Issue 35 item 1. A run's identity is its data (bag, first stamp) *and* every setting it was
given that may change its numbers (``methods.<name>.settings``: outlier mode, latitude,
heading, τ list, config values). The same bag re-run with other settings is checked against
the file like any other run: a value that moves by more than 5 combined standard
uncertainties is refused (``--replace`` takes it), and every replacement, on every front door
(``noise`` too), prints the old value beside the new one.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.handoff import load_calibration

BAGS = Path(__file__).resolve().parent.parent / 'bags'


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = gyro_calib_main([*args, '--no-progress'])
    out, err = capsys.readouterr()
    return code, out, err


def _refused(code: int, out: str, err: str) -> str:
    assert code == 2 and out == '', (code, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_noise_with_outliers_kept_does_not_replace_the_run_that_removed_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's first repro: Q moves 21× (319 σ) when the spikes are kept."""
    out = tmp_path / 'g.yaml'
    bag = str(BAGS / 'noise_rlg_spikes')
    code, text, _ = _cli(capsys, 'noise', bag, '--outliers', 'remove', '--out', str(out))
    assert code == 0 and 'added: quantization_noise_rad = 1.17968' in text
    before = out.read_bytes()
    line = _refused(*_cli(capsys, 'noise', bag, '--out', str(out)))
    assert line.startswith('gyro-calib: error: quantization_noise_rad: this run gives 2.52')
    assert "the same data under other settings (outliers: 'remove' -> 'not given')" in line
    assert 'give --replace' in line
    assert out.read_bytes() == before  # nothing written
    code, text, _ = _cli(capsys, 'noise', bag, '--out', str(out), '--replace')
    assert code == 0
    replaced = [ln for ln in text.splitlines() if ln.startswith('  replaced: quantization')]
    assert len(replaced) == 1 and '2.5215773' in replaced[0] and 'was 1.17968' in replaced[0]
    assert 'replace asked' in replaced[0]
    assert load_calibration(out).values['quantization_noise_rad'] == pytest.approx(2.5216e-5,
                                                                                  rel=1e-3)
    # the same command again is the same run: updated in place, each line old and new
    code, text, _ = _cli(capsys, 'noise', bag, '--out', str(out))
    assert code == 0 and '(same run, updated)' in text and 'was 2.5215773' in text


def test_calibrate_with_a_latitude_is_not_the_same_run_as_without(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's second repro: ω_B moves from 5.2e-8 to −2.9e-5 rad/s (1530 σ)."""
    out = tmp_path / 'A.yaml'
    bag = str(BAGS / 'k_tilde_bench')
    assert _cli(capsys, 'calibrate', bag, '--out', str(out))[0] == 0
    before = out.read_bytes()
    line = _refused(*_cli(capsys, 'calibrate', bag, '--out', str(out), '--latitude-deg', '60'))
    assert 'bias_rad_s: this run gives -2.86' in line and 'the file holds 5.16' in line
    assert "(latitude_deg: 'not given' -> 60.0)" in line and '--replace' in line
    assert out.read_bytes() == before
    code, text, _ = _cli(capsys, 'calibrate', bag, '--out', str(out), '--latitude-deg', '60',
                         '--replace')
    assert code == 0
    (bias,) = [ln for ln in text.splitlines() if ln.startswith('  replaced: bias_rad_s')]
    assert '-2.86' in bias and 'was 5.16' in bias
    run = yaml.safe_load(out.read_text())['methods']['rbrlg']
    assert run['settings'] == {'latitude_deg': 60.0}


def test_a_config_file_edited_between_runs_makes_another_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, config = tmp_path / 'g.yaml', tmp_path / 'noise.yaml'
    bag = str(BAGS / 'noise_rlg_spikes')
    config.write_text('outliers: remove\n')
    assert _cli(capsys, 'noise', bag, '--config', str(config), '--out', str(out))[0] == 0
    config.write_text('outliers: keep\n')
    line = _refused(*_cli(capsys, 'noise', bag, '--config', str(config), '--out', str(out)))
    assert 'config_file_sha256' in line and 'the same data under other settings' in line


def test_a_triad_re_run_under_another_latitude_is_refused_and_its_replacement_says_old_and_new(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The triad's imu: section is checked value by value too (K_i, b)."""
    out = tmp_path / 'T.yaml'
    bag = str(BAGS / 'triad_two_axis_bench')
    assert _cli(capsys, 'calibrate', bag, '--out', str(out))[0] == 0
    before = out.read_bytes()
    line = _refused(*_cli(capsys, 'calibrate', bag, '--out', str(out), '--latitude-deg', '60'))
    assert line.startswith('gyro-calib: error: imu.bias_rad_s[')
    assert "(latitude_deg: 'not given' -> 60.0)" in line and '--replace' in line
    assert out.read_bytes() == before
    code, text, _ = _cli(capsys, 'calibrate', bag, '--out', str(out), '--latitude-deg', '60',
                         '--replace')
    assert code == 0
    lines = [ln for ln in text.splitlines() if ln.startswith('  replaced: imu.')]
    assert len(lines) == 6 and all(' — was ' in ln and 'replace asked' in ln for ln in lines)


def test_a_triads_noise_terms_per_channel_are_checked_and_replaced_saying_old_and_new(
        tmp_path: Path) -> None:
    """The noise method on /imu/pulses sets imu.noise.<channel>: checked like any value."""
    import dataclasses

    from gyro_calib.handoff import HandoffError, Provenance, method_calibration, update_calibration
    from gyro_calib.imu_calibration import ImuCalibration

    def run(n: float, settings: dict[str, str]) -> object:
        cal = method_calibration('noise', {}, Provenance('bags/triad_static', 0, 10,
                                                         settings=settings))
        return dataclasses.replace(cal, imu=ImuCalibration(('x', 'y', 'z'), noise={
            c: {'angle_random_walk_rad_per_sqrt_s': n,
                'angle_random_walk_rad_per_sqrt_s_std': 1e-8} for c in 'xyz'}))

    path = tmp_path / 'triad.yaml'
    update_calibration(path, run(1e-6, {'outliers': 'remove'}))  # type: ignore[arg-type]
    before = path.read_bytes()
    with pytest.raises(HandoffError, match=r"imu.noise.x.angle_random_walk_rad_per_sqrt_s: "
                                           r".*the same data under other settings \(outliers: "
                                           r"'remove' -> 'not given'\)"):
        update_calibration(path, run(2e-6, {}))  # type: ignore[arg-type]
    assert path.read_bytes() == before
    report: list[str] = []
    update_calibration(path, run(2e-6, {}), replace=True, report=report)  # type: ignore[arg-type]
    replaced = [ln for ln in report if ln.startswith('replaced: imu.noise.')]
    assert len(replaced) == 3 and all('= 2e-06' in ln and 'was 1e-06' in ln for ln in replaced)
    assert load_calibration(path).imu.noise['y']['angle_random_walk_rad_per_sqrt_s'] == 2e-6
