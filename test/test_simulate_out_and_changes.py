"""``gyro-calib simulate``: --out names the bag directory; the written line says what changed.

The line after writing says which of the scenario's parameters the flags set, old → new.
A new-user walk found ``--out r4.mcap`` writing ``r4.mcap/r4.mcap.mcap`` silently, and
the seeds printed as a Python dict of the defaults without saying which ``--seed`` set.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gyro_calib.cli import main


@pytest.mark.parametrize('name', ['r4.mcap', 'r4.MCAP', 'bag.db3', 'metadata.yaml'])
def test_an_out_named_like_a_file_is_refused_before_any_work(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(['simulate', 'k_tilde_bench', '--duration-s', '5', '--out',
                 str(tmp_path / name)])
    out, err = capsys.readouterr()
    assert (code, out) == (2, '')
    assert len(err.strip().splitlines()) == 1 and 'a bag is a directory' in err
    assert 'nothing was written' in err
    assert list(tmp_path.iterdir()) == []


def test_the_written_line_names_each_parameter_the_flags_set(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(['simulate', 'k_tilde_bench', '--seed', '3', '--duration-s', '5', '--out',
                 str(tmp_path / 'bag')])
    out = capsys.readouterr().out
    assert code == 0
    assert out.strip() == (f'wrote {tmp_path / "bag"} (table.duration_s 100 → 5, '
                           'table.seed 21 → 3, gyro.seed 21 → 4, procedure.seed 1 → 5)')
