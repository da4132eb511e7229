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
    RockingAllowance,
    combine_components,
    interval_verdict,
    misalignment_interval,
)
from gyro_calib.errors import ConfigError

ARCMIN = math.pi / 180 / 60
K = ARCMIN / 60
PAPER = dict(dither_amplitude_rad=6 * ARCMIN, record_s=300.0, sample_rate_hz=2000.0,
             scale_factor_rad_per_pulse=K, dither_frequency_hz=400.0, table_frequency_hz=20.0)


@pytest.mark.parametrize(('amplitude_rad_s', 'floor_arcmin'), [(1.0, 18), (5.0, 3.6), (7.5, 2.4)])
def test_floor_reproduces_the_methods_examples(amplitude_rad_s: float,
                                               floor_arcmin: float) -> None:
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


NO_ROCKING = RockingAllowance('none', 'proportional', 0.0)
VERDICT_KW = dict(limit_rad=5 * ARCMIN, record_s=300.0, sample_rate_hz=2000.0,
                  table_rate_amplitude_rad_s=5.0)


def _verdict(z: Component, y: Component | None, rocking: RockingAllowance = NO_ROCKING):
    comps = {'z': z} if y is None else {'z': z, 'y': y}
    m = None if y is None else combine_components(z, y, rocking)
    interval = misalignment_interval(m, comps, rocking, 2.0)
    return interval, interval_verdict(interval, m, rocking, **VERDICT_KW,
                                      missing_axes=() if y is not None else ('y',))


def test_verdict_accepts_and_rejects_only_when_the_interval_clears_the_limit() -> None:
    _, ok = _verdict(_component('z', 1.2 * ARCMIN, 0.5 * ARCMIN),
                     _component('y', 1.6 * ARCMIN, 0.5 * ARCMIN))
    _, bad = _verdict(_component('z', 5.4 * ARCMIN, 0.5 * ARCMIN),
                      _component('y', 7.2 * ARCMIN, 0.5 * ARCMIN))
    assert ok.decided and ok.accepted and ok.state == 'accept' and 'accept' in ok.sentence
    assert bad.decided and bad.accepted is False and bad.state == 'reject'


def test_rocking_allowance_is_a_multiplicative_interval_on_a() -> None:
    # κ = 0.2, proportional: ρ = √2·κ; a ∈ [(â − 2σ)/(1 + ρ), (â + 2σ)/(1 − ρ)]
    rocking = RockingAllowance('bound', 'proportional', 0.2, 1 / 35)
    rho = math.sqrt(2) * 0.2
    z, y = _component('z', 30 * ARCMIN, 0.3 * ARCMIN), _component('y', 40 * ARCMIN, 0.4 * ARCMIN)
    m = combine_components(z, y, rocking)
    interval, _ = _verdict(z, y, rocking)
    assert m.rho == pytest.approx(rho)
    assert m.rocking_bound_rad == pytest.approx(rho * m.value_rad / (1 - rho))
    assert interval.upper_rad == pytest.approx((m.value_rad + 2 * m.random_std_rad) / (1 - rho))
    assert interval.lower_rad == pytest.approx((m.value_rad - 2 * m.random_std_rad) / (1 + rho))


def test_a_is_reported_with_a_huge_y_uncertainty_and_rejected_from_z_alone() -> None:
    # the bench: Z 58′ well measured, Y −15′ ± 23′ (cannot be told from zero)
    rocking = RockingAllowance('bound', 'proportional', 0.1, 1 / 35)
    z, y = _component('z', 58.2 * ARCMIN, 2.0 * ARCMIN), _component('y', -14.8 * ARCMIN,
                                                                     22.6 * ARCMIN)
    m = combine_components(z, y, rocking)
    assert m.value_rad > 0 and math.isfinite(m.std_rad)  # a is formed, however wide
    interval, verdict = _verdict(z, y, rocking)
    assert verdict.state == 'reject'
    # Z alone: a ≥ |s_z| and s_z is shifted by ≤ κ·a
    z_low = (z.magnitude_rad - 2 * z.random_std_rad) / 1.1
    assert interval.lower_rad >= z_low > 5 * ARCMIN
    # with one orientation only the lower end still rejects, naming the component
    only_z, alone = _verdict(z, None, rocking)
    assert only_z.lower_rad == pytest.approx(z_low) and math.isinf(only_z.upper_rad)
    assert alone.state == 'reject' and 'component Z alone' in alone.sentence


def test_undecidable_verdict_says_what_record_or_table_amplitude_would_decide() -> None:
    z, y = _component('z', 2.4 * ARCMIN, 1.2 * ARCMIN), _component('y', 3.2 * ARCMIN,
                                                                    1.2 * ARCMIN)
    m = combine_components(z, y, NO_ROCKING)
    _, v = _verdict(z, y)
    assert not v.decided and v.accepted is None and v.state == 'undecidable'
    assert 'cannot decide a < 5′' in v.sentence and 'more in each orientation' in v.sentence
    assert 'table rate amplitude' in v.sentence and 'kHz' in v.sentence
    target = (5 * ARCMIN - m.value_rad) / 2  # upper end â + 2σ below the limit
    factor = (m.random_std_rad / target) ** 2
    assert v.more_record_s == pytest.approx(300 * (factor - 1))
    assert v.sample_rate_needed_hz == pytest.approx(2000 * factor)
    assert v.table_rate_amplitude_needed_rad_s == pytest.approx(5.0 * math.sqrt(factor))


def test_undecidable_verdict_says_when_no_record_can_decide() -> None:
    # the rocking allowance alone spans the limit: â/(1 + ρ) < 5′ < â/(1 − ρ)
    rocking = RockingAllowance('bound', 'proportional', 0.3, 1 / 35)
    _, v = _verdict(_component('z', 3 * ARCMIN, 0.05 * ARCMIN),
                    _component('y', 4 * ARCMIN, 0.05 * ARCMIN), rocking)
    assert not v.decided and 'with any record' in v.sentence


def test_unsized_rocking_bounds_nothing_and_asks_for_k() -> None:
    rocking = RockingAllowance('bound', 'proportional', math.nan, 1 / 35)
    interval, v = _verdict(_component('z', 50 * ARCMIN, 0.5 * ARCMIN),
                           _component('y', 30 * ARCMIN, 0.5 * ARCMIN), rocking)
    assert interval.lower_rad == 0.0 and math.isinf(interval.upper_rad)
    assert v.state == 'undecidable' and 'scale factor K' in v.sentence
