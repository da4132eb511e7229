"""Old import paths: the bag layer's are gone, the windows' still works and warns.

``gyro_calib.bag``, ``gyro_calib.mcap_columns`` and ``gyro_calib.table_input`` were the
import paths before ``gyro_calib.bagio``; no release outside this repository shipped them,
so they are removed (issue 35 §7). ``gyro_calib.rbrlg.windows`` keeps working for one
release (the same objects under the same names) with a DeprecationWarning naming the new
path and that the old one goes in the next release.
"""

from __future__ import annotations

import pkgutil
import sys
from importlib.machinery import PathFinder
from types import ModuleType

import pytest

import gyro_calib


def _import_afresh(name: str, new: str, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """``import name`` in this file, as a first import (the module runs again).

    It must warn once, at that line: deprecated, import from ``new``, removed in the next
    release.
    """
    monkeypatch.delitem(sys.modules, name, raising=False)
    with pytest.warns(DeprecationWarning) as caught:
        exec(compile(f'import {name}', __file__, 'exec'), {})  # noqa: S102 -- a user's import
    module = sys.modules[name]
    messages = [str(w.message) for w in caught if w.category is DeprecationWarning]
    assert len(messages) == 1, messages
    assert messages[0].startswith(f'{name} is deprecated; import from {new} ')
    assert messages[0].endswith('it will be removed in the next release')
    assert caught[0].filename == __file__, 'the warning points at the importing line'
    return module


def _star(module: ModuleType) -> dict[str, object]:
    namespace: dict[str, object] = {}
    exec(f'from {module.__name__} import *', namespace)  # noqa: S102 -- what a user's star gets
    namespace.pop('__builtins__')
    return namespace


@pytest.mark.parametrize('old', ['gyro_calib.bag', 'gyro_calib.mcap_columns',
                                 'gyro_calib.table_input'])
def test_the_bag_layers_old_paths_are_gone(old: str) -> None:
    """No release outside this repository shipped them (issue 35 §7): no such module.

    Looked up in the package's own directory (an editable install's finder would find a
    checkout elsewhere on the machine).
    """
    name = old.rpartition('.')[2]
    assert name not in {m.name for m in pkgutil.iter_modules(gyro_calib.__path__)}
    assert PathFinder.find_spec(old, list(gyro_calib.__path__)) is None


def test_gyro_calib_rbrlg_windows_gives_the_shared_windows(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The windows' old path (before the triad shared them) warns and gives the same objects."""
    import gyro_calib.windows

    old = _import_afresh('gyro_calib.rbrlg.windows', 'gyro_calib.windows;', monkeypatch)
    star = _star(old)
    assert sorted(star) == sorted(old.__all__)
    for name in old.__all__:
        assert star[name] is getattr(gyro_calib.windows, name), name
