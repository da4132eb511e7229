"""The export formats' and streams' names: what ``gyro-calib export --help`` lists.

Kept apart from the writers (:data:`gyro_calib.export.WRITERS`), so listing them imports
none (no NumPy, no YAML).
"""

from __future__ import annotations

FORMAT_NAMES = ('kalibr', 'openvins', 'gtsam', 'lio-sam', 'fast-lio', 'vins-fusion', 'autoware',
                'robot-localization')
"""Every ``--format`` name, in the order ``--help`` lists them."""

STREAMS = ('compensated', 'raw')
"""``compensated``: the consumer subscribes to gyro_calib's imu_corrector output (scale factor,
axes, bias, thermal model applied upstream); ``raw``: to the sensor driver's own stream."""


def export_mark(fmt: str) -> str:
    """The words every file of ``--format fmt`` carries in its leading comment block.

    :func:`gyro_calib.export.common.header` writes them; ``export --out`` recognises by them
    a file it may replace (an earlier export of the same format).
    """
    return f'gyro-calib export --format {fmt}.'
