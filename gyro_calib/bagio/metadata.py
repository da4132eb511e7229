"""The scenario stored in a bag's metadata.yaml.

The scenario stored in a bag's metadata.yaml ``custom_data`` (simulator parameters, seed
and truth), per bench namespace.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from gyro_calib import topics

SCENARIO_KEY = 'gyro_calib.scenario'
"""custom_data key of the scenario YAML in metadata.yaml (the bench in the root namespace;
:func:`scenario_key` names a namespaced bench's)."""


def scenario_key(namespace: str) -> str:
    """custom_data key of the scenario of the bench in ``namespace`` ('' = the root)."""
    ns = topics.normalized_namespace(namespace)
    return f'{SCENARIO_KEY}:{ns}' if ns else SCENARIO_KEY


def scenario_text(scenario: Mapping[str, Any]) -> str:
    r"""The scenario as stored in ``custom_data``.

    The scenario as stored in ``custom_data``: one line of flow-style YAML, Unicode kept
    (no ``\u`` escapes; :func:`store_custom_data` writes it unfolded).
    """
    text: str = yaml.safe_dump(dict(scenario), sort_keys=True, default_flow_style=True,
                               allow_unicode=True, width=2**31 - 1)
    return text.strip()


def store_custom_data(bag_dir: str | Path, key: str, text: str) -> None:
    r"""Write ``custom_data[key] = text`` into the bag's metadata.yaml unfolded.

    rosbags dumps metadata.yaml with ruamel at 80 columns, and ruamel's folding of a
    double-quoted scalar can split an escape (``\\`` came back as ``\ \``), so the
    value it wrote may read back changed; the file is re-dumped here with the value as given
    and no line folding (every other field as rosbags wrote it).
    """
    meta = Path(bag_dir) / 'metadata.yaml'
    doc = yaml.safe_load(meta.read_text(encoding='utf-8'))
    info = doc['rosbag2_bagfile_information']
    custom = info.get('custom_data') or {}
    custom[key] = text
    info['custom_data'] = custom
    meta.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True,
                                   default_flow_style=False, width=2**31 - 1),
                    encoding='utf-8')


_SPLIT_ESCAPE = re.compile(r'\\ (?=u[0-9A-Fa-f]{4}|x[0-9A-Fa-f]{2}|U[0-9A-Fa-f]{8})')


def parse_scenario_text(text: str) -> Any:
    r"""The stored scenario, parsed.

    The stored scenario; repairs an escape split by the ruamel line fold of bags written
    before :func:`scenario_text` (``\ u2080`` → ``\u2080`` inside a quoted scalar).
    """
    return yaml.safe_load(_SPLIT_ESCAPE.sub(lambda m: '\\', text))
