"""``export --out`` replaces only its own file; ``--merge-into`` takes only a YAML mapping.

A new-user walk (S6, S7): ``export --out my_vins.yaml`` over the user's full VINS-Fusion
config exited 0 with the user's keys gone; ``--merge-into`` a file holding ``hello`` wrote
text no YAML reader takes, exit 0. Now an existing --out is replaced only when it is an
export of the same format this tool wrote (its header comment says ``gyro-calib export
--format F.``; for Kalibr also ``noise --kalibr``'s first line); anything else is refused in
one line, exit 2, nothing written, before the hand-off is read.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from consumer_readers import opencv_tree
from test_export import imu_handoff  # noqa: F401 - the fixture
from test_export_consumers import THEIR_VINS

from gyro_calib.cli import main
from gyro_calib.export.names import FORMAT_NAMES
from gyro_calib.noise.kalibr import KALIBR_MARK

RATE = ['--rate-hz', '200']


def export(handoff: Path, fmt: str, out: Path, *more: str) -> list[str]:
    return ['export', str(handoff), '--format', fmt, '--out', str(out), *RATE, *more]


def refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """The one stderr line of a run that must exit 2 with nothing on stdout."""
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == '' and len(lines) == 1, captured
    return lines[0]


def test_a_users_own_vins_config_is_not_replaced_by_an_export(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    mine = tmp_path / 'my_vins.yaml'
    mine.write_text(THEIR_VINS)
    line = refused(capsys, export(imu_handoff, 'vins-fusion', mine))
    assert str(mine) in line and 'new path' in line and 'remove it' in line
    assert f'--merge-into {mine}' in line and 'Nothing was written' in line
    assert mine.read_text() == THEIR_VINS
    assert [p.name for p in tmp_path.iterdir() if p.name != 'imu.yaml'] == ['my_vins.yaml']


def test_notes_and_another_formats_export_are_not_replaced(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    notes = tmp_path / 'notes.txt'
    notes.write_text('call Anna about the turntable\n')
    line = refused(capsys, export(imu_handoff, 'kalibr', notes))
    assert str(notes) in line and notes.read_text() == 'call Anna about the turntable\n'
    earlier = tmp_path / 'k.yaml'
    assert main(export(imu_handoff, 'kalibr', earlier)) == 0
    kalibr = earlier.read_text()
    capsys.readouterr()
    line = refused(capsys, export(imu_handoff, 'vins-fusion', earlier))
    assert 'vins-fusion' in line and earlier.read_text() == kalibr
    line = refused(capsys, export(imu_handoff, 'openvins', earlier))
    assert '--merge-into' not in line  # openvins is not mergeable: not offered


def test_the_refusal_comes_before_the_handoff_is_read(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mine = tmp_path / 'my_vins.yaml'
    mine.write_text(THEIR_VINS)
    line = refused(capsys, export(tmp_path / 'no_such_handoff.yaml', 'vins-fusion', mine))
    assert str(mine) in line and 'no_such_handoff' not in line


@pytest.mark.parametrize('fmt', FORMAT_NAMES)
def test_a_second_export_of_the_same_format_replaces_the_first(
        imu_handoff: Path, tmp_path: Path, fmt: str,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'params.yaml'
    assert main(export(imu_handoff, fmt, out)) == 0
    fresh = out.read_text()
    out.write_text(fresh + '# an older run, edited\n')
    assert main(export(imu_handoff, fmt, out)) == 0
    assert out.read_text() == fresh
    assert capsys.readouterr().err.strip().splitlines()[-1] == f'wrote {out} ({fmt}).'


def test_an_export_replaces_noise_kalibr_file_and_keeps_openCV_readable_headers(
        imu_handoff: Path, tmp_path: Path) -> None:  # noqa: F811
    imu_yaml = tmp_path / 'imu_k.yaml'
    imu_yaml.write_text(f'# {KALIBR_MARK} (Allan deviation)\nrostopic: /imu\n')
    assert main(export(imu_handoff, 'kalibr', imu_yaml)) == 0
    assert yaml.safe_load(imu_yaml.read_text())['rostopic'] == '/imu/data'
    for fmt in ('openvins', 'vins-fusion'):  # the header comment: OpenCV's reader takes it
        out = tmp_path / f'{fmt}.yaml'
        assert main(export(imu_handoff, fmt, out)) == 0
        assert opencv_tree(out.read_text())


@pytest.mark.parametrize('text, why', [
    ('hello\n', 'not a YAML mapping'),
    ('- a\n- b\n', 'not a YAML mapping'),
    ('key: [unclosed\n', 'is not YAML (line'),
    ('%YAML:1.0\n---\nhello\n', 'not a YAML mapping'),
    ('a: 1\n---\nb: 2\n', 'is not YAML'),
])
def test_merge_into_a_file_that_is_not_a_yaml_mapping_is_refused(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],  # noqa: F811
        text: str, why: str) -> None:
    theirs, out = tmp_path / 'notyaml.yaml', tmp_path / 'out.yaml'
    theirs.write_text(text)
    for target in (out, theirs):
        line = refused(capsys, export(imu_handoff, 'vins-fusion', target,
                                      '--merge-into', str(theirs)))
        assert why in line and str(theirs) in line and 'Nothing was written' in line
        assert not out.exists() and theirs.read_text() == text


def test_merge_into_an_empty_file_says_it_started_from_nothing(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    for text in ('', '# my kalibr notes\n\n'):
        empty = tmp_path / 'empty.yaml'
        empty.write_text(text)
        assert main(export(imu_handoff, 'kalibr', empty, '--merge-into', str(empty))) == 0
        err = capsys.readouterr().err
        assert 'holds no key (empty): started from nothing' in err
        assert set(yaml.safe_load(empty.read_text())) == {
            'accelerometer_noise_density', 'accelerometer_random_walk',
            'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic', 'update_rate'}


def test_merge_into_their_file_written_elsewhere_keeps_an_existing_foreign_out(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    theirs, mine = tmp_path / 'euroc.yaml', tmp_path / 'my_vins.yaml'
    theirs.write_text(THEIR_VINS)
    mine.write_text('%YAML:1.0\nloop_closure: 1\n')
    refused(capsys, export(imu_handoff, 'vins-fusion', mine, '--merge-into', str(theirs)))
    assert mine.read_text() == '%YAML:1.0\nloop_closure: 1\n'
