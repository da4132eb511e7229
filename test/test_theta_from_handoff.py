"""θ and K of a run without a K̃ phase take K̃ from a hand-off file (issue 19, part 1).

A procedure split over two sessions (the K̃ phase one day, the stations the next) or a node
restarted in the θ phase must not lose θ and K: the K̃ of the calibration file is used, with
its provenance in the run's conditions, until the run measures its own.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from ros_in_process import init_undiscovered

from gyro_calib.cli import main
from gyro_calib.handoff import load_calibration

BAGS = Path(__file__).resolve().parent.parent / 'bags'


@pytest.fixture
def no_k_tilde_phase(tmp_path: Path) -> Path:
    """A config under which the station bench's own K̃ phase gives no K̃ (too few pairs)."""
    path = tmp_path / 'stations_only.yaml'
    path.write_text('min_pairs: 100\n', encoding='utf-8')
    return path


def test_theta_and_k_take_k_tilde_from_the_calibration_file(
        tmp_path: Path, no_k_tilde_phase: Path, capsys: pytest.CaptureFixture[str]) -> None:
    k_file = tmp_path / 'k_tilde.yaml'
    assert main(['calibrate', str(BAGS / 'k_tilde_bench'), '--out', str(k_file),
                 '--no-progress']) == 0
    k_tilde = load_calibration(k_file).get('k_tilde_rad_per_pulse')
    capsys.readouterr()
    out = k_file  # the procedure's second session updates the first one's file
    assert main(['calibrate', str(BAGS / 'theta_four_position'), '--config',
                 str(no_k_tilde_phase), '--calibration', str(k_file), '--out', str(out),
                 '--json', '--no-progress']) == 0
    results = json.loads(capsys.readouterr().out)['methods']['rbrlg']['results']
    assert 'k_tilde_rad_per_pulse' not in results  # this run measured none
    assert 'fix_error_angle_rad' in results and 'scale_factor_rad_per_pulse' in results
    written = load_calibration(out)
    assert written.get('k_tilde_rad_per_pulse') == k_tilde  # kept from the first run
    theta = written.get('fix_error_angle_rad')
    import math
    assert math.isclose(written.get('scale_factor_rad_per_pulse'), k_tilde * math.cos(theta),
                        rel_tol=1e-12)
    conditions = written.methods['rbrlg'].conditions
    assert str(k_file) in conditions['k_tilde_for_theta_from']


def test_without_a_calibration_file_theta_says_what_would_give_it(
        no_k_tilde_phase: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(['calibrate', str(BAGS / 'theta_four_position'), '--config',
                 str(no_k_tilde_phase), '--json', '--no-progress']) == 1  # nothing measured
    missing = json.loads(capsys.readouterr().out)['methods']['rbrlg']['missing']
    assert '--calibration FILE' in missing['fix_error_angle_rad']


def test_a_calibration_file_without_k_tilde_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fog = tmp_path / 'fog.yaml'
    assert main(['calibrate', str(BAGS / 'fog_turntable'), '--out', str(fog),
                 '--no-progress']) == 0
    capsys.readouterr()
    assert main(['calibrate', str(BAGS / 'theta_four_position'), '--calibration', str(fog),
                 '--no-progress']) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and 'k_tilde_rad_per_pulse' in captured.err


def test_calibration_node_takes_k_tilde_for_theta_from_its_calibration_file(
        tmp_path: Path) -> None:
    """The live node: parameter calibration_file, the same core (RbrlgCalibrator)."""
    import rclpy

    from gyro_calib.nodes.calibration_node import CalibrationNode
    from gyro_calib.nodes.processes import ros_args

    k_file = tmp_path / 'k_tilde.yaml'
    assert main(['calibrate', str(BAGS / 'k_tilde_bench'), '--out', str(k_file),
                 '--no-progress']) == 0
    init_undiscovered(args=ros_args({'calibration_file': str(k_file),
                              'output_file': str(tmp_path / 'gyro.yaml')}))
    try:
        node = CalibrationNode()
        try:
            prior = node.bench.prior_k_tilde
            assert prior is not None and str(k_file) in node.bench.prior_k_tilde_source
            from gyro_calib.units import RAD_PER_ARCSEC
            assert prior.value * RAD_PER_ARCSEC == pytest.approx(
                load_calibration(k_file).get('k_tilde_rad_per_pulse'), rel=1e-15)
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
