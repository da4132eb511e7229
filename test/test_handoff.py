"""The INS hand-off file.

The INS hand-off file: exact round trip, atomic replacement, whatever was measured and what
is missing, methods merged into one file per gyro, format 1 still read, a clear error for
every bad file.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
import yaml

import gyro_calib
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import (
    FORMAT_VERSION,
    Calibration,
    HandoffError,
    Provenance,
    calibration_from_yaml_dict,
    calibration_to_yaml_dict,
    load_calibration,
    method_calibration,
    update_calibration,
    write_calibration,
)
from gyro_calib.units import RAD_PER_ARCSEC

START, END = 1_795_426_200_000_000_001, 1_795_426_500_123_456_789
FULL = dict(
    k_tilde_rad_per_pulse=0.8427948030 * RAD_PER_ARCSEC,
    k_tilde_rad_per_pulse_std=0.0118e-6 * 0.8427948030 * RAD_PER_ARCSEC,
    scale_factor_rad_per_pulse=0.84279066 * RAD_PER_ARCSEC,
    scale_factor_rad_per_pulse_std=1.3e-13,
    fix_error_angle_rad=646.75 * RAD_PER_ARCSEC,
    fix_error_angle_rad_std=0.41 * RAD_PER_ARCSEC,
    bias_plus_earth_rate_rad_s=2.4e-5, bias_plus_earth_rate_rad_s_std=3.0e-8,
    bias_rad_s=1.234567890123e-8, bias_rad_s_std=2.5e-9,
    window_pairs=3, stations=4)


def _rbrlg(values: dict[str, Any] | None = None, missing: dict[str, str] | None = None,
           gyro_id: str = '') -> Calibration:
    return method_calibration(
        'rbrlg', FULL if values is None else values,
        Provenance('bags/bench_2026-11-23', START, END, missing or {},
                   '2026-11-23T09:30:00+00:00'), gyro_id=gyro_id)


def _k_tilde_only() -> Calibration:
    values = {k: v for k, v in FULL.items() if k.startswith(('k_tilde', 'bias_plus', 'window'))}
    values['stations'] = 0
    return _rbrlg(values, {'fix_error_angle_rad': 'no position-table stations in the data.',
                           'scale_factor_rad_per_pulse': 'K = K̃·cos θ needs θ.',
                           'bias_rad_s': 'the bias needs the site latitude.'})


def _noise() -> Calibration:
    return method_calibration('noise', {'angle_random_walk_rad_per_sqrt_s': 2.9e-7,
                                        'angle_random_walk_rad_per_sqrt_s_std': 1.1e-8},
                              Provenance('bags/static', START, END, {}))


def _write_yaml(path: Path, data: Any) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding='utf-8')
    return path


@pytest.mark.parametrize('calibration', [_rbrlg(), _k_tilde_only()],
                         ids=['full', 'k_tilde_only'])
def test_calibration_round_trips_exactly_through_the_file(
        tmp_path: Path, calibration: Calibration) -> None:
    written = write_calibration(tmp_path / 'gyro.yaml', calibration)
    assert written == (tmp_path / 'gyro.yaml').resolve()
    assert load_calibration(written) == calibration  # floats bit-identical, ints exact
    assert sorted(os.listdir(tmp_path)) == ['gyro.yaml']


def test_file_layout_is_gyro_values_methods_provenance_and_completeness(tmp_path: Path) -> None:
    data = yaml.safe_load(write_calibration(tmp_path / 'g.yaml', _rbrlg()).read_text())
    assert data['format_version'] == FORMAT_VERSION == 3
    assert data['gyro_calib_version'] == gyro_calib.__version__
    assert set(data) == {'format_version', 'gyro_calib_version', 'gyro_id', 'conventions',
                         'complete', 'missing', 'not_measurable', 'gyro', 'methods'}
    assert data['complete'] is True and data['missing'] == {}
    assert data['gyro']['fix_error_angle_rad_std'] == 0.41 * RAD_PER_ARCSEC
    assert data['gyro']['window_pairs'] == 3
    assert data['methods']['rbrlg']['data_end_stamp_ns'] == END


def test_k_tilde_only_file_lists_what_is_missing_and_why_with_absent_keys(
        tmp_path: Path) -> None:
    data = yaml.safe_load(write_calibration(tmp_path / 'g.yaml', _k_tilde_only()).read_text())
    assert data['complete'] is False
    assert set(data['missing']) == {'fix_error_angle_rad', 'scale_factor_rad_per_pulse',
                                    'bias_rad_s'}
    assert 'latitude' in data['missing']['bias_rad_s']
    for key in ('fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'bias_rad_s'):
        assert key not in data['gyro'] and key + '_std' not in data['gyro']
    loaded = load_calibration(tmp_path / 'g.yaml')
    assert loaded.get('scale_factor_rad_per_pulse') is None
    with pytest.raises(HandoffError, match='no scale_factor_rad_per_pulse: K = K̃·cos θ needs θ'):
        loaded.require('scale_factor_rad_per_pulse')
    assert loaded.require('k_tilde_rad_per_pulse') == (FULL['k_tilde_rad_per_pulse'],
                                                       FULL['k_tilde_rad_per_pulse_std'])


def test_update_merges_methods_into_one_file_and_replaces_only_the_method_that_ran(
        tmp_path: Path) -> None:
    path = tmp_path / 'gyro.yaml'
    update_calibration(path, _k_tilde_only())
    update_calibration(path, _noise())
    update_calibration(path, _rbrlg())  # θ measured later: rbrlg replaced, noise kept
    merged = load_calibration(path)
    assert set(merged.methods) == {'rbrlg', 'noise'}
    assert merged.complete
    assert merged.get('angle_random_walk_rad_per_sqrt_s') == 2.9e-7
    assert merged.get('scale_factor_rad_per_pulse') == FULL['scale_factor_rad_per_pulse']


def test_update_refuses_a_file_of_another_gyro_and_leaves_it(tmp_path: Path) -> None:
    path = update_calibration(tmp_path / 'gyro.yaml', _rbrlg(gyro_id='SN-001'))
    before = path.read_bytes()
    with pytest.raises(HandoffError, match="holds gyro 'SN-001', this calibration is for "
                                           "gyro 'SN-002'"):
        update_calibration(path, _rbrlg(gyro_id='SN-002'))
    assert path.read_bytes() == before


def test_update_refuses_to_overwrite_an_invalid_file(tmp_path: Path) -> None:
    path = tmp_path / 'gyro.yaml'
    path.write_text('gyro: [not, a, calibration]\n')
    with pytest.raises(HandoffError, match='calibration file'):
        update_calibration(path, _rbrlg())
    assert path.read_text() == 'gyro: [not, a, calibration]\n'


def test_format_1_files_still_load_with_the_same_values(tmp_path: Path) -> None:
    v1 = {'format_version': 1, 'gyro_calib_version': '0.1.0',
          'created_utc': '2026-11-23T09:30:00+00:00', 'source': 'live',
          'data_start_stamp_ns': START, 'data_end_stamp_ns': END,
          'gyro': {'k_tilde_rad_per_pulse': FULL['k_tilde_rad_per_pulse'],
                   'k_tilde_rad_per_pulse_std': FULL['k_tilde_rad_per_pulse_std'],
                   'bias_rad_s': 1.2e-8, 'bias_rad_s_std': 3.0e-9,
                   'angle_random_walk_rad_per_sqrt_s': 2.9e-7,
                   'angle_random_walk_rad_per_sqrt_s_std': 1.5e-8,
                   'window_pairs': 3, 'stations': 0}}
    loaded = load_calibration(_write_yaml(tmp_path / 'v1.yaml', v1))
    assert loaded.format_version == 1
    assert loaded.require('bias_rad_s') == (1.2e-8, 3.0e-9)
    assert loaded.get('angle_random_walk_rad_per_sqrt_s') == 2.9e-7
    assert loaded.methods['rbrlg'].source == 'live'
    update_calibration(tmp_path / 'v1.yaml', _rbrlg())  # rewritten as format 3, ARW kept
    again = load_calibration(tmp_path / 'v1.yaml')
    assert again.format_version == 3 and again.get('angle_random_walk_rad_per_sqrt_s') == 2.9e-7


@pytest.mark.parametrize('failing', ['fsync', 'replace'])
def test_failed_write_leaves_old_file_byte_identical_and_no_temporary(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failing: str) -> None:
    target = write_calibration(tmp_path / 'gyro.yaml', _rbrlg())
    before = target.read_bytes()

    def fail(*args: Any) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(os, failing, fail)
    with pytest.raises(HandoffError) as info:
        write_calibration(target, _k_tilde_only())
    monkeypatch.undo()
    message = str(info.value)
    assert str(target) in message and 'No space left on device' in message
    assert '\n' not in message
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ['gyro.yaml']


def test_write_keeps_the_mode_of_the_file_it_replaces(tmp_path: Path) -> None:
    target = write_calibration(tmp_path / 'gyro.yaml', _rbrlg())
    assert target.stat().st_mode & 0o777 == 0o644
    target.chmod(0o640)
    write_calibration(target, _k_tilde_only())
    assert target.stat().st_mode & 0o777 == 0o640


@pytest.mark.parametrize('where', ['missing_directory', 'parent_is_a_file',
                                   'target_is_a_directory'])
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
        write_calibration(target, _rbrlg())
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
    what = 'is empty' if not content else 'must hold a mapping'
    with pytest.raises(HandoffError, match=f'calibration file {path} {what}'):
        load_calibration(path)


def _valid_dict() -> dict[str, Any]:
    return dict(calibration_to_yaml_dict(_rbrlg()))


@pytest.mark.parametrize('remove, named', [
    (('gyro',), 'field\\(s\\) gyro missing'),
    (('methods',), 'field\\(s\\) methods missing'),
    (('methods.rbrlg.source',), 'methods.rbrlg .*field\\(s\\) source missing'),
    (('gyro.bias_rad_s_std',), 'gyro.bias_rad_s .*has no gyro.bias_rad_s_std beside it'),
    (('gyro.fix_error_angle_rad',), 'gyro.fix_error_angle_rad_std .*has no '
                                    'gyro.fix_error_angle_rad beside it'),
])
def test_load_names_what_is_missing(tmp_path: Path, remove: tuple[str, ...], named: str) -> None:
    data = _valid_dict()
    for key in remove:
        *parents, last = key.split('.')
        node = data
        for p in parents:
            node = node[p]
        del node[last]
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=named) as info:
        load_calibration(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize('key, value, reason', [
    ('gyro.k_tilde_rad_per_pulse', '4e-6', 'must be a finite number .*YAML 1.1 floats'),
    ('gyro.bias_rad_s', [1.0], 'must be a finite number'),
    ('gyro.bias_rad_s_std', float('nan'), 'must be a finite number'),
    ('gyro.window_pairs', 2.5, 'must be a non-negative integer'),
    ('gyro.stations', True, 'must be a non-negative integer'),
    ('methods.rbrlg.data_end_stamp_ns', '1795426500123456789', 'must be an integer'),
    ('methods.rbrlg.source', 42, 'must be a string'),
    ('methods.rbrlg.created_utc', 'yesterday', 'must be an ISO-8601'),
    ('gyro', [1, 2], 'fields gyro and methods .* must be mappings'),
    ('gyro_id', 7, 'gyro_id .* must be a string'),
])
def test_load_raises_on_wrong_type(tmp_path: Path, key: str, value: Any, reason: str) -> None:
    data = _valid_dict()
    *parents, last = key.split('.')
    node = data
    for p in parents:
        node = node[p]
    node[last] = value
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=reason) as info:
        load_calibration(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize('key, value, reason', [
    ('k_tilde_rad_per_pulse', -4e-6, 'must be positive'),
    ('bias_rad_s_std', -1e-9, 'must be non-negative'),
    ('window_pairs', -1, 'must be a non-negative integer'),
])
def test_load_raises_on_value_out_of_range(tmp_path: Path, key: str, value: Any,
                                           reason: str) -> None:
    data = _valid_dict()
    data['gyro'][key] = value
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=f'gyro.{key} = .* in calibration file {path} is '
                                           f'invalid: it {reason}'):
        load_calibration(path)


def test_load_raises_on_stamps_out_of_order(tmp_path: Path) -> None:
    data = _valid_dict()
    data['methods']['rbrlg']['data_end_stamp_ns'] = START - 1
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match='data_end_stamp_ns .* at least data_start_stamp_ns'):
        load_calibration(path)


@pytest.mark.parametrize('version', [5, 0, '1', None])
def test_load_raises_on_unknown_format_version(tmp_path: Path, version: Any) -> None:
    data = _valid_dict()
    data['format_version'] = version
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match=f'calibration file {path} has format_version '
                                           f'{version!r}; .* reads format_version 1, 2, 3 and 4'):
        load_calibration(path)


def test_load_raises_on_unknown_field_or_method(tmp_path: Path) -> None:
    data = _valid_dict()
    data['gyro']['angle_random_walk_rad_sqrt_s'] = 1e-7  # misspelt
    path = _write_yaml(tmp_path / 'g.yaml', data)
    with pytest.raises(HandoffError, match='unknown field\\(s\\) '
                                           'gyro.angle_random_walk_rad_sqrt_s in calibration'):
        load_calibration(path)
    data = _valid_dict()
    data['methods']['rbrlg2'] = data['methods']['rbrlg']
    with pytest.raises(HandoffError, match="unknown method 'rbrlg2'"):
        load_calibration(_write_yaml(tmp_path / 'g.yaml', data))


def test_a_value_needs_the_method_it_belongs_to(tmp_path: Path) -> None:
    data = _valid_dict()
    data['gyro']['angle_random_walk_rad_per_sqrt_s'] = 1e-7
    data['gyro']['angle_random_walk_rad_per_sqrt_s_std'] = 1e-9
    with pytest.raises(HandoffError, match='belongs to method noise, which has no entry'):
        load_calibration(_write_yaml(tmp_path / 'g.yaml', data))


def test_a_method_cannot_write_another_methods_key() -> None:
    with pytest.raises(HandoffError, match='fog_scale_factor_counts_per_rad is not a hand-off '
                                           'key of method rbrlg'):
        _rbrlg({'fog_scale_factor_counts_per_rad': 1.0,
                'fog_scale_factor_counts_per_rad_std': 0.1})


def test_unquoted_yaml_timestamp_is_read_as_its_iso_string() -> None:
    data = yaml.safe_load(yaml.safe_dump(_valid_dict()).replace(
        "'2026-11-23T09:30:00+00:00'", '2026-11-23T09:30:00+00:00'))
    assert not isinstance(data['methods']['rbrlg']['created_utc'], str)
    loaded = calibration_from_yaml_dict(data)
    assert loaded.methods['rbrlg'].created_utc == '2026-11-23T09:30:00+00:00'
