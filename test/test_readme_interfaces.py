"""The README documents every interface other people's code relies on.

Topic names, hand-off keys, executables and CLI commands are contracts: a name added to the
code but not to the README is a contract nobody can find.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gyro_calib import topics
from gyro_calib.registry import METHODS, handoff_schema

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / 'README.md').read_text(encoding='utf-8')
IMU_AXIS = re.compile(r'^imu_(gyro|accel)_[xyz]_')


def documented_key(name: str) -> str:
    """The spelling the README uses: IMU keys once per sensor with the axis as <x|y|z>."""
    match = IMU_AXIS.match(name)
    if match:
        return f'imu_{match.group(1)}_<x\\|y\\|z>_' + name[match.end():]
    return name


@pytest.mark.parametrize('name', sorted(handoff_schema()))
def test_every_handoff_key_is_in_the_readme(name: str) -> None:
    assert f'`{documented_key(name)}`' in README


@pytest.mark.parametrize('topic', sorted(
    value for name, value in vars(topics).items()
    if name.isupper() and isinstance(value, str) and value.startswith('/')))
def test_every_contract_topic_is_in_the_readme(topic: str) -> None:
    assert f'`{topic}`' in README


def test_every_executable_and_method_is_in_the_readme() -> None:
    setup = (ROOT / 'setup.py').read_text(encoding='utf-8')
    scripts = re.findall(r"'([\w-]+) = [\w.]+:\w+'", setup)
    assert len(scripts) >= 15
    for script in scripts:
        assert f'`{script}`' in README, script
    for method in METHODS:
        assert f'`{method}`' in README, method
    for command in ('calibrate', 'info', 'methods', 'simulate', 'compensate', 'noise'):
        assert f'gyro-calib {command}' in README, command
