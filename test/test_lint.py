"""The tree keeps the habits of the model codebases (issue 19): ruff and mypy --strict pass.

``ruff check .`` (pyflakes, pycodestyle at 99 columns, pydocstyle's Google convention,
import order; configuration in ruff.toml) on the whole tree, and ``mypy`` (strict, on
gyro_calib/; configuration in setup.cfg) run from the repository root with this
interpreter, so ``./run.sh test`` and CI hold both.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize('command', [
    ['ruff', 'check', '.'],
    ['mypy', 'gyro_calib'],
], ids=['ruff', 'mypy'])
def test_the_tree_passes(command: list[str]) -> None:
    """The tool exits 0; its findings are the failure message."""
    run = subprocess.run([sys.executable, '-m', *command], cwd=ROOT, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, (f'{" ".join(command)} exited {run.returncode}:\n'
                                 f'{run.stdout}{run.stderr}')
