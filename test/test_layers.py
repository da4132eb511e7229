"""The shared core's data flow one way (issues 19 §5, 28): no higher layer, no circle.

The layer order below is the specification (docs/development/layout.md): a module may
import modules of its own layer or of a lower one, never of a higher one, and no chain of
imports comes back to where it started (no circle, inside one layer too: two front doors
included).
Imports are read statically (``ast``), module-level and function-level alike,
``TYPE_CHECKING`` ones included.

0 base        gyro_calib (the package), errors, units, topics (names only), lazy_names
1 bag I/O     gyro_calib.bagio.*; inside it, one direction too (:data:`BAGIO_ORDER`)
2 core        config, estimate, outputs, streams, handoff, state_record and any other
              top-level module not named here
3 session     gyro_calib.session (the shared session interface)
4 methods     gyro_calib.{rbrlg,fog,dither,thermal,noise,triad,multiposition}.* (no method
              imports another:
              test_*_imports, test_thermal_properties)
5 registry    gyro_calib.registry, and imu_conversion (applies several methods' results)
6 drivers     bag_calibration (the offline driver), bag_compensation (a thermal model
              applied to bags)
7 front doors gyro_calib.cli.* (the ``gyro-calib`` command: one module per subcommand),
              nodes.*, report.*, batch.*, and sim_nodes.* (simulators and scenario bags);
              they may import one another, never in a circle

Only the front doors import argparse: a method, a driver or the registry exposes plain
functions and data (what a subcommand prints or writes), never a command line.

A function-level import counts as an edge of the import graph like a module-level one: it
is the same dependency, only deferred (the circle issue 28 removed, cli ↔ report.cli, ran
through function-level imports both ways). The implicit import of a module's parent
package is not an edge: a package that re-exports its modules would otherwise be a circle
by construction.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
METHODS = ('rbrlg', 'fog', 'dither', 'thermal', 'noise', 'triad', 'multiposition')
LAYERS = ('base', 'bag I/O', 'core', 'session', 'methods', 'registry', 'drivers',
          'front doors')
DRIVERS = {'gyro_calib.bag_calibration', 'gyro_calib.bag_compensation'}
FRONT_DOORS = ('cli', 'nodes', 'report', 'batch')
"""gyro_calib's front-door packages (with sim_nodes)."""
BASE = {'gyro_calib', 'gyro_calib.errors', 'gyro_calib.units', 'gyro_calib.topics',
        'gyro_calib.lazy_names'}
BAGIO_ORDER = ('errors', 'messages', 'metadata', 'storage', 'layouts', 'plan', 'chunks',
               'payloads', 'records', 'recovery', 'columns', 'tables', 'writer', 'repair',
               'duplicates', 'reader')
"""Inside the bag layer: each module imports only those before it (the package re-exports)."""


def layer(module: str) -> int:
    """The layer (index into :data:`LAYERS`) of a gyro_calib or sim_nodes module."""
    parts = module.split('.')
    sub = parts[1] if len(parts) > 1 else ''
    if parts[0] == 'sim_nodes':
        return 7
    if module in BASE:
        return 0
    if sub == 'bagio':
        return 1
    if module == 'gyro_calib.session':
        return 3
    if module in DRIVERS:
        return 6
    if sub in METHODS:
        return 4
    if module == 'gyro_calib.registry' or sub == 'imu_conversion':
        return 5
    if sub in FRONT_DOORS:
        return 7
    return 2


def _modules() -> dict[str, Path]:
    out = {}
    for package in ('gyro_calib', 'sim_nodes'):
        for path in sorted((ROOT / package).rglob('*.py')):
            parts = list(path.relative_to(ROOT).with_suffix('').parts)
            if parts[-1] == '__init__':
                parts.pop()
            out['.'.join(parts)] = path
    return out


MODULES = _modules()


def imports(module: str) -> list[tuple[str, int]]:
    """Every gyro_calib/sim_nodes import in ``module``, with its line.

    (imported gyro_calib/sim_nodes module, line) of every import in ``module``; a name
    imported from a package is the submodule when there is one.
    """
    path = MODULES[module]
    package = module if path.name == '__init__.py' else module.rpartition('.')[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                up = package.split('.')[:len(package.split('.')) - node.level + 1]
                base = '.'.join(up + ([base] if base else []))
            for alias in node.names:
                full = f'{base}.{alias.name}'
                out.append((full if full in MODULES else base, node.lineno))
    return [(name, line) for name, line in out if name.split('.')[0] in ('gyro_calib',
                                                                         'sim_nodes')]


def test_the_scan_sees_every_layer() -> None:
    """The specification covers the tree.

    The specification covers the tree: every layer holds modules, and the imports read
    include function-level ones (bag_calibration's, cli.simulate's).
    """
    assert {layer(m) for m in MODULES} == set(range(len(LAYERS)))
    assert any(name == 'gyro_calib.registry' for name, _ in imports('gyro_calib.bag_calibration'))
    nested = [name for name, line in imports('gyro_calib.cli.simulate')
              if name == 'sim_nodes.scenarios']
    assert nested, 'the function-level imports of gyro_calib.cli.simulate were not read'


def test_no_module_imports_a_higher_layer() -> None:
    """Bag I/O → core → session → methods → registry → drivers → front doors, never back."""
    wrong = [f'{module} ({LAYERS[layer(module)]}) imports {name} ({LAYERS[layer(name)]}) '
             f'at line {line}'
             for module in MODULES for name, line in imports(module)
             if layer(name) > layer(module)]
    assert not wrong, '\n'.join(wrong)


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The circles of an import graph: its strongly connected components of two or more.

    Tarjan's algorithm over ``graph`` (module → the modules it imports); each circle is
    returned as its sorted module names, the circles in the order found.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for name in sorted(graph.get(module, ())):
            if name not in index:
                visit(name)
                low[module] = min(low[module], low[name])
            elif name in on_stack:
                low[module] = min(low[module], index[name])
        if low[module] == index[module]:
            component = []
            while True:
                name = stack.pop()
                on_stack.discard(name)
                component.append(name)
                if name == module:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module → the gyro_calib/sim_nodes modules it imports (all that :func:`imports` reads)."""
    return {module: {name for name, _ in imports(module) if name in MODULES and name != module}
            for module in MODULES}


def test_the_circle_check_finds_circles() -> None:
    """The check below can fail: a circle of two, of three, beside modules outside it."""
    assert circles({'a': {'b'}, 'b': {'c'}, 'c': set(), 'd': {'a', 'c'}}) == []
    assert circles({'gyro_calib.cli': {'gyro_calib.report.cli'},
                    'gyro_calib.report.cli': {'gyro_calib.cli'}}) == [
        ['gyro_calib.cli', 'gyro_calib.report.cli']]
    assert circles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a', 'e'}, 'e': {'d'}}) == [
        ['a', 'b', 'c'], ['d', 'e']]


def test_no_import_circle() -> None:
    """No chain of imports comes back to where it started, within a layer or across."""
    graph = import_graph()
    wrong = []
    for circle in circles(graph):
        edges = sorted({(module, name, line) for module in circle
                        for name, line in imports(module) if name in circle and name != module})
        wrong.append(f'circle of {len(circle)}: ' + '; '.join(
            f'{module} imports {name} at line {line}' for module, name, line in edges))
    assert not wrong, '\n'.join(wrong)


def test_only_the_front_doors_read_a_command_line() -> None:
    """Only the front doors import argparse: the layers below expose plain functions."""
    wrong = []
    for module, path in MODULES.items():
        if layer(module) == len(LAYERS) - 1:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Import | ast.ImportFrom):
                names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                         [node.module or ''])
                wrong += [f'{module} ({LAYERS[layer(module)]}) imports argparse at line '
                          f'{node.lineno}' for name in names if name.split('.')[0] == 'argparse']
    assert not wrong, '\n'.join(wrong)


def test_the_bag_layer_flows_one_way_inside() -> None:
    """Inside gyro_calib.bagio the imports flow one way.

    Inside gyro_calib.bagio each module imports only the modules before it (no circle
    such as the former bag ↔ mcap_columns), and never the package (which re-exports).
    """
    assert sorted(BAGIO_ORDER) == sorted(
        m.rpartition('.')[2] for m in MODULES if m.startswith('gyro_calib.bagio.'))
    rank = {f'gyro_calib.bagio.{name}': i for i, name in enumerate(BAGIO_ORDER)}
    wrong = [f'{module} imports {name} at line {line}'
             for module in rank for name, line in imports(module)
             if name == 'gyro_calib.bagio'
             or (name in rank and rank[name] >= rank[module])]
    assert not wrong, '\n'.join(wrong)


def test_registry_topics_are_the_bag_layers_contract() -> None:
    """The registry's topics are the bag layer's contract.

    The bag layer's topic → type table (its default when no topics are handed down) is
    exactly what the registered methods read, in the same order.
    """
    from gyro_calib.bagio.messages import CONTRACT_TYPES
    from gyro_calib.registry import METHODS as REGISTERED
    from gyro_calib.registry import topic_types

    assert list(topic_types(REGISTERED.values()).items()) == list(CONTRACT_TYPES.items())


def test_the_hand_off_schema_is_handed_down(monkeypatch: pytest.MonkeyPatch) -> None:
    """The hand-off schema is handed down.

    gyro_calib.handoff never imports the registry: its schema is a parameter, defaulting
    to the one the registry installs; with none installed, a call without one says what to
    pass.
    """
    from gyro_calib import handoff
    from gyro_calib.registry import handoff_schema

    values = {'k_tilde_rad_per_pulse': 1e-6, 'k_tilde_rad_per_pulse_std': 1e-12}
    prov = handoff.Provenance('live', 0, 1, {})
    monkeypatch.setattr(handoff.schema, '_DEFAULT_SCHEMA', [])
    with pytest.raises(RuntimeError, match='pass schema='):
        handoff.method_calibration('rbrlg', values, prov)
    record = handoff.method_calibration('rbrlg', values, prov, schema=handoff_schema())
    assert record.values['k_tilde_rad_per_pulse'] == 1e-6
