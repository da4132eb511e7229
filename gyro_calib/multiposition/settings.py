"""The multiposition method's settings (docs/multiposition.md; node parameters, ``--config``)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from gyro_calib.config import check_ranges
from gyro_calib.errors import ConfigError

NODE_NAME = 'multiposition_calibration_node'
DEFAULT_TOPIC = '/imu/data'
"""The sensor_msgs/Imu topic read unless ``--topic`` names another."""
STANDARD_GRAVITY = 9.80665
"""m/s², used when neither g nor the latitude is given."""
UNKNOWN_SITE_GRAVITY_STD = 0.026 / math.sqrt(3)
"""u(g) without a site: rectangular over 9.780–9.832 m/s² (equator to pole), m/s²."""


@dataclass(frozen=True, slots=True)
class MultipositionSettings:
    """What a user may set; none needs tuning (the static threshold is the recording's own).

    Attributes:
        window_s: the variance window of the static detection, s (§G.1).
        min_static_s: the shortest static interval used, s.
        height_m: ellipsoidal height of the site, m (with the latitude: local g, eq. (1)).
        gravity_m_s2: local g given directly (NaN: from latitude and height, eq. (1)).
        gravity_std_m_s2: its standard uncertainty (NaN: the anomaly, or the whole Earth's
            range when the latitude is not given either).
        analysis_period_s: live: the calibration is redone after this much more data, s
            (at stamps first stamp + n·period, on the data up to there).
        finish_when_conditioned: live: the node writes the hand-off and exits 0 at the first
            analysis whose pose set is well-conditioned (§G.5 criterion); false: it runs
            until stopped.
        max_condition: the largest cond(JᵀJ) (columns normalised) of either fit in a
            well-conditioned pose set (§G.5).
    """

    window_s: float = 1.0
    min_static_s: float = 1.0
    height_m: float = 0.0
    gravity_m_s2: float = math.nan
    gravity_std_m_s2: float = math.nan
    analysis_period_s: float = 10.0
    finish_when_conditioned: bool = True
    max_condition: float = 20.0

    def __post_init__(self) -> None:
        """Range-check every field (ConfigError naming it)."""
        check_ranges(self, [
            ('window_s', 0.05 <= self.window_s <= 30, 'between 0.05 and 30 s'),
            ('min_static_s', 0 < self.min_static_s <= 600, 'between 0 and 600 s'),
            ('height_m', -500 <= self.height_m <= 10000, 'between −500 and 10000 m'),
            ('gravity_m_s2', math.isnan(self.gravity_m_s2) or 9.7 <= self.gravity_m_s2 <= 9.9,
             'between 9.7 and 9.9 m/s² (or unset)'),
            ('gravity_std_m_s2', math.isnan(self.gravity_std_m_s2)
             or 0 <= self.gravity_std_m_s2 < 0.1, 'between 0 and 0.1 m/s² (or unset)'),
            ('analysis_period_s', self.analysis_period_s > 0, 'positive'),
            ('max_condition', 1 <= self.max_condition <= 1e6, 'between 1 and 10⁶'),
        ])


def settings_from_mapping(values: dict[str, Any], *, source: str) -> MultipositionSettings:
    """The settings from a mapping (config file, node parameters), unknown fields refused.

    Raises:
        ConfigError: an unknown field (named with the known ones) or a value out of range.
    """
    names = {f.name for f in dataclasses.fields(MultipositionSettings)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ConfigError(f'{source}: unknown multiposition setting {unknown[0]!r}; the '
                          f'settings are {", ".join(sorted(names))}.')
    flags = {'finish_when_conditioned'}
    bad = sorted(k for k, v in values.items() if k in flags and not isinstance(v, bool))
    if bad:
        raise ConfigError(f'{source}: multiposition setting {bad[0]!r} must be true or false.')
    try:
        typed: dict[str, Any] = {k: v if k in flags else float(v) for k, v in values.items()}
        return MultipositionSettings(**typed)
    except (TypeError, ValueError):
        raise ConfigError(f'{source}: multiposition settings must be numbers (and '
                          'finish_when_conditioned true or false).') from None
