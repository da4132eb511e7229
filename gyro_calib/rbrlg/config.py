"""RBRLG window settings: one frozen dataclass, validated once, loadable from YAML.

The same :class:`KTildeConfig` serves the calibration node (ROS parameters), the
offline functions and tests. YAML files may be plain mappings of these fields or
ROS 2 parameter files (``<node>: {ros__parameters: {...}}``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

from gyro_calib.config import (
    RangeCheck,
    check_ranges,
    read_parameter_file,
    settings_from_mapping,
)
from gyro_calib.errors import ConfigError
from gyro_calib.windows import WindowFields


class KTildeConfigFile(TypedDict, total=False):
    """On-disk shape of the K̃ settings (all optional; defaults in :class:`KTildeConfig`)."""

    revolutions_per_window: int
    fit_half_width_s: float
    fit_order: int
    min_fit_samples_per_side: int
    max_fit_gap_s: float
    max_fit_residual_pulses: float
    rate_tolerance: float
    min_rate_deg_s: float
    window_angle_tolerance_arcsec: float
    index_angle_tolerance_arcsec: float
    max_table_gap_s: float
    max_pulse_gap_s: float
    pulse_jump_tolerance_pulses: float
    max_pair_gap_s: float
    max_window_s: float
    min_pairs: int
    restart_backstep_s: float
    stall_timeout_s: float
    window_angle_source: str
    angle_random_walk_deg_sqrt_h: float


@dataclass(frozen=True, slots=True)
class KTildeConfig(WindowFields):
    """Settings of whole-revolution windowing and the K̃ estimate (METHODS §A.2).

    The window and fit fields come first, from :class:`~gyro_calib.windows.WindowFields`.
    """

    max_pair_gap_s: float = 60.0
    """Largest time between a window and the opposite-direction window it is paired with, s."""
    max_window_s: float = 600.0
    """Longest span the calibrator waits for a window to close before it gives up, s."""
    min_pairs: int = 2
    """Window pairs needed before K̃ is reported."""
    restart_backstep_s: float = 1.0
    """A stamp this far before the newest one means the source restarted, s."""
    stall_timeout_s: float = 60.0
    """A stream whose stamps stop while the other's advance this far is dead: pending index
    events are then resolved with what is there, s. A lagging stream that still advances is
    always waited for, so CPU load or replay speed never changes a result."""
    window_angle_source: str = 'encoder'
    """Angle of a window: 'encoder' (the encoder angle swept between the two index
    instants, which measures the index synchronisation error) or 'nominal' (exactly m·360°,
    the paper's eq. (3))."""
    angle_random_walk_deg_sqrt_h: float = math.nan
    """The gyro's angle random walk, °/√h, if known (spec sheet or a noise
    characterisation); it completes the predicted uncertainty. NaN: unknown, the scatter of
    few pairs is then widened by its Student-t factor."""

    def __post_init__(self) -> None:
        """Validate every field once; raise ConfigError naming the field."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type in ('str', str):
                if not isinstance(value, str):
                    raise ConfigError(f'{f.name} = {value!r} is invalid: it must be a string.')
                continue
            want_int = f.type in ('int', int)
            if isinstance(value, bool) or not isinstance(value, int if want_int else (int, float)):
                kind = 'an integer' if want_int else 'a number'
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be {kind}.')
        checks: list[RangeCheck] = [
            *self.window_checks(angle_within_half_turn=True, jump_may_be_zero=False),
            ('max_pair_gap_s', self.max_pair_gap_s > 0, 'positive'),
            ('max_window_s', self.max_window_s > 0, 'positive'),
            ('min_pairs', self.min_pairs >= 2, 'at least 2 (a standard uncertainty needs two)'),
            ('restart_backstep_s', self.restart_backstep_s > 0, 'positive'),
            ('stall_timeout_s', self.stall_timeout_s > 0, 'positive'),
            ('window_angle_source', self.window_angle_source in ('encoder', 'nominal'),
             "'encoder' or 'nominal'"),
            ('angle_random_walk_deg_sqrt_h', not self.angle_random_walk_deg_sqrt_h < 0,
             'non-negative (or NaN: unknown)'),
        ]
        check_ranges(self, checks)  # one range check for every setting


def k_tilde_config_from_mapping(values: dict[str, Any], *,
                                source: str = 'mapping') -> KTildeConfig:
    """Build a KTildeConfig from a mapping, rejecting unknown keys and wrong types."""
    return settings_from_mapping(KTildeConfig, values, source=source, check_types=True,
                                 known_sorted=False)


def load_k_tilde_config(path: str | Path, *, node_name: str = 'calibration_node') -> KTildeConfig:
    """Load settings from a YAML file (plain mapping or ROS 2 parameter file).

    Raises:
        ConfigError: if the file cannot be read or parsed, or a field is wrong.
    """
    return k_tilde_config_from_mapping(read_parameter_file(path, node_name=node_name),
                                       source=str(path))
