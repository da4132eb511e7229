"""Bench settings (issue 17 items 1, 2, 10).

Bench settings (issue 17 items 1, 2, 10): each method takes the settings stored with its own
bags, bags that disagree are refused naming the flag that decides, and every bench setting —
flag, ``--config`` field, node parameter, stored bench setting — is range-checked by the same
code, its unit and range in the message.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
import yaml
from ros_in_process import init_undiscovered

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.config import BENCH_SETTINGS
from gyro_calib.errors import ConfigError
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions

BAGS = Path(__file__).resolve().parents[1] / 'bags'
SCENARIO_KEY = 'gyro_calib.scenario'

OUT_OF_RANGE: dict[str, Any] = {
    'latitude_deg': 128.2, 'heading_deg': 400.0, 'sense_axis_elevation_deg': 91.0,
    'sense_axis_azimuth_deg': -361.0, 'position_table_revolutions': 0,
    'scale_factor_rad_per_pulse': -4e-6, 'fog_scale_factor_counts_per_rad': 0.0,
}
"""One value just outside each numeric bench setting's range (written here, from the
physics: |φ| ≤ 90°, a heading or azimuth within a turn each way, n ≥ 1, K > 0)."""


def restamped_copy(bag: Path, where: Path, **bench: Any) -> Path:
    """A copy of ``bag`` with changed bench settings.

    A copy of ``bag`` (its MCAP linked, not copied) whose stored bench settings are
    changed to ``bench``.
    """
    where.mkdir(parents=True)
    for item in bag.iterdir():
        if item.name != 'metadata.yaml':
            (where / item.name).symlink_to(item.resolve())
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())
    info = meta['rosbag2_bagfile_information']
    scenario = yaml.safe_load(info['custom_data'][SCENARIO_KEY])
    scenario['bench'].update(bench)
    info['custom_data'][SCENARIO_KEY] = yaml.safe_dump(scenario)
    (where / 'metadata.yaml').write_text(yaml.safe_dump(meta))
    return where


def _bias(outcome: Any, method: str, key: str) -> float:
    return float(outcome.sessions[method].results()[key].value)


# -- item 1: each method takes the settings stored with its own bags ------------------------


def test_each_method_takes_the_bench_settings_stored_with_its_own_bags() -> None:
    """Each method takes the bench settings stored with its bags.

    Issue repro: k_tilde_bench (28.2°) beside fog_turntable (45.75°) changed the FOG bias
    from 0.4965 to 4.1627 °/h; in the other order it spoiled the RBRLG bias.
    """
    alone_fog = calibrate_bags([BAGS / 'fog_turntable'])
    alone_rbrlg = calibrate_bags([BAGS / 'k_tilde_bench'])
    for order in ([BAGS / 'k_tilde_bench', BAGS / 'fog_turntable'],
                  [BAGS / 'fog_turntable', BAGS / 'k_tilde_bench']):
        both = calibrate_bags(order)
        assert _bias(both, 'fog', 'fog_bias_rad_s') == _bias(alone_fog, 'fog', 'fog_bias_rad_s')
        assert _bias(both, 'rbrlg', 'bias_rad_s') == _bias(alone_rbrlg, 'rbrlg', 'bias_rad_s')
        assert both.options['fog'].latitude == 45.75
        assert both.options['rbrlg'].latitude == 28.2


@pytest.fixture(scope='module')
def second_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Another run of the FOG bench: other seeds, other data.

    A copy of one bag is refused as the same data twice before its settings are looked at.
    """
    where = tmp_path_factory.mktemp('second_run') / 'fog_turntable_seed5'
    assert gyro_calib_main(['simulate', 'fog_turntable', '--seed', '5', '--out',
                            str(where)]) == 0
    return where


def test_bags_of_one_method_that_store_different_settings_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], second_run: Path) -> None:
    other = restamped_copy(second_run, tmp_path / 'other_site', latitude_deg=30.0)
    capsys.readouterr()
    code = gyro_calib_main(['calibrate', str(BAGS / 'fog_turntable'), str(other),
                            '--no-progress'])
    out, err = capsys.readouterr()
    assert code == 2 and out == ''
    line = err.strip()
    assert '\n' not in line
    for part in ('latitude_deg', str(BAGS / 'fog_turntable'), str(other), '45.75', '30.0',
                 '--latitude-deg'):
        assert part in line


def test_the_flag_decides_between_bags_that_disagree_and_says_so(tmp_path: Path,
                                                                 second_run: Path) -> None:
    other = restamped_copy(second_run, tmp_path / 'other_site', latitude_deg=30.0)
    outcome = calibrate_bags([BAGS / 'fog_turntable', other],
                             options=CalibrationOptions(latitude_deg=45.75))
    assert outcome.options['fog'].latitude == 45.75
    assert outcome.notes == []  # the flag agrees with one bag; the bags' conflict is decided


def test_a_flag_that_overrides_a_stored_setting_is_noted(capsys: pytest.CaptureFixture[str],
                                                         ) -> None:
    assert gyro_calib_main(['calibrate', str(BAGS / 'fog_turntable'), '--latitude-deg', '45',
                            '--no-progress']) == 0
    out = capsys.readouterr().out
    assert ('fog: note: latitude_deg: --latitude-deg gives 45.0 ° but the bench settings '
            f'stored in {BAGS / "fog_turntable"} says 45.75 °') in out


# -- item 2: one range check for every front door ------------------------------------------


@pytest.mark.parametrize('name', sorted(OUT_OF_RANGE))
def test_every_bench_setting_is_range_checked_with_unit_and_range(name: str,
                                                                  tmp_path: Path) -> None:
    spec = BENCH_SETTINGS[name]
    value = OUT_OF_RANGE[name]
    attribute = 'scale_factor_counts_per_rad' if name.startswith('fog_') else name
    expected = spec.expected()
    assert spec.unit in expected
    for given_by, origin in (('flag', spec.flag), ('parameter', f'parameter {name}')):
        with pytest.raises(ConfigError) as err:
            CalibrationOptions(**{attribute: value}, given_by=given_by)
        assert f'{name} = {value!r}' in str(err.value)
        assert f'({origin})' in str(err.value) and expected in str(err.value)
    config = tmp_path / 'c.yaml'
    with pytest.raises(ConfigError, match=f'config file {config}'):
        CalibrationOptions(config_file=config, config_bench={name: value})
    stored = CalibrationOptions(stored_benches=(('bag B', {name: value}),))
    with pytest.raises(ConfigError, match=f'{name} = .*stored in bag B.*{expected}'):
        stored.setting(name)


def test_latitude_out_of_range_refused_by_every_method_front_door(
        capsys: pytest.CaptureFixture[str]) -> None:
    """Issue repro: ``--latitude-deg 128.2`` gave an RBRLG bias with exit 0."""
    for bag in ('k_tilde_bench', 'fog_turntable', 'thermal_validation'):
        code = gyro_calib_main(['calibrate', str(BAGS / bag), '--latitude-deg', '128.2',
                                '--no-progress'])
        out, err = capsys.readouterr()
        assert (code, out) == (2, '')
        assert 'latitude_deg = 128.2 ° (--latitude-deg) is invalid: it must be a number ' \
               'between -90 and 90 °.' in err


def test_a_stored_bench_setting_out_of_range_is_refused(tmp_path: Path) -> None:
    bad = restamped_copy(BAGS / 'k_tilde_bench', tmp_path / 'bad', latitude_deg=128.2)
    with pytest.raises(ConfigError, match=r'latitude_deg = 128\.2 °.*stored in .*bad.*-90 and '
                       r'90 °'):
        calibrate_bags([bad])


def test_every_method_declares_only_known_bench_settings() -> None:
    for method in METHODS.values():
        assert set(method.bench_settings) <= set(BENCH_SETTINGS), method.name
        assert method.node and method.settings_fields()


# -- item 10: one parameter schema for node parameters and --config ------------------------


def test_a_config_file_takes_every_parameter_of_the_node(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str],
                                                         ) -> None:
    """``latitude_deg`` in a ``--config`` file is accepted.

    Issue repro: ``latitude_deg`` in a ``--config`` file was an "unknown field" (RBRLG).
    The file may be the node's ROS 2 parameter file with its bench and node-only parameters.
    """
    config = tmp_path / 'rbrlg.yaml'
    config.write_text(yaml.safe_dump({'calibration_node': {'ros__parameters': {
        'latitude_deg': 28.2, 'heading_deg': 0.0, 'position_table_revolutions': 1,
        'revolutions_per_window': 5, 'output_file': 'x.yaml', 'gyro_id': 'A-1'}}}))
    assert gyro_calib_main(['calibrate', str(BAGS / 'k_tilde_bench'), '--config', str(config),
                            '--json', '--no-progress']) == 0
    doc = json.loads(capsys.readouterr().out)
    bias = doc['methods']['rbrlg']['results']['bias_rad_s']['value']
    assert bias == _bias(calibrate_bags([BAGS / 'k_tilde_bench']), 'rbrlg', 'bias_rad_s')


def test_a_config_file_setting_wins_over_the_bag_and_loses_to_the_flag(tmp_path: Path) -> None:
    config = tmp_path / 'fog.yaml'
    config.write_text('latitude_deg: 40.0\n')
    from_file = calibrate_bags([BAGS / 'fog_turntable'],
                               options=CalibrationOptions(config_file=config))
    assert from_file.options['fog'].setting_with_origin('latitude_deg') == (
        40.0, f'config file {config}')
    assert any('latitude_deg: config file' in n for n in from_file.notes)
    flag = CalibrationOptions(config_file=config, latitude_deg=45.75)
    assert calibrate_bags([BAGS / 'fog_turntable'], options=flag).options['fog'].latitude == 45.75


def test_an_unknown_config_field_is_still_refused_listing_the_fields(tmp_path: Path) -> None:
    config = tmp_path / 'rbrlg.yaml'
    config.write_text('latitude: 28.2\n')
    with pytest.raises(ConfigError, match='unknown field.*latitude in .*known fields'):
        calibrate_bags([BAGS / 'k_tilde_bench'], options=CalibrationOptions(config_file=config))


def test_conventions_of_heading_and_azimuth_are_stated() -> None:
    """The conventions of heading and azimuth are stated.

    Issue 17 item 15: --heading-deg 'from East' beside --sense-axis-azimuth-deg 'from
    North'; both now state their zero, their positive sense and how they relate.
    """
    heading = BENCH_SETTINGS['heading_deg'].description
    azimuth = BENCH_SETTINGS['sense_axis_azimuth_deg'].description
    assert 'from East towards North' in heading and '90° − the azimuth from North' in heading
    assert 'from North towards East' in azimuth and '90° − a heading from East' in azimuth
    assert math.isfinite(BENCH_SETTINGS['heading_deg'].high)



@pytest.mark.parametrize('method, field, value, message', [
    ('rbrlg', 'fit_half_width_s', -1.0, 'fit_half_width_s = -1.0 s is invalid: it must be '
     'positive.'),
    ('fog', 'min_segment_s', 0.0, 'min_segment_s = 0.0 s is invalid: it must be positive.'),
    ('dither', 'block_s', 0.0, 'block_s = 0.0 s is invalid: it must be between 0.1 and 600 s.'),
    ('thermal', 'max_pulse_gap_s', 0.0, 'max_pulse_gap_s = 0.0 s is invalid: it must be '
     'positive.'),
    ('noise', 'reorder_window_s', -1.0, 'reorder_window_s = -1.0 s is invalid: it must be zero '
     'or positive.'),
    ('fog', 'latitude_deg', 128.2, 'latitude_deg = 128.2 ° (settings) is invalid: it must be a '
     'number between -90 and 90 °.'),
    ('thermal', 'latitude_deg', -91.0, 'latitude_deg = -91.0 ° (settings) is invalid'),
    ('noise', 'scale_factor_rad_per_pulse', 0.5, 'scale_factor_rad_per_pulse = 0.5 rad/pulse '
     '(settings) is invalid: it must be a positive number, at most 0.01 rad/pulse.'),
])
def test_every_methods_settings_are_range_checked_by_the_same_code(
        method: str, field: str, value: float, message: str) -> None:
    """One range check for every method's settings.

    Issue 17 item 2: one check (config.check_ranges) for every method's settings, the value
    with its unit; the bench settings among them checked as flags and parameters are.
    """
    with pytest.raises(ConfigError) as err:
        METHODS[method].settings_class()(**{field: value})
    assert message in str(err.value)


NODES = {'rbrlg': ('gyro_calib.nodes.calibration_node', 'CalibrationNode'),
         'fog': ('gyro_calib.nodes.fog_calibration_node', 'FogCalibrationNode'),
         'thermal': ('gyro_calib.nodes.thermal_calibration_node', 'ThermalCalibrationNode'),
         'noise': ('gyro_calib.nodes.noise_node', 'NoiseNode')}
NEEDS = {'thermal': {'scale_factor_rad_per_pulse': 1.1150714665519326e-05,
                     'latitude_deg': 34.26},
         'noise': {'scale_factor_rad_per_pulse': 4.0860157e-06}}


def _declared_parameters(method: str) -> dict[str, Any]:
    """Every parameter the method's node declares, with its value (no output file)."""
    import importlib

    import rclpy

    from gyro_calib.nodes.processes import ros_args

    module, cls = NODES[method]
    init_undiscovered(args=ros_args({'output_file': '', **NEEDS.get(method, {})}))
    try:
        node = getattr(importlib.import_module(module), cls)()
        try:
            return {k: p.value for k, p in node._parameters.items()}  # as ros2 param dump
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()


@pytest.mark.parametrize('method', sorted(NODES))
def test_a_nodes_own_parameter_file_is_a_valid_config(method: str, tmp_path: Path) -> None:
    """A node's own parameter file is a valid config.

    Issue 17 item 10: one parameter schema — every parameter a node declares (as written by
    ``ros2 param dump``) is accepted by ``--config`` / ``config_file``.
    """
    declared = _declared_parameters(method)
    assert 'latitude_deg' in declared or method in ('noise',)
    config = tmp_path / 'params.yaml'
    values = dict(declared)  # NaN (not given) and inf (no limit) as ros2 param dump writes them
    assert any(isinstance(v, float) and math.isnan(v) for v in values.values())
    config.write_text(yaml.safe_dump({METHODS[method].node: {'ros__parameters': values}}))
    options = CalibrationOptions(config_file=config, topic='/gyro/pulses' if method == 'noise'
                                 else None)
    session = METHODS[method].make_session(options)  # no "unknown field"
    assert session.name == method
