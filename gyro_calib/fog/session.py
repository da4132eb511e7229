"""The FOG method behind the shared front door (registry, CLI, bag calibration, hand-off)."""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from gyro_calib import topics
from gyro_calib.config import read_parameter_file
from gyro_calib.fog.calibrator import FogCalibrator
from gyro_calib.fog.keys import METHOD
from gyro_calib.fog.settings import FogSettings, fog_settings_from_mapping
from gyro_calib.session import CalibrationOptions, MethodSession

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bag import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection

TOPICS = {topics.FOG_OUTPUT: 'sensor_msgs/msg/JointState',
          topics.FOG_INJECTION: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_JOINT_STATES: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_ZERO_INDEX: 'std_msgs/msg/Header'}


def fog_settings(options: CalibrationOptions) -> FogSettings:
    """The FOG settings: the node's parameters, then the config file's values, then the
    latitude from the flags or the bag."""
    values = dict(options.settings)
    source = 'ROS parameters'
    if options.config_file is not None:
        values.update(read_parameter_file(options.config_file, node_name='fog_calibration_node'))
        source = str(options.config_file)
    settings = fog_settings_from_mapping(values, source=source) if values else FogSettings()
    latitude = options.latitude
    if math.isfinite(latitude):
        settings = dataclasses.replace(settings, latitude_deg=latitude)
    return settings


class FogSession(MethodSession):
    """Turntable K (IEEE Std 952), equivalence mapping and ladder-wave self-calibration."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Build the calibrator from the options."""
        self.calibrator = FogCalibrator(fog_settings(options))
        self._seen_rejections = 0

    def topics(self) -> dict[str, str]:
        """Output, injection and (for the turntable phases) the rate table."""
        return dict(TOPICS)

    def feed(self, batch: SampleBatch) -> None:
        """Output counts, injection levels, table joint_states and zero-index events."""
        cal = self.calibrator
        out = batch.joint_state(topics.FOG_OUTPUT)
        if out is not None:
            cal.extend_output(out[0], out[1])
        inj = batch.joint_state(topics.FOG_INJECTION)
        if inj is not None:
            cal.extend_injection(inj[0], inj[1])
        table = batch.joint_state(topics.RATE_TABLE_JOINT_STATES)
        if table is not None:
            cal.extend_table_states(*table)
        index = batch.stamps(topics.RATE_TABLE_ZERO_INDEX)
        if index is not None:
            cal.extend_zero_index(index)

    def process(self, *, flush: bool = False) -> list[str]:
        """Measure finished segments and plateaus."""
        return self.calibrator.process(flush=flush)

    def results(self) -> dict[str, Estimate]:
        """By hand-off key."""
        return self.calibrator.results()

    def missing(self) -> dict[str, str]:
        """Why each FOG key is not measured."""
        return self.calibrator.missing()

    def rejections(self) -> list[Rejection]:
        """Segments, plateaus and events rejected, with reasons."""
        return list(self.calibrator.rejections)

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first to the last segment or plateau measured."""
        cal = self.calibrator
        stamps = [s.start_ns for s in cal.segments] + [s.end_ns for s in cal.segments]
        stamps += [p.start_ns for p in cal.plateaus] + [p.end_ns for p in cal.plateaus]
        return (min(stamps), max(stamps)) if stamps else None

    def summary_lines(self) -> list[str]:
        """The self-calibration table (K against plateaus used), and what is missing."""
        return self.calibrator.summary()

    def info_lines(self) -> list[str]:
        """The constant-rate segments and plateaus found."""
        cal = self.calibrator
        lines = [f'turntable segments measured: {len(cal.segments)}; injection plateaus: '
                 f'{len(cal.plateaus)}']
        for s in cal.segments:
            lines.append(f'  t={s.start_ns / 1e9:.3f} s → {s.end_ns / 1e9:.3f} s  '
                         f'{math.degrees(s.rate_rad_s):+.4f} °/s, {s.output_rate_counts_s:.6g} counts/s')
        return lines

    def plot(self, out_dir: Path) -> list[Path]:
        """The turntable nonlinearity curve and self-cal K against the range used."""
        from gyro_calib.fog.plots import plot_fog

        return plot_fog(self.calibrator, out_dir)
