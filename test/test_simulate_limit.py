"""``gyro-calib simulate`` refuses a bag too big to write, before any work (new-user walk).

A ``--sample-rate-hz 1e9`` or ``--duration-s 1e9`` used to run for hours, silent. Now a run
whose estimated message count exceeds :data:`sim_nodes.scenarios.MAX_SIMULATED_MESSAGES` is
refused in one line on stderr (the estimate, the limit, the flag to change), exit 2, nothing on
stdout, nothing written; the limit is documented where simulate's flags are.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from gyro_calib.bagio import bag_info
from gyro_calib.cli import main
from sim_nodes.scenarios import (
    DEFAULT_RECORDS,
    GROUPS,
    MAX_SIMULATED_MESSAGES,
    SCENARIOS,
    estimated_message_count,
)

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(('scenario', 'flags'), [
    ('noise_rlg_static', ['--sample-rate-hz', '1e9']),
    ('noise_rlg_static', ['--duration-s', '1e9']),
    ('thermal_calibration', ['--duration-s', '1e9']),
    ('multiposition_hand_turned', ['--sample-rate-hz', '1e6']),
    ('triad_remount_bench', ['--sample-rate-hz', '1e6']),
])
def test_a_simulation_over_the_message_limit_is_refused_at_once_in_one_line(
        scenario: str, flags: list[str], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    start = time.monotonic()
    code = main(['simulate', scenario, '--out', str(tmp_path / 'bag'), *flags])
    out, err = capsys.readouterr()
    assert time.monotonic() - start < 5, 'refused before any simulation'
    assert (code, out) == (2, '')
    assert len(err.strip().splitlines()) == 1, err
    assert f'scenario {scenario}' in err
    assert f'over the limit of {MAX_SIMULATED_MESSAGES:,} messages per bag' in err
    assert 'docs/howto/offline.md' in err
    assert flags[0] in err.split('; give ')[1]
    assert list(tmp_path.iterdir()) == []


def test_the_limit_is_documented_where_the_simulate_flags_are() -> None:
    text = ' '.join((ROOT / 'docs' / 'howto' / 'offline.md').read_text().split())
    assert f'limited to {MAX_SIMULATED_MESSAGES:,} messages per bag' in text


def test_the_committed_scenarios_and_modest_overrides_stay_within_the_limit() -> None:
    for name in [*SCENARIOS, *GROUPS]:
        assert estimated_message_count(name, {}) <= MAX_SIMULATED_MESSAGES
    assert estimated_message_count('noise_rlg_static', {'duration_s': 2000}) == pytest.approx(
        139000 * 2000 / 280, rel=1e-6)
    assert estimated_message_count('noise_rlg_static', {'sample_rate_hz': 1000}) == \
        pytest.approx(2 * 139000, rel=1e-6)


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_the_estimate_rests_on_each_committed_bag(name: str) -> None:
    info = bag_info(ROOT / 'bags' / name)
    assert DEFAULT_RECORDS[name] == (info.message_count, round(info.duration_s, 1))
