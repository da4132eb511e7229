"""The same data under two paths is refused, never counted twice.

A new-user walk: ``calibrate bag bag_copy`` gave 8 stations instead of 4, θ ± 0.0103″
instead of ± 0.0381″, dof 5 instead of 1, written to the hand-off with exit 0. Now:

- bags with identical content (a copy), or holding the same messages (a repaired copy of a
  damaged bag beside the original, a subset of it) given in one command — ``calibrate``,
  ``noise``, ``report`` with bags, ``batch`` (one gyro listing a bag under two paths, or two
  gyros listing it) — are refused in one line naming both paths: exit 2, nothing on stdout,
  nothing written;
- different recordings of one bench (stamps starting at the same instants, the noise
  another) are still taken together;
- the hand-off's run identity of a bag does not depend on how its path was spelled: given
  once relative and once absolute, the second run is the same run, updated.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml
from cli_helpers import run

from gyro_calib.bagio import bag_info
from gyro_calib.bagio.duplicates import refuse_repeated_bags, same_content_pairs
from gyro_calib.cli import main
from gyro_calib.errors import ConfigError
from gyro_calib.handoff.runs import Provenance

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
THETA = BAGS / 'theta_four_position'
NOISE = BAGS / 'noise_rlg_turning'


def files_under(path: Path) -> list[Path]:
    return sorted(p for p in path.rglob('*')) if path.exists() else []


@pytest.fixture(scope='module')
def copies(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A copy of the theta bag, a cut-off copy of it and ``repair``'s whole copy of that."""
    tmp = tmp_path_factory.mktemp('same_data')
    copy = tmp / 'bagcopy'
    shutil.copytree(THETA, copy)
    cut = tmp / 'cut'
    shutil.copytree(THETA, cut)
    mcap = next(cut.glob('*.mcap'))
    with mcap.open('r+b') as f:
        f.truncate(mcap.stat().st_size * 2 // 3)
    repaired = tmp / 'repaired'
    assert main(['repair', str(cut), '--out', str(repaired)]) == 0
    noise_copy = tmp / 'noise_copy'
    shutil.copytree(NOISE, noise_copy)
    return {'copy': copy, 'cut': cut, 'repaired': repaired, 'noise_copy': noise_copy,
            'tmp': tmp}


def test_identical_copies_are_found_by_size_then_hash_and_others_are_not() -> None:
    assert same_content_pairs([THETA, NOISE, BAGS / 'dither_y']) == []


@pytest.mark.parametrize('pair, words', [
    (('THETA', 'copy'), 'holds the same content as'),
    (('THETA', 'repaired'), 'hold the same /gyro/pulses messages'),
    (('cut', 'repaired'), 'hold the same /gyro/pulses messages'),
    (('THETA', 'cut'), 'hold the same /gyro/pulses messages'),
])
def test_calibrate_refuses_the_same_data_under_two_paths(
        pair: tuple[str, str], words: str, copies: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Before: 8 stations, θ ± 0.0103″ (not ± 0.0381″), dof 5, exit 0, hand-off written."""
    first, second = (THETA if p == 'THETA' else copies[p] for p in pair)
    out, plots = tmp_path / 'dup2.yaml', tmp_path / 'plots'
    code, stdout, err = run(capsys, 'calibrate', first, second, '--out', out, '--plot', plots,
                            '--no-progress')
    assert code == 2 and stdout == '' and len(err.strip().splitlines()) == 1, err
    assert words in err and str(first) in err and str(second) in err and 'give one' in err
    assert not out.exists() and not plots.exists()


def test_noise_refuses_a_copy_of_its_bag(copies: dict[str, Path], tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'noise.yaml'
    code, stdout, err = run(capsys, 'noise', NOISE, copies['noise_copy'], '--out', out,
                            '--no-progress')
    assert code == 2 and stdout == '' and len(err.strip().splitlines()) == 1, err
    assert 'same content' in err and str(copies['noise_copy']) in err and not out.exists()


@pytest.fixture(scope='module')
def handoff(copies: dict[str, Path]) -> Path:
    out = copies['tmp'] / 'theta.yaml'
    assert main(['calibrate', str(THETA), '--out', str(out), '--no-progress']) == 0
    return out


def test_report_refuses_a_bag_and_its_repaired_copy(
        handoff: Path, copies: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'cert'
    code, stdout, err = run(capsys, 'report', handoff, THETA, copies['repaired'], '--out', out,
                            '--no-pdf')
    assert code == 2 and stdout == '' and len(err.strip().splitlines()) == 1, err
    assert 'same /gyro/pulses messages' in err and files_under(out) == []


@pytest.mark.parametrize('case', ['one gyro, a copy', 'one gyro, the path twice',
                                  'two gyros, one bag', 'two gyros, a copy'])
def test_batch_refuses_a_bag_listed_twice(case: str, copies: dict[str, Path], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    gyros = {
        'one gyro, a copy': [{'id': 'G1', 'bags': [str(THETA), str(copies['copy'])]}],
        'one gyro, the path twice': [{'id': 'G1', 'bags': [str(THETA),
                                                           str(THETA / '..' / THETA.name)]}],
        'two gyros, one bag': [{'id': 'G1', 'bags': [str(THETA)]},
                               {'id': 'G2', 'bags': [str(THETA)]}],
        'two gyros, a copy': [{'id': 'G1', 'bags': [str(THETA)]},
                              {'id': 'G2', 'bags': [str(copies['copy'])]}],
    }[case]
    manifest = tmp_path / 'm.yaml'
    manifest.write_text(yaml.safe_dump(gyros), encoding='utf-8')
    out = tmp_path / 'out'
    code, stdout, err = run(capsys, 'batch', manifest, '--out', out, '--no-pdf',
                            '--no-progress')
    assert code == 2 and stdout == '' and len(err.strip().splitlines()) == 1, err
    assert 'twice' in err and 'G1' in err and not out.exists()


def test_a_gyro_listing_a_bag_and_its_repaired_copy_is_a_failed_row(
        copies: dict[str, Path]) -> None:
    from gyro_calib.batch.manifest import GyroJob
    from gyro_calib.batch.tasks import plan_gyro

    plan = plan_gyro(GyroJob('G1', (str(THETA), str(copies['repaired'])), (), {}), '', '',
                     False)
    assert plan.error and 'same /gyro/pulses messages' in plan.error and not plan.methods


def test_two_recordings_of_one_bench_overlapping_in_stamps_are_taken_together() -> None:
    """The triad's remount bags share topics and start at the same stamps: other noise."""
    bags = [BAGS / f'triad_remount_bench_{s}' for s in ('px', 'mx', 'py')]
    refuse_repeated_bags([bag_info(b) for b in bags])  # no ConfigError
    with pytest.raises(ConfigError, match='given twice'):
        refuse_repeated_bags([bag_info(b) for b in (bags[0], bags[0].parent / '.' / bags[0].name)])


def test_a_bag_given_relative_then_absolute_is_the_same_run(
        copies: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Before: 'replaced … (as precise, newer)', as if another run had measured it."""
    monkeypatch.chdir(copies['tmp'])
    out = tmp_path / 'h.yaml'
    assert run(capsys, 'calibrate', 'bagcopy', '--out', out, '--no-progress')[0] == 0
    code, stdout, _ = run(capsys, 'calibrate', copies['copy'].resolve(), '--out', out,
                          '--no-progress')
    replaced = [line for line in stdout.splitlines() if 'replaced:' in line]
    assert code == 0 and replaced and all('(same run, updated)' in line for line in replaced)


def test_old_records_keep_comparing_as_written() -> None:
    """A path not found here (another machine's record) and 'live' compare as written."""
    a = Provenance('/elsewhere/run1', 0, 10)
    assert a.same_data(Provenance('/elsewhere/run1', 0, 20))
    assert not a.same_data(Provenance('/elsewhere/run2', 0, 10))
    assert Provenance('live', 5, 9).same_data(Provenance('live', 5, 12))
