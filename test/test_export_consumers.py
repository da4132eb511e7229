"""``gyro-calib export`` files read by each navigation stack's own reader (issue 36).

Not our reader, not PyYAML: OpenCV's ``cv::FileStorage`` as OpenVINS and VINS-Fusion read,
rclpy's parameter parsing under the consumer's node name, Autoware's JSON schema
(:mod:`consumer_readers`). Values are checked against the conversions docs/methods.md §E.5
derives from each consumer's propagation code.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from consumer_readers import OPENVINS_MODELS, opencv_tree, openvins_imu0, vins_fusion_config
from test_export import export

from gyro_calib.export.opencv_yaml import read_opencv_yaml

pytest_plugins = ['test_export']


# -- 1. OpenCV files: every string and number as cv::FileStorage reads it ---------------------

OPENCV_CASES = [('openvins', 'imu_handoff', {}), ('openvins', 'triad_handoff', {}),
                ('openvins', 'triad_handoff', {'stream': 'raw', 'raw_scale_rad_per_pulse': 4e-6}),
                ('vins-fusion', 'imu_handoff', {})]


@pytest.mark.parametrize(('fmt', 'handoff', 'kw'), OPENCV_CASES)
def test_opencv_reads_every_string_and_number_we_meant(
        fmt: str, handoff: str, kw: dict[str, Any], request: pytest.FixtureRequest) -> None:
    """cv::FileStorage keeps an inline comment inside a plain string: none may be written."""
    text = export(request.getfixturevalue(handoff), fmt, **kw)
    assert opencv_tree(text) == read_opencv_yaml(text)


@pytest.mark.parametrize(('handoff', 'kw'), [(h, kw) for f, h, kw in OPENCV_CASES
                                             if f == 'openvins'])
def test_openvins_starts_with_a_model_it_knows_and_the_topic_given(
        handoff: str, kw: dict[str, Any], request: pytest.FixtureRequest) -> None:
    text = export(request.getfixturevalue(handoff), 'openvins', topic='/imu/data', **kw)
    imu0 = openvins_imu0(text)
    assert imu0['model'] == 'kalibr' and imu0['model'] in OPENVINS_MODELS
    assert imu0['rostopic'] == '/imu/data'


def test_vins_fusion_reads_use_imu_and_the_topic_given(imu_handoff: Path) -> None:
    cfg = vins_fusion_config(export(imu_handoff, 'vins-fusion', topic='/imu/data'))
    assert cfg['imu'] == 1 and cfg['imu_topic'] == '/imu/data'
