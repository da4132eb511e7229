"""A bench setting /sim/scenario offers and the node leaves unset: the advice must work.

The triad node's tilt_deg, tilt_std_arcsec, station_offset_deg and position_table_revolutions
are not ROS parameters (they come from ``config_file``): a ``-p tilt_deg:=45.0`` would be
ignored, so the warning names the config file for them, and ``-p`` only for a declared
parameter (latitude_deg).
"""

from __future__ import annotations

from typing import Any

from fake_node import FakeLogger

from gyro_calib.nodes.method_node import SimScenarioBench
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions


class _Node:
    def __init__(self, declared: set[str]) -> None:
        self.declared, self.logger = declared, FakeLogger()

    def create_subscription(self, *args: Any) -> None:
        return None

    def has_parameter(self, name: str) -> bool:
        return name in self.declared

    def get_logger(self) -> FakeLogger:
        return self.logger

    def get_name(self) -> str:
        return 'triad_calibration_node'


def test_unset_bench_settings_are_advised_the_way_this_node_takes_them() -> None:
    node = _Node({'latitude_deg', 'heading_deg', 'gyro_id', 'config_file'})
    bench = SimScenarioBench(node, METHODS['triad'].bench_settings,  # type: ignore[arg-type]
                             lambda stored: None)
    stored = (('/sim/scenario (triad_two_axis_bench)',
               {'latitude_deg': 28.2, 'tilt_deg': 45.0, 'tilt_std_arcsec': 60.0}),)
    bench.tell_unset(CalibrationOptions(stored_benches=stored))
    lines = node.logger.lines
    latitude = next(x for x in lines if 'gives latitude_deg' in x)
    assert 'pass -p latitude_deg:=28.2 to use it' in latitude
    tilt = next(x for x in lines if 'gives tilt_deg' in x)
    assert '-p tilt_deg' not in tilt
    assert "set tilt_deg: 45.0 under triad_calibration_node: ros__parameters: in the " \
           "config_file to use it" in tilt
