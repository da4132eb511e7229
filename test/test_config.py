"""Calibration settings: one validated dataclass, loadable from the shipped YAML."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from gyro_calib.config import field_descriptions
from gyro_calib.errors import ConfigError
from gyro_calib.rbrlg.config import KTildeConfig, k_tilde_config_from_mapping, load_k_tilde_config
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig

REPO = Path(__file__).resolve().parents[1]


def test_shipped_parameter_file_loads() -> None:
    cfg = load_k_tilde_config(REPO / 'config' / 'calibration.yaml')
    assert cfg.revolutions_per_window == 5
    assert cfg == KTildeConfig()


def test_plain_mapping_file_loads_and_ints_become_floats(tmp_path: Path) -> None:
    path = tmp_path / 'c.yaml'
    path.write_text('revolutions_per_window: 3\nfit_half_width_s: 1\n')
    cfg = load_k_tilde_config(path)
    assert (cfg.revolutions_per_window, cfg.fit_half_width_s) == (3, 1.0)


def test_wrong_type_names_field_and_file(tmp_path: Path) -> None:
    path = tmp_path / 'c.yaml'
    path.write_text('min_pairs: two\n')
    with pytest.raises(ConfigError, match=r'min_pairs in .*c\.yaml must be an integer'):
        load_k_tilde_config(path)


@pytest.mark.parametrize('cls', [KTildeConfig, RateTableConfig, RingLaserGyroConfig])
def test_every_parameter_has_a_description(cls: type) -> None:
    descriptions = field_descriptions(cls)
    assert {f.name for f in dataclasses.fields(cls)} == set(descriptions)
    assert all(len(text) > 10 for text in descriptions.values())


def test_mapping_rejects_bool_for_number() -> None:
    with pytest.raises(ConfigError, match='rate_tolerance'):
        k_tilde_config_from_mapping({'rate_tolerance': True})
