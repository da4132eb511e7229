"""The INS hand-off file: exact round trip, atomic replacement, a clear error for every bad file."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import pytest
import yaml

import gyro_calib
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import (
    FORMAT_VERSION,
    GyroCalibration,
    HandoffError,
    calibration_from_yaml_dict,
    calibration_to_yaml_dict,
    load_calibration,
    write_calibration,
)
from gyro_calib.units import RAD_PER_ARCSEC


def _calibration(**changes: Any) -> GyroCalibration:
    values: dict[str, Any] = dict(
        k_tilde_rad_per_pulse=0.8427948030 * RAD_PER_ARCSEC,
        k_tilde_rad_per_pulse_std=0.0118e-6 * 0.8427948030 * RAD_PER_ARCSEC,
        scale_factor_rad_per_pulse=0.84279066 * RAD_PER_ARCSEC,
        scale_factor_rad_per_pulse_std=1.3e-13,
        fix_error_angle_rad=646.75 * RAD_PER_ARCSEC,
        fix_error_angle_rad_std=0.41 * RAD_PER_ARCSEC,
        bias_rad_s=1.234567890123e-8,
        bias_rad_s_std=2.5e-9,
        angle_random_walk_rad_per_sqrt_s=2.9e-7,
        angle_random_walk_rad_per_sqrt_s_std=1.1e-8,
        window_pairs=3,
        stations=4,
        data_start_stamp_ns=1_795_426_200_000_000_001,
        data_end_stamp_ns=1_795_426_500_123_456_789,
        source='bags/bench_2026-11-23.mcap',
        created_utc='2026-11-23T09:30:00+00:00',
    )
    values.update(changes)
    return GyroCalibration(**values)


def _k_tilde_only() -> GyroCalibration:
    return _calibration(scale_factor_rad_per_pulse=None, scale_factor_rad_per_pulse_std=None,
                        fix_error_angle_rad=None, fix_error_angle_rad_std=None, stations=0,
                        angle_random_walk_rad_per_sqrt_s=None,
                        angle_random_walk_rad_per_sqrt_s_std=None, source='live')


def _write_yaml(path: Path, data: Any) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding='utf-8')
    return path


@pytest.mark.parametrize('calibration', [_calibration(), _k_tilde_only()],
                         ids=['full', 'k_tilde_only'])
def test_calibration_round_trips_exactly_through_the_file(
        tmp_path: Path, calibration: GyroCalibration) -> None:
    written = write_calibration(tmp_path / 'gyro.yaml', calibration)
    assert written == (tmp_path / 'gyro.yaml').resolve()
    assert written.is_absolute()
    assert load_calibration(written) == calibration  # floats bit-identical, ints exact
    assert sorted(os.listdir(tmp_path)) == ['gyro.yaml']


def test_file_layout_is_gyro_mapping_plus_top_level_metadata(tmp_path: Path) -> None:
    data = yaml.safe_load(write_calibration(tmp_path / 'g.yaml', _calibration()).read_text())
    assert data['format_version'] == FORMAT_VERSION == 1
    assert data['gyro_calib_version'] == gyro_calib.__version__
    assert set(data) == {'format_version', 'gyro_calib_version', 'created_utc', 'source',
                         'data_start_stamp_ns', 'data_end_stamp_ns', 'gyro'}
    assert data['gyro']['fix_error_angle_rad_std'] == 0.41 * RAD_PER_ARCSEC
    assert data['gyro']['window_pairs'] == 3


def test_absent_fix_error_angle_stays_absent_keys_not_a_number(tmp_path: Path) -> None:
    path = write_calibration(tmp_path / 'g.yaml', _k_tilde_only())
    gyro = yaml.safe_load(path.read_text())['gyro']
    for key in ('fix_error_angle_rad', 'fix_error_angle_rad_std', 'scale_factor_rad_per_pulse',
                'scale_factor_rad_per_pulse_std', 'angle_random_walk_rad_per_sqrt_s'):
        assert key not in gyro
    loaded = load_calibration(path)
    assert loaded.fix_error_angle_rad is None
    assert loaded.scale_factor_rad_per_pulse is None
    assert loaded.stations == 0


def test_new_calibration_gets_version_and_utc_creation_time() -> None:
    cal = _k_tilde_only()
    fresh = GyroCalibration(**{f.name: getattr(cal, f.name) for f in dataclasses.fields(cal)
                               if f.name not in ('created_utc', 'gyro_calib_version')})
    assert fresh.gyro_calib_version == gyro_calib.__version__
    assert fresh.created_utc.endswith('+00:00')


@pytest.mark.parametrize('failing', ['fsync', 'replace'])
def test_failed_write_leaves_old_file_byte_identical_and_no_temporary(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failing: str) -> None:
    target = write_calibration(tmp_path / 'gyro.yaml', _calibration())
    before = target.read_bytes()

    def fail(*args: Any) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(os, failing, fail)
    with pytest.raises(HandoffError) as info:
        write_calibration(target, _calibration(bias_rad_s=5e-8))
    monkeypatch.undo()
    message = str(info.value)
    assert str(target) in message and 'No space left on device' in message
    assert '\n' not in message
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ['gyro.yaml']


def test_write_keeps_the_mode_of_the_file_it_replaces(tmp_path: Path) -> None:
    target = write_calibration(tmp_path / 'gyro.yaml', _calibration())
    assert target.stat().st_mode & 0o777 == 0o644
    target.chmod(0o640)
    write_calibration(target, _calibration(window_pairs=4))
    assert target.stat().st_mode & 0o777 == 0o640


@pytest.mark.parametrize('where', ['missing_directory', 'parent_is_a_file', 'target_is_a_directory'])
def test_unwritable_directory_raises_handoff_error_naming_the_path(
        tmp_path: Path, where: str) -> None:
    if where == 'missing_directory':
        target = tmp_path / 'nowhere' / 'gyro.yaml'
    elif where == 'parent_is_a_file':
        (tmp_path / 'file').write_text('')
        target = tmp_path / 'file' / 'gyro.yaml'
    else:  # works as root too, unlike a read-only directory
        target = tmp_path / 'gyro.yaml'
        target.mkdir()
    with pytest.raises(HandoffError, match='cannot write calibration file') as info:
        write_calibration(target, _calibration())
    assert str(target) in str(info.value)
    assert isinstance(info.value, GyroCalibError)


def test_load_raises_on_missing_file(tmp_path: Path) -> None:
    with pytest.raises(HandoffError, match='cannot read calibration file .*absent.yaml'):
        load_calibration(tmp_path / 'absent.yaml')


def test_load_raises_on_invalid_yaml(tmp_path: Path) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text('gyro: {k_tilde_rad_per_pulse: [1.0\n')
    with pytest.raises(HandoffError, match=f'calibration file {path} is not valid YAML'):
        load_calibration(path)


@pytest.mark.parametrize('content', ['', '- 1\n- 2\n', 'just text\n'])
def test_load_raises_on_document_that_is_not_a_mapping(tmp_path: Path, content: str) -> None:
    path = tmp_path / 'list.yaml'
    path.write_text(content)
    with pytest.raises(HandoffError, match=f'calibration file {path} must hold a mapping'):
        load_calibration(path)


def _valid_dict() -> dict[str, Any]:
    return dict(calibration_to_yaml_dict(_calibration()))


@pytest.mark.parametrize('remove, named', [
    (('source',), 'source'),
    (('gyro',), 'gyro'),
    (('format_version', 'created_utc'), 'format_version, created_utc'),
    (('gyro.bias_rad_s', 'gyro.window_pairs'), 'gyro.bias_rad_s, gyro.window_pairs'),
])
def test_load_names_the_missing_required_fields(tmp_path: Path, remove: tuple[str, ...],
                                                named: str) -> None:
    data = _valid_dict()
    for key in remove:
        if key.startswith('gyro.'):
            del data['gyro'][key[5:]]
        else:
            del data[key]
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=f'field\\(s\\) {named} missing in calibration file '
                                           f'{path}'):
        load_calibration(path)


@pytest.mark.parametrize('key, value, reason', [
    ('gyro.k_tilde_rad_per_pulse', '4e-6', 'must be a number, got the string'),
    ('gyro.bias_rad_s', [1.0], 'must be a finite number'),
    ('gyro.bias_rad_s_std', float('nan'), 'must be a finite number'),
    ('gyro.window_pairs', 2.5, 'must be an integer'),
    ('gyro.stations', True, 'must be an integer'),
    ('data_end_stamp_ns', '1795426500123456789', 'must be a number'),
    ('source', 42, 'must be a string'),
    ('gyro_calib_version', 0.1, 'must be a string'),
    ('created_utc', 'yesterday', 'must be an ISO-8601'),
    ('gyro', [1, 2], 'field gyro in calibration file .* must be a mapping'),
])
def test_load_raises_on_wrong_type(tmp_path: Path, key: str, value: Any, reason: str) -> None:
    data = _valid_dict()
    if key.startswith('gyro.'):
        data['gyro'][key[5:]] = value
    else:
        data[key] = value
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=reason) as info:
        load_calibration(path)
    assert str(path) in str(info.value)
    assert key.split('.')[-1] in str(info.value)


@pytest.mark.parametrize('key, value, reason', [
    ('k_tilde_rad_per_pulse', -4e-6, 'must be positive'),
    ('bias_rad_s_std', -1e-9, 'must be non-negative'),
    ('window_pairs', -1, 'must be non-negative'),
])
def test_load_raises_on_value_out_of_range(tmp_path: Path, key: str, value: Any,
                                           reason: str) -> None:
    data = _valid_dict()
    data['gyro'][key] = value
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=f'{key} = .* {reason} in calibration file {path}'):
        load_calibration(path)


def test_load_raises_on_stamps_out_of_order(tmp_path: Path) -> None:
    data = _valid_dict()
    data['data_end_stamp_ns'] = data['data_start_stamp_ns'] - 1
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match='data_end_stamp_ns .* at least data_start_stamp_ns'):
        load_calibration(path)


@pytest.mark.parametrize('version', [2, 0, '1', None])
def test_load_raises_on_unknown_format_version(tmp_path: Path, version: Any) -> None:
    data = _valid_dict()
    data['format_version'] = version
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=f'calibration file {path} has format_version '
                                           f'{version!r}; .* reads format_version 1 only'):
        load_calibration(path)


def test_load_raises_on_unknown_field(tmp_path: Path) -> None:
    data = _valid_dict()
    data['gyro']['angle_random_walk_rad_sqrt_s'] = 1e-7  # misspelt
    data['comment'] = 'x'
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match='unknown field\\(s\\) comment, '
                                           'gyro.angle_random_walk_rad_sqrt_s in calibration'):
        load_calibration(path)


@pytest.mark.parametrize('drop', [
    ('fix_error_angle_rad', 'fix_error_angle_rad_std'),  # K without θ
    ('scale_factor_rad_per_pulse', 'scale_factor_rad_per_pulse_std'),  # θ without K
    ('fix_error_angle_rad_std',),
    ('angle_random_walk_rad_per_sqrt_s_std',),
])
def test_load_raises_on_value_without_its_partner(tmp_path: Path, drop: tuple[str, ...]) -> None:
    data = _valid_dict()
    for key in drop:
        del data['gyro'][key]
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match='must be given together or both left out'):
        load_calibration(path)


def test_unquoted_yaml_timestamp_is_read_as_its_iso_string() -> None:
    data = yaml.safe_load(yaml.safe_dump(_valid_dict()).replace(
        "'2026-11-23T09:30:00+00:00'", '2026-11-23T09:30:00+00:00'))
    assert not isinstance(data['created_utc'], str)
    assert calibration_from_yaml_dict(data).created_utc == '2026-11-23T09:30:00+00:00'
