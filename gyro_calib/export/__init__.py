"""``gyro-calib export``: the hand-off in each navigation stack's own keys and units.

Pure core (no ROS). One module per consumer; :data:`FORMATS` maps the ``--format`` name to
its writer, :func:`export_text` reads a hand-off and writes one. Each number carries a
comment with its source key, SI value and conversion (:mod:`gyro_calib.export.common`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.export.names import FORMAT_NAMES, STREAMS

if TYPE_CHECKING:  # the names as the type checker sees them; at run time, on first use
    from gyro_calib.export.common import ExportOptions
    from gyro_calib.export.source import ExportError, ExportSource, read_source

    FORMATS: dict[str, Callable[[ExportSource, ExportOptions], str]]
    """``--format`` name → writer."""

WRITERS = {
    'kalibr': 'gyro_calib.export.kalibr:kalibr_text',
    'openvins': 'gyro_calib.export.openvins:openvins_text',
    'gtsam': 'gyro_calib.export.gtsam:gtsam_text',
    'lio-sam': 'gyro_calib.export.lio_sam:lio_sam_text',
    'fast-lio': 'gyro_calib.export.fast_lio:fast_lio_text',
    'vins-fusion': 'gyro_calib.export.vins_fusion:vins_fusion_text',
    'autoware': 'gyro_calib.export.autoware:autoware_text',
    'robot-localization': 'gyro_calib.export.robot_localization:robot_localization_text',
}
"""``--format`` name → its writer as 'module:function', imported when used (the names are
:data:`~gyro_calib.export.names.FORMAT_NAMES`, which ``gyro-calib export --help`` lists
without importing a writer)."""

_WHERE = {'ExportError': 'gyro_calib.export.source', 'ExportSource': 'gyro_calib.export.source',
          'read_source': 'gyro_calib.export.source', 'ExportOptions': 'gyro_calib.export.common'}


def writer(fmt: str) -> Callable[[ExportSource, ExportOptions], str]:
    """The writer of the format ``fmt`` (a name of :data:`FORMAT_NAMES`), imported now."""
    module, name = WRITERS[fmt].split(':')
    return getattr(importlib.import_module(module), name)  # type: ignore[no-any-return]


def __getattr__(name: str) -> Any:
    """``FORMATS`` (name → writer) and the re-exported names, imported on first use (PEP 562)."""
    if name == 'FORMATS':
        value: Any = {fmt: writer(fmt) for fmt in FORMAT_NAMES}
    elif name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
    else:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    globals()[name] = value
    return value


def export_text(handoff: str | Path, fmt: str, options: ExportOptions) -> str:
    """The text of ``fmt`` from the hand-off file ``handoff``.

    Raises:
        ExportError: one line: the file cannot be read, or the consumer cannot take it.
    """
    from gyro_calib.export.common import default_topic
    from gyro_calib.export.source import read_source, with_accelerometer_of

    src = read_source(handoff)
    if options.accel_from:
        src = with_accelerometer_of(src, read_source(options.accel_from))
    return writer(fmt)(src, replace(options, topic=default_topic(src, options)))


__all__ = ['FORMATS', 'FORMAT_NAMES', 'STREAMS', 'WRITERS', 'ExportError', 'ExportOptions',
           'ExportSource', 'export_text', 'read_source', 'writer']
