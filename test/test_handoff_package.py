"""The hand-off package flows one way inside, and its front keeps every name importable.

gyro_calib.handoff is one module an idea (issue 28): each submodule imports only those
before it in :data:`ORDER` (no circle), never the package itself (which re-exports them), and
every name that code, tests, benchmarks or docs import from ``gyro_calib.handoff`` is still
there.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / 'gyro_calib' / 'handoff'
ORDER = ('schema', 'runs', 'scale_factor', 'merge', 'sensor', 'calibration', 'layout', 'load',
         'write')
"""Low → high: keys and checks, runs, the scale-factor rule, the merge rules, the record,
its on-disk shape, reading, writing."""


def _handoff_imports(path: Path) -> list[tuple[str, int]]:
    """(gyro_calib.handoff module, line) of every import of the package or a submodule."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            out += [(f'{node.module}.{a.name}' if node.module == 'gyro_calib.handoff'
                     and a.name in ORDER else node.module, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            raise AssertionError(f'{path.name}:{node.lineno}: a relative import; name the module')
    return [(m, line) for m, line in out
            if m == 'gyro_calib.handoff' or m.startswith('gyro_calib.handoff.')]


def test_each_submodule_imports_only_those_before_it() -> None:
    assert sorted(p.stem for p in PACKAGE.glob('*.py') if p.stem != '__init__') == sorted(ORDER)
    wrong = []
    for rank, name in enumerate(ORDER):
        for module, line in _handoff_imports(PACKAGE / f'{name}.py'):
            target = module.removeprefix('gyro_calib.handoff').lstrip('.')
            if target not in ORDER[:rank]:
                wrong.append(f'{name}.py:{line} imports {module}')
    assert not wrong, '\n'.join(wrong)


def _names_imported_from_the_package() -> set[str]:
    names = set()
    for folder in ('gyro_calib', 'sim_nodes', 'test', 'benchmarks', 'docs'):
        for path in (ROOT / folder).rglob('*.py'):
            if PACKAGE in path.parents:
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
                if isinstance(node, ast.ImportFrom) and node.module == 'gyro_calib.handoff':
                    names.update(a.name for a in node.names if a.name not in ORDER)
    return names


def test_the_package_re_exports_every_name_imported_from_it() -> None:
    package = importlib.import_module('gyro_calib.handoff')
    names = _names_imported_from_the_package()
    assert {'Calibration', 'load_calibration', 'update_calibration', 'HandoffKey'} <= names
    assert sorted(names - set(package.__all__)) == []
    assert [n for n in package.__all__ if not hasattr(package, n)] == []
