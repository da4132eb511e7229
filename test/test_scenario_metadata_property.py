r"""A bag's stored scenario reads back exactly, whatever text it holds (issue 17 item 15).

``info th4`` showed ``β u2080``: the scenario YAML stored in ``metadata.yaml`` had ``\u2080``
escapes, and the ruamel emitter rosbags writes metadata with folded the long double-quoted
line inside an escape. The property: any scenario (nested mappings of the kinds the
simulators store: Unicode descriptions with Greek letters, subscripts, primes and combining
marks, quotes and backslashes, long lines, numbers, lists, null) written into a bag by
:func:`gyro_calib.bagio.write_bag` reads back equal through :func:`gyro_calib.bagio.bag_info`.
Scenarios are generated here (not from sim_nodes). Derandomized with 25 examples;
``GYRO_CALIB_STRESS=1`` runs 400 random ones.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.bagio import (
    SCENARIO_KEY,
    BagMessage,
    ContractMessages,
    bag_info,
    parse_scenario_text,
    write_bag,
)

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
SYMBOLS = 'βθψωΩ₀₁₂·°′″±√×—…K̃ẼḢ'
"""Characters scenario descriptions use (escaped by a plain YAML dump)."""

_COUNTER = itertools.count()
_PULSE = ContractMessages().joint_state(1, 'gyro', 0.0)
words = st.text(alphabet=st.sampled_from(list('abcdefgh xyz,.:;-()/\'"\\#') + list(SYMBOLS)),
                min_size=0, max_size=60)
scalars = st.one_of(words, st.floats(allow_nan=False, allow_infinity=False), st.integers(),
                    st.booleans(), st.none())
keys = st.text(alphabet='abcdefghijklmnopqrstuvwxyz_', min_size=1, max_size=24)
scenarios = st.recursive(
    st.dictionaries(keys, scalars, max_size=6),
    lambda inner: st.dictionaries(keys, st.one_of(scalars, inner, st.lists(scalars, max_size=5)),
                                  max_size=6), max_leaves=30).map(
    lambda d: {**d, 'description': ' '.join(SYMBOLS) * 3 + str(d)[:200]})


@settings(max_examples=400 if STRESS else 25, deadline=None, derandomize=not STRESS,
          database=None, suppress_health_check=[HealthCheck.too_slow,
                                                HealthCheck.function_scoped_fixture])
@given(scenario=scenarios)
def test_any_stored_scenario_reads_back_equal(scenario: dict[str, Any], tmp_path: Path) -> None:
    path = tmp_path / f'b{next(_COUNTER)}'
    write_bag(path, [BagMessage('/gyro/pulses', 1, _PULSE)], scenario=scenario)
    assert bag_info(path).scenario == scenario
    stored = yaml.safe_load((path / 'metadata.yaml').read_text())
    text = stored['rosbag2_bagfile_information']['custom_data'][SCENARIO_KEY]
    assert '\n' not in text and parse_scenario_text(text) == scenario


def test_a_scenario_split_by_the_old_fold_is_repaired_on_reading() -> None:
    split = 'description: "classic four stations \\u03B2\\ u2080 + k\\xB790\\xB0."\n'
    assert parse_scenario_text(split) == {'description': 'classic four stations β₀ + k·90°.'}
