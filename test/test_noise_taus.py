"""``gyro-calib noise --taus``: a list no record can fit is refused before the bag is read.

New-user walk: ``gyro-calib noise BAG --taus 0.1,1,10`` read the whole bag and then exited 1,
because a term fit needs 8 τ and three can never give one. Now:

- asked for the terms alone, a list of fewer than 8 distinct τ is refused in one line (exit 2,
  nothing on stdout) before any bag is read; a list that is no grid likewise;
- asked for the curves (``--json``), the Allan deviation at the τ listed is given (exit 1);
- a listed τ this record cannot give (shorter than one sample interval, longer than a
  fraction max_tau_fraction of the longest gap-free segment) is named with why, in a line of
  the summary, and left out — not dropped silently, never a traceback.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from gyro_calib.cli import main
from gyro_calib.noise.axis import listed_taus_left_out

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'noise_rlg_static'
"""/gyro/pulses at 500 Hz (τ0 = 2 ms), 280 s with a 2 s gap: the longest segment is 240 s."""


def run(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    try:
        code = main(['noise', *[str(a) for a in argv], '--no-progress'])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(('taus', 'distinct'), [('0.1,1,10', 3), ('1,1,1,1,1,1,1,1', 1)])
def test_a_list_too_short_for_any_fit_is_refused_before_the_bag_is_read(
        taus: str, distinct: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    absent = tmp_path / 'not_a_bag'  # never looked at: the list is refused first
    code, out, err = run(capsys, absent, '--taus', taus)
    assert (code, out) == (2, '')
    assert err == (f'gyro-calib: error: --taus {taus} lists {distinct} distinct averaging '
                   'time(s), fewer than the 8 a noise-term fit needs, so no record can give a '
                   'term: list at least 8 τ or leave --taus out (the default grid); for the '
                   'Allan deviation at these τ alone add --json or --plot DIR. Nothing was '
                   'read.\n')


def test_a_list_that_is_no_grid_is_refused_before_the_bag_is_read(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, tmp_path / 'not_a_bag', '--taus', 'fortnightly')
    assert (code, out) == (2, '')
    assert len(err.splitlines()) == 1 and err.startswith("gyro-calib: error: --taus: taus = ")


def test_with_json_the_curve_at_the_three_taus_is_given_and_exit_is_1(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, BAG, '--taus', '0.1,1,10', '--json')
    assert code == 1, err
    assert json.loads(out)['methods']['noise']['axes']['gyro']['tau_s'] == [0.1, 1.0, 10.0]


def test_a_tau_the_record_cannot_give_is_named_with_why_and_the_rest_is_measured(
        capsys: pytest.CaptureFixture[str]) -> None:
    taus = '0.0001,0.1,0.2,0.5,1,2,5,10,20,1e6'
    code, out, err = run(capsys, BAG, '--taus', taus)
    assert code == 0, err
    assert ('gyro: --taus (the setting taus): τ = 0.0001 s is shorter than the sample interval '
            '(0.002 s); τ = 1e+06 s is longer than 60 s (a fraction 0.25 of the longest '
            'gap-free segment, 240 s): left out of the curve.') in out.splitlines()
    assert 'angle random walk N' in out


def test_the_left_out_phrase_names_each_side_and_is_empty_when_every_tau_fits() -> None:
    assert listed_taus_left_out((0.1, 1.0), 0.01, 1000, 0.25) == ''
    assert listed_taus_left_out((0.004, 0.1), 0.01, 1000, 0.25) == (
        '--taus (the setting taus): τ = 0.004 s is shorter than the sample interval (0.01 s): '
        'left out of the curve.')
    assert listed_taus_left_out((0.1, 3.0, 1e300), 0.01, 1000, 0.25) == (
        '--taus (the setting taus): τ = 3, 1e+300 s is longer than 2.5 s (a fraction 0.25 of '
        'the longest gap-free segment, 10 s): left out of the curve.')
