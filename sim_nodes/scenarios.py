"""Every committed scenario of every method, by name (``gyro-calib simulate``, bags/generate.py).

Each method's simulator package defines its scenarios (``sim_nodes/<method>/scenarios.py``:
a ``SCENARIOS`` mapping of objects with ``name``, ``description``, ``expected_results()``,
and its ``write_scenario_bag(scenario, path)``); this module only gathers them.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

SCENARIO_MODULES = ('sim_nodes.rbrlg.scenarios', 'sim_nodes.fog.bag_scenarios',
                    'sim_nodes.dither.bag_scenarios', 'sim_nodes.noise.bag_scenarios',
                    'sim_nodes.thermal.bag_scenarios')
"""The methods' scenario modules, in listing order."""


def _gather() -> dict[str, tuple[Any, Any]]:
    out: dict[str, tuple[Any, Any]] = {}
    for name in SCENARIO_MODULES:
        module = importlib.import_module(name)
        for key, scenario in module.SCENARIOS.items():
            if key in out:
                raise RuntimeError(f'scenario {key} is defined twice')
            out[key] = (scenario, module)
    return out


_ALL = _gather()
SCENARIOS: dict[str, Any] = {name: sc for name, (sc, _) in _ALL.items()}
"""Scenario name → scenario (``.description``, ``.expected_results()``)."""


def write_scenario_bag(name: str, path: str | Path) -> Path:
    """Simulate scenario ``name`` and write its bag at ``path`` (which must not exist)."""
    scenario, module = _ALL[name]
    return module.write_scenario_bag(scenario, path)  # type: ignore[no-any-return]


def write_scenario_files(name: str, directory: str | Path) -> Path:
    """Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` into ``directory``."""
    scenario, module = _ALL[name]
    return module.write_scenario_files(scenario, directory)  # type: ignore[no-any-return]
