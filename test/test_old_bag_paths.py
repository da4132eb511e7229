"""The old bag import paths still work for one release, and say they are deprecated.

``gyro_calib.bag``, ``gyro_calib.mcap_columns`` and ``gyro_calib.table_input`` were the
import paths before ``gyro_calib.bagio``: code written against them keeps working (the
same objects under the same names) but gets a DeprecationWarning naming the new path and
that the old one goes in the next release.
"""

from __future__ import annotations

import sys
from types import ModuleType

import pytest

import gyro_calib.bagio
import gyro_calib.bagio.tables

MCAP_COLUMNS_NAMES = (
    'CODECS', 'HEADER', 'IMU', 'JOINT_STATE', 'JOINT_WIDTHS', 'KNOWN_TYPES', 'MAX_CHUNK_BYTES',
    'MAX_GROUP_CHUNKS', 'MAX_LAYOUTS', 'PREFETCH', 'TEMPERATURE', 'BagError', 'ChunkPlan',
    'ColumnBatch', 'ColumnDecodeError', 'CorruptBagError', 'CountMismatchError',
    'DamagedChunkError', 'FrameIds', 'GyroCalibError', 'IndexMismatchError',
    'MessageDecodeError', 'ReadPlan', 'TopicColumns', 'UnindexedChunksError',
    'UnsupportedMessageTypeError', 'codec_for', 'iter_column_batches', 'plan_bag', 'typestore',
)
"""Every name ``from gyro_calib.mcap_columns import *`` gave that is not a library's."""


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


def test_gyro_calib_bag_gives_the_bag_layer(monkeypatch: pytest.MonkeyPatch) -> None:
    old = _import_afresh('gyro_calib.bag', 'gyro_calib.bagio;', monkeypatch)
    star = _star(old)
    for name in gyro_calib.bagio.__all__:
        assert star[name] is getattr(gyro_calib.bagio, name), name
    assert old._open_reader is gyro_calib.bagio.storage.open_reader


def test_gyro_calib_mcap_columns_gives_the_column_reader(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from gyro_calib.bagio import chunks, columns, errors, layouts, messages, payloads, plan

    old = _import_afresh('gyro_calib.mcap_columns', 'gyro_calib.bagio.columns', monkeypatch)
    star = _star(old)
    assert sorted(star) == sorted(MCAP_COLUMNS_NAMES)
    homes = (columns, plan, layouts, chunks, payloads, errors, messages)
    for name in MCAP_COLUMNS_NAMES:
        if name == 'GyroCalibError':
            continue
        home = next(m for m in homes if name in vars(m))
        assert star[name] is vars(home)[name], name


def test_gyro_calib_table_input_gives_the_tables(monkeypatch: pytest.MonkeyPatch) -> None:
    old = _import_afresh('gyro_calib.table_input', 'gyro_calib.bagio.tables;', monkeypatch)
    star = _star(old)
    assert {'is_table', 'table_info', 'iter_table_batches', 'read_table'} <= set(star)
    assert star == _star(gyro_calib.bagio.tables)


def test_gyro_calib_rbrlg_windows_gives_the_shared_windows(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The windows' old path (before the triad shared them) warns and gives the same objects."""
    import gyro_calib.windows

    old = _import_afresh('gyro_calib.rbrlg.windows', 'gyro_calib.windows;', monkeypatch)
    star = _star(old)
    assert sorted(star) == sorted(old.__all__)
    for name in old.__all__:
        assert star[name] is getattr(gyro_calib.windows, name), name
