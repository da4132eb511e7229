"""Turntable scale factor of the FOG.

Turntable scale factor of the FOG (IEEE Std 952 style; METHODS §B, §E): K, bias,
nonlinearity, asymmetry and polynomial terms, each within its stated uncertainty.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.fog import FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import (
    KEY_ASYMMETRY,
    KEY_BIAS,
    KEY_BIAS_PLUS_EARTH,
    KEY_CUBIC,
    KEY_NONLINEARITY,
    KEY_QUADRATIC,
    KEY_SCALE_FACTOR,
)
from gyro_calib.units import EARTH_RATE_DEG_H
from sim_nodes.fog import FogConfig, TableSettings, simulate_turntable
from sim_nodes.fog.scenarios import FogRecording

TABLE = TableSettings(output_rate_hz=200.0, lead_s=1.0)
NOISE_FREE = dataclasses.replace(
    FogConfig(), angle_random_walk_deg_sqrt_h=0.0, y_waveguide_gain_error=0.0,
    sense_axis_tilt_deg=0.0, quantise_output=False)
QUIET_TABLE = dataclasses.replace(TABLE, encoder_counts_per_rev=0, zero_index_jitter_arcsec=0.0)
RATES = (1.0, -1.0, 5.0, -5.0, 20.0, -20.0, 50.0, -50.0, 100.0, -100.0)


def _calibrate(rec: FogRecording, **changes: object):  # noqa: ANN202
    return calibrate_fog(rec.output_t_ns, rec.output_counts, table_t_ns=rec.table_t_ns,
                         table_angle_rad=rec.table_angle_rad,
                         table_rate_rad_s=rec.table_rate_rad_s,
                         zero_index_ns=rec.zero_index_ns, settings=FogSettings(**changes))


@pytest.fixture(scope='module')
def noisy() -> FogRecording:
    return simulate_turntable(rates_deg_s=RATES, hold_s=20.0, table=TABLE)


def test_turntable_noise_free_recovers_k_to_1e9() -> None:
    rec = simulate_turntable(NOISE_FREE, rates_deg_s=RATES, hold_s=20.0, table=QUIET_TABLE)
    res = _calibrate(rec, latitude_deg=NOISE_FREE.latitude_deg).results()
    k = res[KEY_SCALE_FACTOR].value
    assert abs(k / rec.truth['turntable_k_counts_per_rad'] - 1) < 1e-9
    assert res[KEY_BIAS].value == pytest.approx(rec.truth['bias_rad_s'], rel=1e-6)
    assert res[KEY_NONLINEARITY].value < 1e-3


@pytest.mark.parametrize(('asymmetry_ppm', 'k2', 'k3'), [
    (300.0, 0.0, 0.0), (0.0, 2e-4, 0.0), (0.0, 0.0, 5e-5), (0.0, -1e-4, 3e-5)])
def test_turntable_recovers_injected_nonlinearity_coefficients(asymmetry_ppm: float, k2: float,
                                                                k3: float) -> None:
    cfg = dataclasses.replace(NOISE_FREE, scale_factor_asymmetry_ppm=asymmetry_ppm,
                              scale_factor_quadratic_s_per_rad=k2,
                              scale_factor_cubic_s2_per_rad2=k3)
    rec = simulate_turntable(cfg, rates_deg_s=RATES, hold_s=20.0, table=QUIET_TABLE)
    res = _calibrate(rec).results()
    if asymmetry_ppm:
        assert res[KEY_ASYMMETRY].value == pytest.approx(asymmetry_ppm, abs=1e-3)
    else:
        assert res[KEY_QUADRATIC].value == pytest.approx(rec.truth['quadratic_s_per_rad'],
                                                         rel=1e-6, abs=1e-12)
        assert res[KEY_CUBIC].value == pytest.approx(rec.truth['cubic_s2_per_rad2'],
                                                     rel=1e-6, abs=1e-12)
        assert res[KEY_NONLINEARITY].value > 1.0  # curvature shows in the residuals


def test_turntable_noisy_results_lie_within_their_uncertainty(noisy: FogRecording) -> None:
    res = _calibrate(noisy, latitude_deg=FogConfig().latitude_deg).results()
    k = res[KEY_SCALE_FACTOR]
    assert abs(k.value - noisy.truth['turntable_k_counts_per_rad']) < 4 * k.std_uncertainty
    assert 1e-9 < k.relative_uncertainty < 1e-6
    bias = res[KEY_BIAS]
    assert abs(bias.value - noisy.truth['bias_rad_s']) < 4 * bias.std_uncertainty
    assert abs(res[KEY_ASYMMETRY].value) < 4 * res[KEY_ASYMMETRY].std_uncertainty
    assert k.n_used == len(RATES)


def test_turntable_bias_keeps_earth_rate_without_latitude(noisy: FogRecording) -> None:
    res = _calibrate(noisy).results()
    assert KEY_BIAS not in res
    both = res[KEY_BIAS_PLUS_EARTH]
    truth = noisy.truth['bias_plus_earth_rate_rad_s']
    assert abs(both.value - truth) < 4 * both.std_uncertainty


def test_turntable_without_zero_index_bounds_the_earth_residual(noisy: FogRecording) -> None:
    rec = dataclasses.replace(noisy, zero_index_ns=np.zeros(0, dtype=np.int64))
    cal = _calibrate(rec)
    k = cal.results()[KEY_SCALE_FACTOR]
    assert all(s.revolutions == 0 and s.earth_bound_rad_s > 0 for s in cal.segments)
    assert abs(k.value - noisy.truth['turntable_k_counts_per_rad']) < 4 * k.std_uncertainty
    with_index = _calibrate(noisy)
    assert sum(s.revolutions > 0 for s in with_index.segments) >= 6  # ≥ 20 °/s: whole revs


def test_turntable_spurious_zero_index_events_are_ignored(noisy: FogRecording) -> None:
    rng = np.random.default_rng(5)
    extra = rng.integers(noisy.output_t_ns[0], noisy.output_t_ns[-1], 25)
    rec = dataclasses.replace(noisy, zero_index_ns=np.sort(np.concatenate(
        (noisy.zero_index_ns, extra))))
    clean = _calibrate(noisy).results()[KEY_SCALE_FACTOR]
    spoiled = _calibrate(rec).results()[KEY_SCALE_FACTOR]
    assert abs(spoiled.value - clean.value) < clean.std_uncertainty


# -- property test: a generator written here from the physics, not the simulator ---------------
@dataclass(frozen=True)
class TurntableRun:
    """Piecewise constant-rate table motion and an ideal FOG: C = ⌊K·(ψ + b·t + W) + φ₀⌋."""

    rates_deg_s: tuple[float, ...]
    holds_s: tuple[float, ...]
    k_counts_per_rad: float
    bias_rad_s: float
    arw_rad_sqrt_s: float
    output_hz: float
    with_index: bool
    seed: int


@st.composite
def turntable_runs(draw: st.DrawFn) -> TurntableRun:
    n_rates = draw(st.integers(3, 6))
    rates = draw(st.lists(st.floats(0.5, 200.0), min_size=n_rates, max_size=n_rates,
                          unique_by=lambda r: round(r, 0)))
    signs = draw(st.lists(st.sampled_from([-1.0, 1.0]), min_size=n_rates, max_size=n_rates))
    holds = draw(st.lists(st.floats(8.0, 25.0), min_size=n_rates, max_size=n_rates))
    return TurntableRun(
        rates_deg_s=tuple(r * s for r, s in zip(rates, signs)), holds_s=tuple(holds),
        k_counts_per_rad=10 ** draw(st.floats(3.0, 6.0)),
        bias_rad_s=draw(st.floats(-1e-4, 1e-4)),
        arw_rad_sqrt_s=10 ** draw(st.floats(-7.0, -5.0)),
        output_hz=draw(st.sampled_from([100.0, 200.0, 250.0, 500.0])),
        with_index=draw(st.booleans()), seed=draw(st.integers(0, 2**16)))


def _synthesise(run: TurntableRun) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(run.seed)
    acc = math.radians(50.0)
    pieces: list[tuple[float, float]] = [(1.0, 0.0)]  # (duration, acceleration)
    rate = 0.0
    for r_deg, hold in zip(run.rates_deg_s, run.holds_s):
        target = math.radians(r_deg)
        pieces.append((abs(target - rate) / acc, math.copysign(acc, target - rate)))
        pieces.append((hold, 0.0))
        rate = target
    pieces.append((1.0, 0.0))
    dt = 1.0 / run.output_hz
    t = np.arange(0.0, sum(d for d, _ in pieces), dt)
    psi, w = np.zeros_like(t), np.zeros_like(t)
    t0, psi0, w0 = 0.0, 0.0, 0.0
    for d, a in pieces:
        inside = (t >= t0) & (t < t0 + d)
        s = t[inside] - t0
        psi[inside] = psi0 + w0 * s + 0.5 * a * s * s
        w[inside] = w0 + a * s
        psi0, w0, t0 = psi0 + w0 * d + 0.5 * a * d * d, w0 + a * d, t0 + d
    walk = np.cumsum(rng.standard_normal(len(t))) * run.arw_rad_sqrt_s * math.sqrt(dt)
    sensed = psi + run.bias_rad_s * t + walk
    counts = np.floor(run.k_counts_per_rad * sensed + rng.uniform())
    t_ns = (1_000_000_000 + np.round(t * 1e9)).astype(np.int64)
    index = np.zeros(0, dtype=np.int64)
    if run.with_index:  # reference mark at 0.3 rad, crossings within the motion
        turns = np.floor((psi - 0.3) / (2 * math.pi))
        at = np.nonzero(np.diff(turns))[0]
        frac = (0.3 + 2 * math.pi * np.maximum(turns[at], turns[at + 1]) - psi[at]) / (
            psi[at + 1] - psi[at])
        index = t_ns[at] + np.round(frac * dt * 1e9).astype(np.int64)
    keep = slice(None, None, 5)
    return {'output_t_ns': t_ns, 'output_counts': counts, 'table_t_ns': t_ns[keep],
            'table_angle_rad': psi[keep], 'table_rate_rad_s': w[keep], 'zero_index_ns': index}


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(turntable_runs())
def test_turntable_k_and_bias_lie_within_stated_uncertainty(run: TurntableRun) -> None:
    data = _synthesise(run)
    cal = calibrate_fog(data['output_t_ns'], data['output_counts'],
                        table_t_ns=data['table_t_ns'], table_angle_rad=data['table_angle_rad'],
                        table_rate_rad_s=data['table_rate_rad_s'],
                        zero_index_ns=data['zero_index_ns'])
    res = cal.results()
    k = res[KEY_SCALE_FACTOR]
    truth = run.k_counts_per_rad
    assert abs(k.value - truth) <= 4.5 * k.std_uncertainty + 1e-12 * truth
    bias = res[KEY_BIAS_PLUS_EARTH]  # the generator has no Earth rate: bias alone
    assert abs(bias.value - run.bias_rad_s) <= 4.5 * bias.std_uncertainty + 1e-12
    assert k.n_used == len(run.rates_deg_s)


def test_earth_rate_constant_is_the_projects() -> None:
    from gyro_calib.fog.turntable import EARTH_RATE_RAD_S
    assert EARTH_RATE_RAD_S == pytest.approx(math.radians(EARTH_RATE_DEG_H) / 3600)
