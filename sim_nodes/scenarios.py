"""Every committed scenario of every method, by name (``gyro-calib simulate``, bags/generate.py).

Each method's simulator package defines its scenarios (``sim_nodes/<method>/scenarios.py``:
a ``SCENARIOS`` mapping of objects with ``name``, ``description``, ``expected_results()``,
and its ``write_scenario_bag(scenario, path)``); this module only gathers them.
"""

from __future__ import annotations

import importlib
import math
import os
import re
from pathlib import Path
from typing import Any

SCENARIO_MODULES = ('sim_nodes.rbrlg.scenarios', 'sim_nodes.fog.bag_scenarios',
                    'sim_nodes.dither.bag_scenarios', 'sim_nodes.noise.bag_scenarios',
                    'sim_nodes.thermal.bag_scenarios', 'sim_nodes.triad.scenarios',
                    'sim_nodes.multiposition.scenarios')
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

GROUPS: dict[str, tuple[str, ...]] = {
    group: members for name in SCENARIO_MODULES
    for group, members in getattr(importlib.import_module(name), 'GROUPS', {}).items()}
"""Names standing for several scenarios (``gyro-calib simulate NAME --out DIR``: one bag each
in DIR), e.g. ``triad_remount_bench`` for the six mounts."""


def write_scenario_bag(name: str, path: str | Path) -> Path:
    """Simulate scenario ``name`` and write its bag at ``path`` (which must not exist)."""
    scenario, module = _ALL[name]
    return module.write_scenario_bag(scenario, path)  # type: ignore[no-any-return]


def write_scenario_files(name: str, directory: str | Path) -> Path:
    """Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` into ``directory``."""
    scenario, module = _ALL[name]
    return module.write_scenario_files(scenario, directory)  # type: ignore[no-any-return]


OVERRIDABLE = ('seed', 'duration_s', 'sample_rate_hz', 'output_rate_hz')
"""Parameter names ``gyro-calib simulate`` may change (wherever they sit in the scenario)."""


def _walk(obj: Any, path: str = '') -> list[tuple[str, Any]]:
    """(dotted path, value) of every field of a (nested) dataclass scenario."""
    import dataclasses

    out: list[tuple[str, Any]] = []
    if not dataclasses.is_dataclass(obj) or isinstance(obj, type):
        return out
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        where = f'{path}{f.name}'
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out += _walk(value, where + '.')
        else:
            out.append((where, value))
    return out


def scenario_parameters(name: str) -> dict[str, Any]:
    """The overridable parameters of scenario ``name``: dotted path → value."""
    return {p: v for p, v in _walk(SCENARIOS[name]) if p.rsplit('.', 1)[-1] in OVERRIDABLE}


def _replace_path(obj: Any, path: list[str], value: Any) -> Any:
    import dataclasses

    head = path[0]
    if len(path) == 1:
        return dataclasses.replace(obj, **{head: value})
    return dataclasses.replace(obj, **{head: _replace_path(getattr(obj, head), path[1:], value)})


def with_overrides(name: str, overrides: dict[str, Any]) -> Any:
    """Scenario ``name`` with parameters changed.

    Scenario ``name`` with parameters changed: ``seed`` (each seed of the scenario gets
    ``seed + k``, k its order, so the sources stay independent), ``duration_s``, a sample
    rate (``sample_rate_hz``, or ``output_rate_hz`` where the scenario names it so).

    Raises:
        KeyError: the scenario has no such parameter (the message names those it has).
    """
    scenario = SCENARIOS[name]
    params = scenario_parameters(name)
    changed: list[tuple[str, Any, Any]] = []
    for key, value in overrides.items():
        names = ('sample_rate_hz', 'output_rate_hz') if key == 'sample_rate_hz' else (key,)
        paths = [p for p in params if p.rsplit('.', 1)[-1] in names]
        if not paths:
            have = sorted({p.rsplit('.', 1)[-1] for p in params})
            raise KeyError(f'scenario {name} has no {key} parameter (it has: '
                           f'{", ".join(have) or "none"}).')
        for k, p in enumerate(paths):
            new = value + k if key == 'seed' else type(params[p])(value)
            scenario = _replace_path(scenario, p.split('.'), new)
            if new != params[p]:
                changed.append((p, params[p], new))
    if changed and isinstance(getattr(scenario, 'description', None), str):
        scenario = _replace_path(scenario, ['description'],
                                 described_with(scenario.description, changed))
    return scenario


def parameters_changed(name: str, overrides: dict[str, Any]) -> list[tuple[str, Any, Any]]:
    """(dotted path, scenario's value, value with ``overrides``) of each parameter they change."""
    before = scenario_parameters(name)
    after = dict(_walk(with_overrides(name, overrides)))
    return [(p, v, after[p]) for p, v in before.items() if p in after and after[p] != v]


def with_node_parameters(name: str, seed: int, sample_rate_hz: float) -> Any:
    """Scenario ``name`` as a simulator node's parameters give it (:func:`with_overrides`).

    ``seed`` −1 keeps the scenario's seeds (else each becomes SEED + k), ``sample_rate_hz``
    0 keeps its rate; so the node publishes what ``gyro-calib simulate`` writes, bit for bit.
    """
    overrides: dict[str, Any] = {}
    if seed >= 0:
        overrides['seed'] = seed
    if sample_rate_hz > 0:
        overrides['sample_rate_hz'] = sample_rate_hz
    return with_overrides(name, overrides) if overrides else SCENARIOS[name]


def _spellings(key: str, value: Any) -> list[str]:
    """How a description writes a parameter value: '280 s', '500 Hz', '1 kHz', 'seed 101'."""
    if key == 'seed':
        return [f'seed {value}']
    if key == 'duration_s':
        return [f'{value:g} s']
    out = [f'{value:g} Hz']
    if value >= 1000 and value % 1000 == 0:
        out.append(f'{value / 1000:g} kHz')
    return out


def described_with(description: str, changed: list[tuple[str, Any, Any]]) -> str:
    """The scenario's sentence made to follow the parameters actually simulated.

    Each value the sentence states ('280 s', '500 Hz', '1 kHz', 'seed 101') is rewritten
    to the value used; a changed parameter the sentence does not state is said after it
    ("Simulated with duration_s = 60 (the scenario's 280)."), so the stored description
    never claims what the bag does not hold.

    Args:
        description: the scenario's own sentence.
        changed: (dotted parameter path, the scenario's value, the value used).
    """
    unsaid = []
    for path, old, new in changed:
        key = path.rsplit('.', 1)[-1]
        key = 'sample_rate_hz' if key == 'output_rate_hz' else key
        found = False
        for was, now in zip(_spellings(key, old), _spellings(key, new)):
            pattern = rf'(?<![\d.]){re.escape(was)}(?![\w])'
            if re.search(pattern, description):
                description = re.sub(pattern, now.replace('\\', r'\\'), description)
                found = True
                break
        if not found:
            unsaid.append(f'{path} = {new:g} (the scenario\'s {old:g})' if key != 'seed'
                          else f'{path} = {new} (the scenario\'s {old})')
    if unsaid:
        description = f'{description.rstrip()} Simulated with {", ".join(unsaid)}.'
    return description


def write_scenario_bag_with(name: str, path: str | Path, overrides: dict[str, Any]) -> Path:
    """Simulate scenario ``name`` with :func:`with_overrides` and write its bag at ``path``.

    For a group (:data:`GROUPS`), ``path`` becomes a directory holding one bag per member
    (written under a temporary name and renamed when all are complete; a given seed becomes
    SEED + 10·j for the j-th member, so the members' noise stays independent).
    """
    if name in GROUPS:
        import shutil

        path = Path(path)
        tmp = path.with_name(f'.{path.name}.partial-{os.getpid()}')  # this run's own
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir()
        try:
            for j, member in enumerate(GROUPS[name]):  # a given seed: SEED + 10·j for member j
                own = ({**overrides, 'seed': overrides['seed'] + 10 * j} if 'seed' in overrides
                       else overrides)
                write_scenario_bag_with(member, tmp / member, own)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        from gyro_calib.bagio.writer import publish_directory

        publish_directory(tmp, path)
        return path
    _, module = _ALL[name]
    return module.write_scenario_bag(  # type: ignore[no-any-return]
        with_overrides(name, overrides), path)


MAX_SIMULATED_MESSAGES = 10_000_000
"""The most messages ``gyro-calib simulate`` writes in one bag: a run whose estimate
(:func:`estimated_message_count`) is larger is refused before any work. A million messages
take about 20 s and 30 MB (noise_rlg_static, 2 cores); the committed scenarios hold at most
0.15 million."""

DEFAULT_RECORDS: dict[str, tuple[int, float]] = {
    'k_tilde_bench': (120043, 100.0),
    'theta_four_position': (94859, 270.9),
    'theta_multi_station': (150079, 428.6),
    'fault_lock_in': (120043, 100.0),
    'fault_missing_zero_index': (120042, 100.0),
    'fault_pulse_gap': (119643, 100.0),
    'fault_index_jitter_burst': (120043, 100.0),
    'k_tilde_mark_in_acceleration': (134445, 112.0),
    'fault_out_of_order': (120043, 100.0),
    'fog_turntable': (81446, 339.2),
    'fog_mapping_self_cal': (84809, 353.1),
    'fog_fault_short_plateau': (29608, 123.3),
    'fog_fault_silent_injection': (31000, 129.1),
    'fog_fault_saturating_staircase': (39694, 165.1),
    'fog_slow_loop_low_rate': (19736, 197.1),
    'dither_z': (88002, 40.0),
    'dither_y': (88002, 40.0),
    'dither_53arcmin_z': (66002, 30.0),
    'dither_53arcmin_y': (66002, 30.0),
    'dither_stripped': (44002, 20.0),
    'dither_small_table': (44002, 20.0),
    'noise_imu_static': (100025, 500.0),
    'noise_imu_band_limited': (60000, 600.0),
    'noise_rlg_static': (139000, 280.0),
    'noise_rlg_spikes': (60000, 120.0),
    'noise_rlg_turning': (60229, 200.8),
    'thermal_calibration': (147004, 29400.0),
    'thermal_validation': (90004, 18000.0),
    'thermal_fault_stuck_sensor': (61204, 12300.0),
    'thermal_ramp_only_sparse': (73081, 20880.0),
    'triad_two_axis_bench': (140393, 140.4),
    'triad_remount_bench_px': (44876, 59.8),
    'triad_remount_bench_mx': (44876, 59.8),
    'triad_remount_bench_py': (44876, 59.8),
    'triad_remount_bench_my': (44876, 59.8),
    'triad_remount_bench_pz': (44876, 59.8),
    'triad_remount_bench_mz': (44876, 59.8),
    'multiposition_hand_turned': (4880, 97.6),
    'multiposition_few_poses_low_rate': (1209, 60.4),
}
"""Scenario name → (message count, record length in s) of its bag as committed in bags/
(test/test_simulate_limit.py checks them against the bags)."""


def estimated_message_count(name: str, overrides: dict[str, Any]) -> int:
    """How many messages scenario (or group) ``name``'s bag(s) would hold with ``overrides``.

    The committed bag's count scaled by the asked sample rate over the scenario's and the
    asked ``duration_s`` over the committed record length (each only where the scenario has
    that parameter): an upper estimate, since index events and table states do not follow the
    sample rate. For a group, the largest member's.
    """
    if name in GROUPS:
        return max(estimated_message_count(m, overrides) for m in GROUPS[name])
    count, length_s = DEFAULT_RECORDS[name]
    params = scenario_parameters(name)
    scale = 1.0
    rates = [v for p, v in params.items()
             if p.rsplit('.', 1)[-1] in ('sample_rate_hz', 'output_rate_hz')]
    if 'sample_rate_hz' in overrides and rates:
        scale *= float(overrides['sample_rate_hz']) / float(rates[0])
    if 'duration_s' in overrides and any(p.rsplit('.', 1)[-1] == 'duration_s' for p in params):
        scale *= float(overrides['duration_s']) / length_s
    return int(math.ceil(count * scale))
