"""``gyro-calib`` run in this test process, and what it printed (for the command-line tests)."""

from __future__ import annotations

from typing import Any

import pytest

from gyro_calib.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``gyro-calib ARGV``; argparse exits are caught."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    """The one line ``err`` holds (a refusal says what was wrong in exactly one line)."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]
