"""The lines a new user meets name the right flag, the right method and the right clock.

New-user walk (gyro-calib CLI):

- a file given where a certificate's or a batch's directory goes is refused with what that
  directory holds (it said "the figures are named by method inside it", --plot's reason);
- ``--kalibr DIR/`` (and every file output ending in /) wrote a file named DIR: refused in
  one line, as docs/howto/offline.md ("Outputs") promises for a directory where a file goes;
- a certificate of bags stamped in simulation time gave their spans as 1970 dates: the
  stamps are given in seconds, said not to be calendar dates;
- a multiposition calibration's certificate said "no triad run" for its procedure.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from cli_helpers import one_line, run

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import Calibration, Provenance
from gyro_calib.report.certificate import build_certificate

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'


# -- a file where a directory goes: the flag's own reason ---------------------------------------
@pytest.mark.parametrize(('argv', 'says'), [
    (['calibrate', BAGS / 'k_tilde_bench', '--report', '{file}'],
     '--report {file} is a file; --report takes a directory (the certificate is written inside '
     'it as HTML and PDF). Nothing was read.'),
    (['report', BAGS / 'k_tilde_bench.expected.yaml', '--out', '{file}'],
     '--out {file} is a file; --out takes a directory (the certificate is written inside it as '
     'HTML and PDF). Nothing was read.'),
    (['batch', '{file}', '--out', '{file}'],
     '--out {file} is a file; --out takes a directory (one result directory per gyro and the '
     'fleet files are written inside it). Nothing was read.'),
    (['calibrate', BAGS / 'k_tilde_bench', '--plot', '{file}'],
     '--plot {file} is a file; --plot takes a directory (the figures are named by method '
     'inside it). Nothing was read.'),
])
def test_a_file_where_a_directory_goes_is_refused_with_that_directorys_contents(
        argv: list[Any], says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    file = tmp_path / 'a_file'
    file.write_text('kept')
    code, out, err = run(capsys, *[str(a).format(file=file) for a in argv])
    assert (code, out) == (2, '')
    assert one_line(err) == 'gyro-calib: error: ' + says.format(file=file)
    assert file.read_text() == 'kept' and list(tmp_path.iterdir()) == [file]


# -- a file output given as a directory -------------------------------------------------------
@pytest.mark.parametrize(('argv', 'flag', 'example'), [
    (['noise', BAGS / 'noise_imu_static', '--topic', '/imu/data', '--kalibr'], '--kalibr',
     'imu.yaml'),
    (['noise', BAGS / 'noise_imu_static', '--topic', '/imu/data', '--out'], '--out',
     'handoff.yaml'),
    (['calibrate', BAGS / 'k_tilde_bench', '--out'], '--out', 'handoff.yaml'),
    (['export', BAGS / 'k_tilde_bench.expected.yaml', '--format', 'kalibr', '--out'], '--out',
     'params.yaml'),
])
@pytest.mark.parametrize('exists', [False, True])
def test_a_file_output_ending_in_a_slash_is_refused_and_nothing_is_written(
        argv: list[Any], flag: str, example: str, exists: bool, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / 'calib'
    if exists:
        target.mkdir()
    code, out, err = run(capsys, *argv, f'{target}/')
    assert (code, out) == (2, '')
    line = one_line(err)
    assert f'argument {flag}: {str(target) + "/"!r} ends in /, a directory; it takes a file ' \
           f'name (e.g. {target}/{example})' in line
    assert [p.name for p in tmp_path.iterdir()] == (['calib'] if exists else [])
    assert not exists or list(target.iterdir()) == []


def test_an_existing_directory_given_without_the_slash_is_refused_too(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, 'noise', BAGS / 'noise_imu_static', '--topic', '/imu/data',
                         '--kalibr', tmp_path)
    assert (code, out) == (2, '')
    assert one_line(err) == (f'gyro-calib: error: --kalibr {tmp_path} is a directory; give a '
                             'file name. Nothing was read.')


# -- certificates: simulation-time stamps are no calendar dates ---------------------------------
def test_a_span_stamped_in_simulation_time_is_given_in_seconds_not_as_1970() -> None:
    record = Calibration({'angle_random_walk_rad_per_sqrt_s': 8.5e-7,
                          'angle_random_walk_rad_per_sqrt_s_std': 2.0e-8},
                         {'noise': Provenance('bags/n', 0, 279_998_000_000)}, 'N-1')
    span = build_certificate(record, None).methods[0].span
    assert span == ('stamps 0.000 → 279.998 s (simulation or monotonic time, not calendar '
                    'dates; 279.998 s)')


def test_a_span_stamped_in_utc_keeps_its_dates() -> None:
    record = Calibration({'angle_random_walk_rad_per_sqrt_s': 8.5e-7,
                          'angle_random_walk_rad_per_sqrt_s_std': 2.0e-8},
                         {'noise': Provenance('bags/n', 1_767_225_600_000_000_000,
                                              1_767_225_879_998_000_000)}, 'N-1')
    span = build_certificate(record, None).methods[0].span
    assert span == '2026-01-01 00:00:00.000 → 00:04:39.998 UTC (279.998 s)'


def test_a_multiposition_certificate_names_its_procedure_not_a_missing_triad() -> None:
    bag = BAGS / 'multiposition_hand_turned'
    session = calibrate_bags([bag], methods=['multiposition']).sessions['multiposition']
    record = session.handoff(str(bag))
    assert record is not None
    conditions = dict(build_certificate(record, None).imu_conditions)
    assert conditions['procedure'] == ('multiposition: the IMU turned by hand through static '
                                       f'poses, no table (docs/methods.md §G; run on {bag})')
    assert conditions['pairs and stations'] == ('none: a multiposition calibration has static '
                                                'poses, no table')
