"""The detection floor, its inverses, a from components and the acceptance verdict (METHODS §C)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyro_calib.dither.floor import (
    detection_floor,
    required_record_s,
    required_sample_rate_hz,
    required_table_rate_amplitude_rad_s,
)
from gyro_calib.dither.misalignment import (
    Component,
    acceptance_verdict,
    combine_components,
)
from gyro_calib.errors import ConfigError

ARCMIN = math.pi / 180 / 60
K = ARCMIN / 60
PAPER = dict(dither_amplitude_rad=6 * ARCMIN, record_s=300.0, sample_rate_hz=2000.0,
             scale_factor_rad_per_pulse=K, dither_frequency_hz=400.0, table_frequency_hz=20.0)


@pytest.mark.parametrize(('amplitude_rad_s', 'floor_arcmin'), [(1.0, 18), (5.0, 3.6), (7.5, 2.4)])
def test_floor_reproduces_the_methods_examples(amplitude_rad_s: float, floor_arcmin: float) -> None:
    f = detection_floor(table_rate_amplitude_rad_s=amplitude_rad_s, **PAPER)
    assert f.component_std_rad / ARCMIN == pytest.approx(floor_arcmin, rel=0.02)


def test_floor_is_quantisation_dominated_for_an_rlg_arw() -> None:
    arw = math.radians(0.0005) / 60  # 0.0005 °/√h in rad/√s
    f = detection_floor(table_rate_amplitude_rad_s=5.0, angle_random_walk_rad_sqrt_s=arw,
                        **PAPER)
    assert (f.arw_std_rad / f.quantisation_std_rad) ** 2 < 1e-4
    assert f.component_std_rad == pytest.approx(math.hypot(f.quantisation_std_rad,
                                                           f.arw_std_rad))


def test_floor_in_pulse_units_needs_no_scale_factor() -> None:
    rad = detection_floor(table_rate_amplitude_rad_s=5.0, **PAPER)
    pulses = detection_floor(table_rate_amplitude_rad_s=5.0,
                             **{**PAPER, 'dither_amplitude_rad': 6 * ARCMIN / K,
                                'scale_factor_rad_per_pulse': 1.0})
    assert pulses.component_std_rad == pytest.approx(rad.component_std_rad, rel=1e-12)


def test_floor_snr_is_a_over_sigma() -> None:
    f = detection_floor(table_rate_amplitude_rad_s=5.0, misalignment_rad=10 * ARCMIN, **PAPER)
    assert f.snr == pytest.approx(10 * ARCMIN / f.component_std_rad)


def test_required_record_sample_rate_and_amplitude_give_the_target_floor() -> None:
    target = 1.0 * ARCMIN
    common = {k: v for k, v in PAPER.items() if k != 'record_s'}
    t = required_record_s(target, table_rate_amplitude_rad_s=5.0, **common)
    assert detection_floor(table_rate_amplitude_rad_s=5.0, record_s=t,
                           **common).component_std_rad == pytest.approx(target)
    no_rate = {k: v for k, v in PAPER.items() if k != 'sample_rate_hz'}
    fs = required_sample_rate_hz(target, table_rate_amplitude_rad_s=5.0, **no_rate)
    assert detection_floor(table_rate_amplitude_rad_s=5.0, **{**PAPER, 'sample_rate_hz': fs}
                           ).component_std_rad == pytest.approx(target)
    amp = required_table_rate_amplitude_rad_s(target, **PAPER)
    assert detection_floor(table_rate_amplitude_rad_s=amp, **PAPER
                           ).component_std_rad == pytest.approx(target)


def test_required_sample_rate_is_infinite_when_arw_alone_exceeds_the_target() -> None:
    no_rate = {k: v for k, v in PAPER.items() if k != 'sample_rate_hz'}
    assert required_sample_rate_hz(1e-6, table_rate_amplitude_rad_s=5.0,
                                   angle_random_walk_rad_sqrt_s=1e-3, **no_rate) == math.inf


@pytest.mark.parametrize('field', ['table_rate_amplitude_rad_s', 'record_s', 'sample_rate_hz'])
def test_floor_raises_config_error_naming_a_non_positive_argument(field: str) -> None:
    args = {**PAPER, 'table_rate_amplitude_rad_s': 5.0, field: 0.0}
    with pytest.raises(ConfigError, match=field):
        detection_floor(**args)


def _component(axis: str, value: float, sigma: float, bound: float = 0.0) -> Component:
    floor = detection_floor(table_rate_amplitude_rad_s=5.0, **PAPER)
    return Component(axis, value, sigma, bound, 0.0, sigma, floor, 150, 10**6, 300.0, 2000.0,
                     1.0)


def test_a_is_the_bias_corrected_hypot_with_propagated_uncertainty() -> None:
    m = combine_components(_component('z', 3 * ARCMIN, 0.1 * ARCMIN),
                           _component('y', 4 * ARCMIN, 0.2 * ARCMIN))
    assert m.raw_rad == pytest.approx(5 * ARCMIN)
    assert m.value_rad == pytest.approx(math.sqrt(25 - 0.01 - 0.04) * ARCMIN)
    assert m.statistical_std_rad == pytest.approx(math.sqrt(9 * 0.01 + 16 * 0.04) / 5 * ARCMIN)
    assert m.resolved


def test_unresolved_a_reads_zero_with_the_largest_component_uncertainty() -> None:
    m = combine_components(_component('z', 0.5 * ARCMIN, 1.0 * ARCMIN),
                           _component('y', -0.5 * ARCMIN, 2.0 * ARCMIN))
    assert m.value_rad == 0.0
    assert m.statistical_std_rad == pytest.approx(2.0 * ARCMIN)
    assert not m.resolved


def test_bias_correction_makes_a_squared_unbiased_near_zero() -> None:
    rng = np.random.default_rng(3)
    sigma, a = 1.0, 1.0
    sz = a * 0.6 + sigma * rng.standard_normal(20000)
    sy = a * 0.8 + sigma * rng.standard_normal(20000)
    raw2 = sz ** 2 + sy ** 2
    assert np.mean(raw2 - 2 * sigma ** 2) == pytest.approx(a * a, abs=0.05)
    assert np.mean(raw2) == pytest.approx(a * a + 2, abs=0.05)  # the bias it removes


def test_rocking_bound_adds_a_rectangular_type_b_uncertainty() -> None:
    c = _component('z', 3 * ARCMIN, 0.3 * ARCMIN, bound=0.9 * ARCMIN)
    assert c.std_rad == pytest.approx(math.hypot(0.3, 0.9 / math.sqrt(3)) * ARCMIN)


def test_verdict_accepts_and_rejects_only_when_the_record_decides() -> None:
    kw = dict(limit_rad=5 * ARCMIN, coverage_factor=2.0, record_s=300.0, sample_rate_hz=2000.0)
    ok = acceptance_verdict(2 * ARCMIN, 1 * ARCMIN, statistical_std_rad=1 * ARCMIN, **kw)
    bad = acceptance_verdict(9 * ARCMIN, 1 * ARCMIN, statistical_std_rad=1 * ARCMIN, **kw)
    assert ok.decided and ok.accepted and 'accept' in ok.sentence
    assert bad.decided and bad.accepted is False and 'reject' in bad.sentence


def test_undecided_verdict_says_how_much_more_record_or_how_fast_to_sample() -> None:
    v = acceptance_verdict(3 * ARCMIN, 2.4 * ARCMIN, statistical_std_rad=2.4 * ARCMIN,
                           limit_rad=5 * ARCMIN, coverage_factor=2.0, record_s=300.0,
                           sample_rate_hz=2000.0)
    assert not v.decided and v.accepted is None
    assert 'cannot decide a < 5′' in v.sentence and 'more' in v.sentence and 'kHz' in v.sentence
    # σ must fall from 2.4′ to 1′: 5.76 × the samples
    assert v.more_record_s == pytest.approx(300 * (5.76 - 1))
    assert v.sample_rate_needed_hz == pytest.approx(2000 * 5.76)


def test_undecided_verdict_says_when_no_record_can_decide() -> None:
    # the Type B part (rocking bound) alone exceeds the margin
    v = acceptance_verdict(4 * ARCMIN, 1.5 * ARCMIN, statistical_std_rad=0.2 * ARCMIN,
                           limit_rad=5 * ARCMIN, coverage_factor=2.0, record_s=300.0,
                           sample_rate_hz=2000.0)
    assert not v.decided and 'with any record' in v.sentence
