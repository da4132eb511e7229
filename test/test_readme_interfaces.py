"""The documentation explains every interface other people's code relies on.

Topic names, hand-off keys, executables and CLI commands are contracts: a name added to the
code but not to the documentation is a contract nobody can find. The README once held it all;
since issue 39 it is the README and the pages written by hand under docs/ (the reference
generated from the code is left out: it lists every name whatever the pages say, so it
cannot show that a name is explained).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gyro_calib import topics
from gyro_calib.registry import METHODS, handoff_schema

ROOT = Path(__file__).resolve().parents[1]
HAND_WRITTEN = [ROOT / 'README.md'] + sorted(
    p for p in (ROOT / 'docs').rglob('*.md')
    if not {'generated', '_build'} & set(p.relative_to(ROOT / 'docs').parts))
README = '\n'.join(p.read_text(encoding='utf-8') for p in HAND_WRITTEN)
"""README.md and the hand-written documentation pages, as one text."""
IMU_AXIS = re.compile(r'^imu_(gyro|accel)_[xyz]_')


def documented_key(name: str) -> str:
    """The spelling the pages use: IMU keys once per sensor with the axis as <x|y|z>."""
    match = IMU_AXIS.match(name)
    if match:
        return f'imu_{match.group(1)}_<x\\|y\\|z>_' + name[match.end():]
    return name


def test_the_pages_read_are_the_readme_and_the_docs() -> None:
    assert len(HAND_WRITTEN) > 20
    assert not any('generated' in p.parts for p in HAND_WRITTEN)


@pytest.mark.parametrize('name', sorted(handoff_schema()))
def test_every_handoff_key_is_in_the_docs(name: str) -> None:
    assert f'`{documented_key(name)}`' in README


@pytest.mark.parametrize('topic', sorted(
    value for name, value in vars(topics).items()
    if name.isupper() and isinstance(value, str) and value.startswith('/')))
def test_every_contract_topic_is_in_the_docs(topic: str) -> None:
    assert f'`{topic}`' in README


def test_every_executable_and_method_is_in_the_docs() -> None:
    setup = (ROOT / 'setup.py').read_text(encoding='utf-8')
    scripts = re.findall(r"'([\w-]+) = [\w.]+:\w+'", setup)
    assert len(scripts) >= 15
    for script in scripts:
        assert f'`{script}`' in README, script
    for method in METHODS:
        assert f'`{method}`' in README, method
    for command in ('calibrate', 'info', 'methods', 'simulate', 'compensate', 'noise'):
        assert f'gyro-calib {command}' in README, command
