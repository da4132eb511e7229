"""imu_corrector's single-gyro mode learns FOGs (issue 26 §3; imu_conversion eqs. (3)–(4)).

- a FOG hand-off (``fog_scale_factor_counts_per_rad``) is converted through K = 1/SF and its
  asymmetry, instead of being refused with advice about K̃ and θ;
- counts generated from a known rate with K₊ ≠ K₋ come back as that rate, both signs;
- the turntable scale factor applies when the file has it, the self-calibrated one
  otherwise, and the note says which and why.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyro_calib.handoff import Calibration, Provenance, method_calibration
from gyro_calib.imu_conversion import (
    ImuAngularVelocity,
    PulseRateConverter,
    angular_velocity_from_pulses,
    pulse_calibration,
    scale_factor_line,
)

T0_NS = 1_795_426_200_000_000_000
SF = 823_190.0  # counts/rad
BIAS = 4.8e-6  # rad/s
ASYM_PPM = 120.0
NL_PPM = 35.0


def _fog_handoff(*, turntable: bool = True, self_cal: bool = True) -> Calibration:
    prov = Provenance('bags/fog_turntable_bench', T0_NS - 600 * 10**9, T0_NS - 10**9)
    values: dict[str, float] = {}
    if turntable:
        values.update(fog_scale_factor_counts_per_rad=SF,
                      fog_scale_factor_counts_per_rad_std=4.0,
                      fog_bias_rad_s=BIAS, fog_bias_rad_s_std=2e-8,
                      fog_asymmetry_ppm=ASYM_PPM, fog_asymmetry_ppm_std=6.0,
                      fog_nonlinearity_ppm=NL_PPM, fog_nonlinearity_ppm_std=3.0,
                      fog_angle_random_walk_rad_per_sqrt_s=1.2e-6,
                      fog_angle_random_walk_rad_per_sqrt_s_std=1e-7)
    if self_cal:
        values.update(fog_self_cal_scale_factor_counts_per_rad=SF * (1 + 3e-5),
                      fog_self_cal_scale_factor_counts_per_rad_std=9.0,
                      fog_self_cal_linear_range_rad_s=0.35,
                      fog_self_cal_linear_range_rad_s_std=0.01,
                      fog_self_cal_nonlinearity_ppm=80.0,
                      fog_self_cal_nonlinearity_ppm_std=5.0)
    return method_calibration('fog', values, prov, gyro_id='F-3')


def test_a_fog_handoff_is_no_longer_refused_with_advice_about_k_tilde() -> None:
    cal = pulse_calibration(_fog_handoff())
    assert cal.is_fog and cal.scale_factor_key == 'fog_scale_factor_counts_per_rad'
    assert cal.scale_factor_rad_per_pulse == pytest.approx(1 / SF, rel=1e-15)
    assert cal.scale_factor_std == pytest.approx(4.0 / SF**2, rel=1e-12)
    assert cal.bias_known and cal.bias_rad_s == BIAS
    assert cal.angle_random_walk_rad_per_sqrt_s == 1.2e-6
    line = scale_factor_line(cal)
    assert line.startswith(f'SF = {SF!r} ± ') and 'counts/rad' in line
    assert 'θ' not in line and 'K̃' not in line


@pytest.mark.parametrize('omega', [0.2, -0.2, 1.5e-4, -3.0])
def test_fog_counts_from_a_known_rate_with_asymmetric_scale_factor_come_back(omega: float
                                                                             ) -> None:
    """The physics: output rate = K±·ω + SF·b, K± = SF(1 ± a/2) by the sign of ω (§B.2 (7))."""
    a = ASYM_PPM * 1e-6
    k_pm = SF * (1 + math.copysign(a / 2, omega))
    dt_s, steps = 0.01, 200
    rng = np.random.default_rng(26)
    phase = rng.uniform()
    counts = np.floor(phase + (k_pm * omega + SF * BIAS) * dt_s * np.arange(steps + 1))
    converter = PulseRateConverter(pulse_calibration(_fog_handoff()))
    outs = [converter.add(T0_NS + i * 10_000_000, float(c)) for i, c in enumerate(counts)]
    rates = [o for o in outs if isinstance(o, ImuAngularVelocity)]
    assert len(rates) == steps
    z = np.array([r.angular_velocity_rad_s[2] for r in rates])
    sigma = np.sqrt([r.covariance_rad2_s2[8] for r in rates])
    assert np.all(np.abs(z - omega) < 4 * sigma)
    # the mean over the run: the quantisation averages out, the asymmetry must not be left in
    assert abs(np.mean(z) - omega) < abs(omega) * a / 20 + 2 / (SF * dt_s * steps)


def test_fog_variance_holds_the_asymmetry_and_nonlinearity_terms() -> None:
    cal = pulse_calibration(_fog_handoff())
    k, dt_s, counts = 1 / SF, 0.01, 8231.0
    out = angular_velocity_from_pulses(T0_NS, 0.0, T0_NS + 10_000_000, counts, cal)
    lin = k * counts / dt_s - BIAS
    a = ASYM_PPM * 1e-6
    rate = lin / (1 + a / 2)
    base = (1.2e-6**2 / dt_s + k * k / (6 * dt_s**2) + (k * counts / dt_s * cal.scale_factor_std
                                                       / k) ** 2 + 2e-8**2)
    expected = base / (1 + a / 2) ** 2 + (rate * 6e-6 / 2) ** 2 + (NL_PPM * 1e-6 * rate) ** 2 / 3
    assert out.angular_velocity_rad_s[2] == pytest.approx(rate, rel=1e-12)
    assert out.covariance_rad2_s2[8] == pytest.approx(expected, rel=1e-12)


def test_the_turntable_scale_factor_applies_when_present_else_the_self_calibrated_one() -> None:
    both = pulse_calibration(_fog_handoff())
    assert both.scale_factor_key == 'fog_scale_factor_counts_per_rad'
    assert both.scale_factor_note.startswith('the turntable scale factor applies (from run '
                                             'bags/fog_turntable_bench')
    assert 'measured against the table\'s rates' in both.scale_factor_note
    assert 'self-calibrated one is anchored to the equivalence mapping' in both.scale_factor_note
    only_self = pulse_calibration(_fog_handoff(turntable=False))
    assert only_self.scale_factor_key == 'fog_self_cal_scale_factor_counts_per_rad'
    assert only_self.scale_factor_rad_per_pulse == pytest.approx(1 / (SF * (1 + 3e-5)))
    assert only_self.asymmetry == 0.0 and only_self.nonlinearity == pytest.approx(80e-6)
    assert 'self-calibrated scale factor applies' in only_self.scale_factor_note
    assert 'no turntable scale factor' in only_self.scale_factor_note
    assert '|ω| ≤ 0.35 rad/s' in only_self.scale_factor_note
    assert not only_self.bias_known  # the bias comes from the turntable run
