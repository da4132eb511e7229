"""``gyro-calib export``: the hand-off in each navigation stack's own keys and units.

Pure core (no ROS). One module per consumer; :data:`FORMATS` maps the ``--format`` name to
its writer, :func:`export_text` reads a hand-off and writes one. Each number carries a
comment with its source key, SI value and conversion (:mod:`gyro_calib.export.common`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from gyro_calib.export.autoware import autoware_text
from gyro_calib.export.common import STREAMS, ExportOptions, default_topic
from gyro_calib.export.fast_lio import fast_lio_text
from gyro_calib.export.gtsam import gtsam_text
from gyro_calib.export.kalibr import kalibr_text
from gyro_calib.export.lio_sam import lio_sam_text
from gyro_calib.export.openvins import openvins_text
from gyro_calib.export.robot_localization import robot_localization_text
from gyro_calib.export.source import (
    ExportError,
    ExportSource,
    read_source,
    with_accelerometer_of,
)
from gyro_calib.export.vins_fusion import vins_fusion_text

FORMATS: dict[str, Callable[[ExportSource, ExportOptions], str]] = {
    'kalibr': kalibr_text,
    'openvins': openvins_text,
    'gtsam': gtsam_text,
    'lio-sam': lio_sam_text,
    'fast-lio': fast_lio_text,
    'vins-fusion': vins_fusion_text,
    'autoware': autoware_text,
    'robot-localization': robot_localization_text,
}
"""``--format`` name → writer."""


def export_text(handoff: str | Path, fmt: str, options: ExportOptions) -> str:
    """The text of ``fmt`` from the hand-off file ``handoff``.

    Raises:
        ExportError: one line: the file cannot be read, or the consumer cannot take it.
    """
    src = read_source(handoff)
    if options.accel_from:
        src = with_accelerometer_of(src, read_source(options.accel_from))
    return FORMATS[fmt](src, replace(options, topic=default_topic(src, options)))


__all__ = ['ExportError', 'ExportOptions', 'ExportSource', 'FORMATS', 'STREAMS', 'export_text',
           'read_source']
