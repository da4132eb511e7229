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
    assert status == 130 and list(tmp_path.iterdir()) == []
    assert '== rbrlg' in out and ' written: ' not in out  # what was measured, no file
    assert err.strip().splitlines()[-1] == 'gyro-calib: interrupted; nothing written.'


def test_a_ctrl_c_while_the_interpreter_shuts_down_after_the_command_does_not_kill_it(
        tmp_path: Path) -> None:
    """README walk: `noise ... --json` stopped once its files and JSON were out exited 130.

    Python gives SIGINT back to its default action while the interpreter shuts down, so a
    late Ctrl-C killed the finished command; here one lands in the module teardown.
    """
    import os
    import subprocess
    import sys

    script = tmp_path / 'late.py'
    script.write_text(
        'import os, signal\n'
        'class Late:\n'
        '    def __del__(self) -> None:  # at interpreter teardown\n'
        '        os.kill(os.getpid(), signal.SIGINT)\n'
        'late = Late()\n'
        'import gyro_calib.cli as cli\n'
        'cli.main = lambda argv=None: 0\n'
        'cli.console_main()\n')
    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [root, *filter(None, [os.environ.get('PYTHONPATH')])])}
    done = subprocess.run([sys.executable, str(script)], env=env, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
