"""Ctrl-C names exactly the files already written, each whole, and those not written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from gyro_calib.cli import main

BAGS = Path(__file__).resolve().parents[1] / 'bags'


def test_calibrate_interrupted_in_the_certificate_names_the_handoff_and_figures_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Stopped in the certificate: the hand-off and figures are named written, exit 130.

    README walk: `calibrate --out --plot --report` interrupted said 'nothing written'.
    """
    import gyro_calib.cli.report as report

    def interrupted(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(report, 'report_after_calibrate', interrupted)
    out_file, figs, cert = tmp_path / 'A.yaml', tmp_path / 'figs', tmp_path / 'cert'
    cert.mkdir()
    status = main(['calibrate', str(BAGS / 'k_tilde_bench'), '--gyro-id', 'A-1',
                   '--out', str(out_file), '--plot', str(figs), '--report', str(cert)])
    out, err = capsys.readouterr()
    line = err.strip().splitlines()[-1]
    assert status == 130 and f'hand-off written: {out_file}' in out  # the summary too
    figures = sorted(figs.iterdir())
    assert out_file.exists() and figures and list(cert.iterdir()) == []
    assert line.startswith('gyro-calib: interrupted; written (complete): '
                           f'hand-off {out_file}, figure {figures[0]}')
    assert line.endswith(f'; not written: --report {cert}.')
    assert 'nothing written' not in err


def test_calibrate_interrupted_before_any_file_says_nothing_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Stopped before the hand-off is in place: nothing written, exit 130, no file."""
    import gyro_calib.cli.calibrate as calibrate

    def interrupted(*args: Any, **kwargs: Any) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(calibrate, '_write_handoff', interrupted)
    status = main(['calibrate', str(BAGS / 'k_tilde_bench'), '--gyro-id', 'A-1',
                   '--out', str(tmp_path / 'A.yaml')])
    out, err = capsys.readouterr()
    assert status == 130 and out == '' and list(tmp_path.iterdir()) == []
    assert err.strip().splitlines()[-1] == 'gyro-calib: interrupted; nothing written.'
