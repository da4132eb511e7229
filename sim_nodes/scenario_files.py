"""What every method's scenario module writes beside a bag: ``<name>.expected.yaml``.

Each method's scenario module (``sim_nodes/<method>/scenarios.py`` or ``bag_scenarios.py``)
keeps its scenarios and how one is simulated into a bag (``write_scenario_bag``); naming a
scenario and writing the bag with its expected results is the same for all of them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol, TypeVar


class NamedScenario(Protocol):
    """A committed scenario: a name and the results its bag should calibrate to."""

    @property
    def name(self) -> str:
        """The scenario's (and its bag's) name."""

    def expected_results(self) -> Any:
        """The expected results (written as YAML)."""


S = TypeVar('S', bound=NamedScenario)


def named(scenario: S | str, scenarios: Mapping[str, S]) -> S:
    """``scenario``, or the scenario of that name in ``scenarios``."""
    return scenarios[scenario] if isinstance(scenario, str) else scenario


def write_scenario_files(scenario: S | str, directory: str | Path, *,
                         scenarios: Mapping[str, S],
                         write_bag: Callable[[S, Path], Path], source: str,
                         what: str = 'calibration') -> Path:
    """Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in ``directory``.

    Args:
        scenario: the scenario, or its name in ``scenarios``.
        directory: where both go.
        scenarios: the module's scenarios by name.
        write_bag: the module's ``write_scenario_bag``.
        source: the module named in the expected file's first line.
        what: what the expected file holds ('calibration', 'noise characterisation', …).

    Returns:
        The bag's path.
    """
    import yaml

    scenario = named(scenario, scenarios)
    directory = Path(directory)
    bag = write_bag(scenario, directory / scenario.name)
    (directory / f'{scenario.name}.expected.yaml').write_text(
        f'# Expected {what} of the bag beside this file ({source}; regenerate with '
        'bags/generate.py).\n'
        + yaml.safe_dump(scenario.expected_results(), sort_keys=False, allow_unicode=True),
        encoding='utf-8')
    return bag


def files_writer(scenarios: Mapping[str, S], write_bag: Callable[[S, Path], Path], *,
                 source: str, what: str = 'calibration'
                 ) -> Callable[[S | str, str | Path], Path]:
    """A module's ``write_scenario_files(scenario, directory)``: :func:`write_scenario_files`."""
    def write(scenario: S | str, directory: str | Path) -> Path:
        """Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in ``directory``."""
        return write_scenario_files(scenario, directory, scenarios=scenarios,
                                    write_bag=write_bag, source=source, what=what)
    write.__name__ = write.__qualname__ = 'write_scenario_files'
    return write
