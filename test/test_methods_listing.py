"""``gyro-calib methods`` names only commands that exist.

A new-user walk ran ``gyro-calib multiposition``, which the listing offered and the CLI
does not have.
"""

from __future__ import annotations

import re

import pytest

from gyro_calib.cli import main


def test_every_command_the_listing_names_exists(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(['methods']) == 0
    listing = capsys.readouterr().out
    named = set(re.findall(r'gyro-calib (\w+)', listing))
    assert named, listing
    for command in sorted(named):
        with pytest.raises(SystemExit) as done:
            main([command, '--help'])
        assert done.value.code == 0, f'gyro-calib {command} is named but does not exist'
    capsys.readouterr()


def test_a_method_that_runs_when_asked_says_how(capsys: pytest.CaptureFixture[str]) -> None:
    main(['methods'])
    listing = capsys.readouterr().out
    assert '[runs when asked: gyro-calib calibrate --method multiposition]' in listing
    assert '--method noise or gyro-calib noise]' in listing
