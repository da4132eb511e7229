"""docs/multiposition.md's Xsens tables show what the command prints (F10).

Specification: every "ours" value and u of the page's Xsens MTi tables (the scales' 1/s, the
biases, the misalignment angles) is what ``gyro-calib calibrate xsens_acc.mat xsens_gyro.mat
--format imu_tk --config g.yaml`` (IMU-TK's g, 9.81744 m/s², exact) prints: each u as printed
(two significant digits, rounded to nearest), each value the printed one to the page's digits.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gyro_calib.cli import main as gyro_calib_main

ROOT = Path(__file__).resolve().parents[1]
XSENS = ROOT / 'test' / 'data' / 'real' / 'imu_tk_xsens'
PAGE = ROOT / 'docs' / 'multiposition.md'
NUMBER = r'[−\-+]?\d+(?:\.\d+)?'


def _float(text: str) -> float:
    return float(text.replace('−', '-'))


@pytest.fixture(scope='module')
def printed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[str, str]]:
    """Summary row name → (value, u) as the command prints them (1/s rows: the [...] ones)."""
    config = tmp_path_factory.mktemp('g') / 'g.yaml'
    config.write_text('gravity_m_s2: 9.81744\ngravity_std_m_s2: 0.0\n', encoding='utf-8')
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert gyro_calib_main(['calibrate', str(XSENS / 'xsens_acc.mat.xz'),
                                str(XSENS / 'xsens_gyro.mat.xz'), '--format', 'imu_tk',
                                '--config', str(config), '--no-progress']) == 0
    rows: dict[str, tuple[str, str]] = {}
    for line in out.getvalue().splitlines():
        m = re.match(r'(accelerometer|gyro) (\w+) \(.*?\)(?: \[1/s\])?\s+(\S+)(?: \[(\S+)\])?'
                     r'\s+(\S+)(?: \[(\S+)\])?\s+\d+$', line)
        if m:
            sensor, name, value, inv, u, u_inv = m.groups()
            rows[f'{sensor} {name}'] = (value, u)
            if inv is not None:
                rows[f'{sensor} 1/s {name[-1]}'] = (inv, u_inv)
    return rows


def _page_rows() -> dict[str, list[tuple[str, str]]]:
    """Page row label → [(value, u), …] of its "ours" cells (the Xsens section)."""
    text = PAGE.read_text(encoding='utf-8')
    section = text.split('### Xsens MTi', 1)[1].split('\n### ', 1)[0]
    rows: dict[str, list[tuple[str, str]]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if len(cells) < 2:
            continue
        pairs = re.findall(rf'({NUMBER}) \(({NUMBER})(?:, [^)]*)?\)', ' | '.join(cells[1:4]))
        if pairs:
            rows[cells[0]] = pairs
    return rows


def _same_value(page: str, cli: str) -> bool:
    """The page's value is the printed one to the page's digits."""
    decimals = len(page.split('.')[1]) if '.' in page else 0
    return abs(_float(page) - _float(cli)) <= 0.5 * 10 ** -decimals + 1e-12


def test_every_ours_cell_of_the_xsens_tables_is_what_the_command_prints(
        printed: dict[str, tuple[str, str]]) -> None:
    page = _page_rows()
    expected = {
        'accelerometer 1/s, ours (u, ν)': [f'accelerometer 1/s {a}' for a in 'xyz'],
        'accelerometer bias, ours (u)': [f'accelerometer bias_{a}_raw' for a in 'xyz'],
        'gyro 1/s, ours (u, ν)': [f'gyro 1/s {a}' for a in 'xyz'],
        'gyro bias, ours (u, ν = 38)': [f'gyro bias_{a}_raw' for a in 'xyz'],
        **{f'{s} {n}': [f'{s} misalignment_{n}'] for s, names in (
            ('accelerometer', ('yz', 'zy', 'zx')),
            ('gyro', ('yz', 'zy', 'zx', 'xz', 'xy', 'yx'))) for n in names},
    }
    checked = 0
    for label, names in expected.items():
        assert label in page, (label, sorted(page))
        for (value, u), name in zip(page[label], names, strict=True):
            cli_value, cli_u = printed[name]
            assert u == cli_u, f'{label} ({name}): the page says u = {u}, the command {cli_u}'
            assert _same_value(value, cli_value), (label, name, value, cli_value)
            checked += 1
    assert checked == 21
