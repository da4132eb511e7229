"""The hand-off's ``imu:`` section (format 4): read back as written, refused when malformed."""

from __future__ import annotations

import numpy as np
import pytest

from gyro_calib.imu_calibration import ImuCalibration, ImuSectionError, imu_from_section


def _triad() -> ImuCalibration:
    axes = np.array([[1.0, 2e-4, -1e-4], [-3e-4, 1.0, 5e-4], [1e-4, -2e-4, 1.0]])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    k = np.array([4.1e-6, 4.2e-6, 4.0e-6])
    m = np.linalg.inv(axes / k[:, None])
    return ImuCalibration(('x', 'y', 'z'), np.eye(3), k, k * 1e-7, np.array([9.0, 9.0, np.inf]),
                          axes, np.full(3, 2e-7), m, np.eye(9) * 1e-26,
                          np.array([1e-6, -2e-6, 3e-6]), np.full(3, 1e-8),
                          {'x': {'angle_random_walk_rad_per_sqrt_s': 1e-6}},
                          missing={}, not_measurable={})


def test_a_section_reads_back_as_written() -> None:
    imu = _triad()
    back = imu_from_section(imu.to_section())
    assert back.channels == ('x', 'y', 'z')
    assert back.pulses_to_body_rad is not None and imu.pulses_to_body_rad is not None
    np.testing.assert_array_equal(back.pulses_to_body_rad, imu.pulses_to_body_rad)
    np.testing.assert_array_equal(back.scale_factor_rad_per_pulse_dof, [9.0, 9.0, np.inf])
    assert back.noise == {'x': {'angle_random_walk_rad_per_sqrt_s': 1e-6}}


def test_misalignment_is_the_small_angle_form_of_the_sense_axes() -> None:
    imu = _triad()
    m = imu.misalignment_rad
    assert m is not None and imu.sense_axes is not None
    assert np.all(np.diag(m) == 0.0)
    assert m[0, 1] == pytest.approx(imu.sense_axes[0, 1] / imu.sense_axes[0, 0])


@pytest.mark.parametrize('change, words', [
    ({'sense_axis': [[1.0, 0.0, 0.0]] * 3}, "unknown key 'sense_axis' (did you mean 'sense_axes'"),
    ({'channels': ['x', 'x', 'z']}, 'three distinct channel names'),
    ({'sense_axes': [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}, 'unit vectors'),
    ({'scale_factor_rad_per_pulse': [4e-6, -4e-6, 4e-6]}, 'must be > 0'),
    ({'bias_rad_s_std': None}, 'bias_rad_s is given without its uncertainty'),
    ({'pulses_to_body_rad': [[1.0, 0.0], [0.0, 1.0]]}, 'shape (3, 3)'),
    ({'fixture_rotation': [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]}, 'not a rotation'),
    ({'noise': {'w': {}}}, "channel 'w'"),
])
def test_a_malformed_section_is_refused_naming_the_key(change: dict[str, object],
                                                       words: str) -> None:
    section = _triad().to_section()
    for key, value in change.items():
        if value is None:
            section.pop(key)
        else:
            section[key] = value
    with pytest.raises(ImuSectionError, match=None) as caught:
        imu_from_section(section, source='h.yaml')
    assert words in str(caught.value) and str(caught.value).startswith('h.yaml: ')


def test_channels_not_along_their_own_body_axes_get_no_small_angle_misalignment() -> None:
    """Channels listed z, x, y: s_ii ≈ 0, so m_ij = s_ij/s_ii would be inf; the key is left out."""
    imu = _triad()
    assert imu.sense_axes is not None
    permuted = ImuCalibration(('z', 'x', 'y'), sense_axes=imu.sense_axes[[2, 0, 1]],
                              sense_axes_std_rad=imu.sense_axes_std_rad)
    assert permuted.misalignment_rad is None
    section = permuted.to_section()
    assert 'misalignment_rad' not in section and 'sense_axes' in section
    assert imu_from_section(section).sense_axes is not None


def test_a_channel_not_measured_is_null_in_every_per_channel_list_with_its_reason() -> None:
    imu = _triad()
    section = imu.to_section()
    for key in ('pulses_to_body_rad', 'pulses_to_body_rad_covariance', 'bias_rad_s',
                'bias_rad_s_std', 'misalignment_rad'):
        section.pop(key)
    for key in ('scale_factor_rad_per_pulse', 'scale_factor_rad_per_pulse_std',
                'scale_factor_rad_per_pulse_dof', 'sense_axes', 'sense_axes_std_rad'):
        section[key][1] = None
    with pytest.raises(ImuSectionError, match="channel 'y' has no value"):
        imu_from_section(section)
    section['not_measurable'] = {'scale_factor_rad_per_pulse': 'channel y: 2 directions'}
    back = imu_from_section(section)
    assert back.scale_factor_rad_per_pulse is not None and back.sense_axes is not None
    assert np.isnan(back.scale_factor_rad_per_pulse[1]) and np.isnan(back.sense_axes[1]).all()
    assert back.to_section()['sense_axes'][1] is None
    section['sense_axes_std_rad'][1] = 1e-7
    with pytest.raises(ImuSectionError, match='null for different channels'):
        imu_from_section(section)
