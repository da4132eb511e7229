"""Unused settings flags are refused by ``gyro-calib info``.

Issue 17 §10 for ``gyro-calib info``: a settings flag no method run uses is refused there
as in ``calibrate`` — also when no method runs at all (it used to be ignored silently) —
in one line, exit 2, before anything is printed on stdout.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gyro_calib.cli import main as gyro_calib

BAGS = Path(__file__).resolve().parents[1] / 'bags'


@pytest.mark.parametrize('flag', [['--latitude-deg', '45'], ['--heading-deg', '10'],
                                  ['--sense-axis-elevation-deg', '90'], ['--gyro-id', 'A-1']])
def test_info_refuses_a_flag_when_no_method_runs(
        flag: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert gyro_calib(['info', str(BAGS / 'noise_imu_static'), *flag]) == 2
    out, err = capsys.readouterr()
    assert out == ''
    assert err.count('\n') == 1
    assert f'{flag[0]} does not apply' in err and 'no method runs' in err


def test_info_refuses_a_flag_the_methods_run_do_not_use_before_printing(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert gyro_calib(['info', str(BAGS / 'fog_turntable'), '--heading-deg', '10']) == 2
    out, err = capsys.readouterr()
    assert out == ''
    assert err.count('\n') == 1 and '--heading-deg does not apply' in err and 'fog' in err


def test_info_without_flags_still_describes_a_bag_no_method_runs_on(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert gyro_calib(['info', str(BAGS / 'noise_imu_static')]) == 0
    assert '/imu/data' in capsys.readouterr().out


def test_info_with_a_method_whose_topics_the_bag_lacks_prints_nothing_on_stdout(
        capsys: pytest.CaptureFixture[str]) -> None:
    """Bad input (``--method fog``, no FOG topics): one line on stderr, stdout empty.

    README walk: the bag's description used to go to stdout before the error.
    """
    assert gyro_calib(['info', str(BAGS / 'theta_four_position'), '--method', 'fog']) == 2
    out, err = capsys.readouterr()
    assert out == ''
    assert err.count('\n') == 1 and 'method fog needs topic /fog/output' in err
