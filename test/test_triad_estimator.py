"""The triad estimator against the two-axis bench kinematics (docs/methods.md §F).

The generator below is written from the kinematics, not from sim_nodes or from
gyro_calib.triad.kinematics: the outer axis in the body frame comes from composing the bench's
rotations (position table → tilt α → rate table at β → fixture), the counts of every window
from the integral of s·ω over it (table rotation, Earth rate in the rotating body, bias),
then quantised to whole pulses with a random phase and read with Gaussian end noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib.errors import InsufficientDataError
from gyro_calib.triad.estimator import BenchParameter, TriadPair, triad_calibration
from gyro_calib.triad.kinematics import (
    STATION_OFFSET,
    TILT,
    inner_axis_enu,
    outer_axis_direction,
    pair_from_windows,
    remount_direction,
)

ARCSEC = math.pi / 648000
EARTH = 15.041 * ARCSEC  # rad/s
TABLE_RATE = math.radians(150.0)  # rad/s, both tables


def rot(axis: int, angle: float) -> np.ndarray:
    """Active rotation by ``angle`` about coordinate axis ``axis`` (right hand)."""
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


@dataclass
class Bench:
    """Truth of one bench run: the triad and the bench."""

    k_rad: np.ndarray                # K_i, rad/pulse
    axes: np.ndarray                 # rows s_i, body frame
    tilt: float                      # α, rad
    fixture: np.ndarray = field(default_factory=lambda: np.eye(3))  # v_B = F·v_T
    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))    # rad/s along s_i
    latitude: float = math.radians(34.0)
    heading: float = math.radians(20.0)
    chi: float = 0.7                 # position-table angle during inner windows, rad
    count_noise: float = 0.0         # Gaussian count noise per window end, pulses
    quantise: bool = False
    jitter: float = 0.0              # swept-angle error per window end (index), rad

    def outer_axis_body(self, beta: float) -> np.ndarray:
        """The outer axis ON in the body frame, from the bench's rotations.

        Position-table frame Q: z = ON (Up). The rate-table base P is Q turned by α about
        y (its z, the rate-table axis, leans to +x_Q); the table frame T is P turned by β
        about its z; the body is T through the fixture.
        """
        r_qt = rot(1, self.tilt) @ rot(2, beta)
        return np.asarray(self.fixture @ (r_qt.T @ np.array([0.0, 0.0, 1.0])), dtype=float)

    def inner_axis_enu(self) -> np.ndarray:
        """The rate-table axis in East-North-Up while the position table holds at χ."""
        oz_q = rot(2, self.chi) @ rot(1, self.tilt) @ np.array([0.0, 0.0, 1.0])
        # the base is ENU turned by h about Up (§A (4a))
        return np.asarray(rot(2, self.heading) @ oz_q, dtype=float)

    def earth_enu(self) -> np.ndarray:
        return EARTH * np.array([0.0, math.cos(self.latitude), math.sin(self.latitude)])

    def window_counts(self, rng: np.random.Generator, u: np.ndarray, u_enu: np.ndarray,
                      angle: float, sign: int) -> tuple[np.ndarray, float, float]:
        """Counts of a window turning ``angle`` (signed by ``sign``) about u; and A, T.

        ∫ s·ω dt over the window, with ω = sign·rate·u + ω_E(body) and ω_E(body) turning about
        u at −sign·rate: the part of ω_E along u stays, the rest integrates to a sinusoid that
        vanishes over whole turns (kept exactly here for the jittered end points).
        """
        a_true = angle + self.jitter * (rng.standard_normal() - rng.standard_normal())
        t = a_true / TABLE_RATE
        w_e = self.earth_enu()
        w_par = float(w_e @ u_enu)
        w_perp = math.sqrt(max(float(w_e @ w_e) - w_par * w_par, 0.0))
        phase0 = rng.uniform(0, 2 * math.pi)
        counts = np.empty(3)
        for i in range(3):
            s = self.axes[i]
            s_par = float(s @ u)
            s_perp = math.sqrt(max(1.0 - s_par * s_par, 0.0))
            earth = s_par * w_par * t + s_perp * w_perp * (
                math.sin(phase0) - math.sin(phase0 - sign * a_true)) * sign / TABLE_RATE
            c = (sign * a_true * s_par + earth + self.bias[i] * t) / self.k_rad[i]
            if self.quantise:
                start = rng.uniform(0, 1)
                c = math.floor(start + c) - math.floor(start)
            counts[i] = c + self.count_noise * (rng.standard_normal() - rng.standard_normal())
        return counts, a_true, t

    def window_std(self) -> float:
        """Stated standard uncertainty of one window count, pulses."""
        return math.sqrt(2 * self.count_noise**2 + (1 / 6 if self.quantise else 0.0) + 1e-12)

    def pair(self, rng: np.random.Generator, u: np.ndarray, u_enu: np.ndarray, turns: int,
             sensitivity: np.ndarray | None = None) -> TriadPair:
        angle = 2 * math.pi * turns
        n_p, a_p, t_p = self.window_counts(rng, u, u_enu, angle, +1)
        n_m, a_m, t_m = self.window_counts(rng, u, u_enu, angle, -1)
        del a_p, a_m  # the estimator is told the nominal angle and the jitter
        std = np.full(3, self.window_std())
        return pair_from_windows(
            u, forward_counts=n_p, reverse_counts=n_m, counts_std=std,
            forward_angle_rad=angle, reverse_angle_rad=angle, forward_s=t_p, reverse_s=t_m,
            angle_std_rad=math.sqrt(2) * self.jitter,
            earth_rate_along_u_rad_s=float(self.earth_enu() @ u_enu),
            direction_sensitivity=sensitivity)

    def two_axis_run(self, rng: np.random.Generator, stations: list[float], *,
                     station_turns: int = 1, inner_pairs: int = 0, inner_turns: int = 5,
                     stated_tilt: float | None = None) -> list[TriadPair]:
        """K̃ pairs on the inner axis, then one pair per station (u from the stated α)."""
        pairs = [self.pair(rng, self.fixture @ np.array([0.0, 0.0, 1.0]), self.inner_axis_enu(),
                           inner_turns, np.zeros((3, 2))) for _ in range(inner_pairs)]
        for beta in stations:
            u_true = self.outer_axis_body(beta)
            u_stated, d = outer_axis_direction(
                beta, self.tilt if stated_tilt is None else stated_tilt, fixture=self.fixture)
            p = self.pair(rng, u_true, np.array([0.0, 0.0, 1.0]), station_turns, d)
            pairs.append(_with_direction(p, u_stated))
        return pairs


def _with_direction(p: TriadPair, u: np.ndarray) -> TriadPair:
    return TriadPair(u, p.swept_angle_rad, p.count_difference, p.count_difference_std,
                     p.swept_angle_std_rad, p.direction_sensitivity, p.sum_rate,
                     p.sum_rate_std, p.excess_rate_rad_s, p.earth_rate_along_u_rad_s,
                     p.stamp_ns, p.rejected)


def random_axes(rng: np.random.Generator, spread: float = 5e-3) -> np.ndarray:
    """Sense axes within ±``spread`` rad of the body axes (each tilted on both sides)."""
    axes = np.eye(3) + rng.uniform(-spread, spread, (3, 3)) * (1 - np.eye(3))
    return np.asarray(axes / np.linalg.norm(axes, axis=1)[:, None], dtype=float)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))


def test_the_generator_agrees_with_eqs_1_and_13() -> None:
    """The composed rotations give §F eqs. (1) and (13) (the generator is independent)."""
    bench = Bench(np.ones(3), np.eye(3), math.radians(40.0), heading=0.4, chi=2.1)
    for beta in (0.0, 0.3, 2.0, -1.1):
        u, d = outer_axis_direction(beta, bench.tilt)
        np.testing.assert_allclose(bench.outer_axis_body(beta), u, atol=1e-15)
        h = 1e-7
        bent = Bench(np.ones(3), np.eye(3), bench.tilt + h)
        np.testing.assert_allclose((bent.outer_axis_body(beta) - u) / h, d[:, 0], atol=1e-6)
    np.testing.assert_allclose(
        inner_axis_enu(tilt_rad=bench.tilt, heading_deg=math.degrees(bench.heading),
                       position_table_angle_rad=bench.chi), bench.inner_axis_enu(), atol=1e-15)


@pytest.mark.parametrize('fixture_z', [0.0, math.pi / 2])
def test_noise_free_data_recover_everything_to_round_off(fixture_z: float) -> None:
    rng = np.random.default_rng(1)
    fixture = rot(0, math.pi / 2) @ rot(2, fixture_z)  # body y along the rate-table axis
    bench = Bench(np.array([0.84, 2.3, 4.9]) * ARCSEC, random_axes(rng), math.radians(45.0),
                  fixture=fixture, bias=np.array([3.0, -2.0, 1.0]) * ARCSEC)
    pairs = bench.two_axis_run(rng, list(np.radians([10, 100, 190, 280, 55])), inner_pairs=2)
    res = triad_calibration(pairs)
    true_r = bench.axes / bench.k_rad[:, None]
    for i, ch in enumerate(res.channels):
        assert ch.scale_factor_rad_per_pulse is not None and ch.sense_axis is not None
        assert ch.scale_factor_rad_per_pulse.value == pytest.approx(bench.k_rad[i], rel=1e-12)
        s = np.array([e.value for e in ch.sense_axis])
        assert angle_between(s, bench.axes[i]) < 1e-11
        assert ch.bias_rad_s is not None
        assert ch.bias_rad_s.value == pytest.approx(bench.bias[i], abs=1e-9 * ARCSEC)
    assert res.pulses_to_body_rad is not None and res.bias_body_rad_s is not None
    m = np.array([[e.value for e in row] for row in res.pulses_to_body_rad])
    np.testing.assert_allclose(m @ true_r, np.eye(3), atol=1e-11)
    # b = M·β with β_i = b_i/K_i: ω = M·ṅ − b for a gyro at rest in inertial space
    np.testing.assert_allclose([e.value for e in res.bias_body_rad_s],
                               m @ (bench.bias / bench.k_rad), atol=1e-16)


def test_remount_variant_recovers_the_triad() -> None:
    """Single-axis table: ±x, ±y, ±z along the table axis, K̃-style pairs on each."""
    rng = np.random.default_rng(2)
    bench = Bench(np.array([1.0, 1.5, 0.6]) * ARCSEC, random_axes(rng), 0.0)
    pairs = []
    for axis in ('+x', '-x', '+y', '-y', '+z', '-z'):
        u = remount_direction(axis)
        pairs.append(bench.pair(rng, u, np.array([0.0, 0.0, 1.0]), 5))
    res = triad_calibration(pairs)
    for i, ch in enumerate(res.channels):
        assert ch.scale_factor_rad_per_pulse is not None
        assert ch.scale_factor_rad_per_pulse.value == pytest.approx(bench.k_rad[i], rel=1e-12)


COVERAGE: list[bool] = []
COVERAGE_M: list[bool] = []


@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n_stations=st.integers(3, 8),
       tilt_deg=st.floats(30.0, 60.0), inner_pairs=st.integers(0, 4),
       k_arcsec=st.tuples(*[st.floats(0.5, 5.0)] * 3), station_turns=st.integers(1, 3),
       noise=st.floats(0.0, 1.0), jitter_arcsec=st.floats(0.0, 0.2))
def _coverage_examples(seed: int, n_stations: int, tilt_deg: float, inner_pairs: int,
                       k_arcsec: tuple[float, float, float], station_turns: int, noise: float,
                       jitter_arcsec: float) -> None:
    rng = np.random.default_rng(seed)
    bench = Bench(np.array(k_arcsec) * ARCSEC, random_axes(rng), math.radians(tilt_deg),
                  count_noise=noise, quantise=True, jitter=jitter_arcsec * ARCSEC)
    offset = rng.uniform(0, 2 * math.pi)
    stations = [offset + 2 * math.pi * j / n_stations for j in range(n_stations)]
    res = triad_calibration(bench.two_axis_run(rng, stations, station_turns=station_turns,
                                               inner_pairs=inner_pairs))
    for i, ch in enumerate(res.channels):
        assert ch.scale_factor_rad_per_pulse is not None and ch.sense_axis is not None, \
            ch.not_measurable
        k = ch.scale_factor_rad_per_pulse
        COVERAGE.append(abs(k.value - bench.k_rad[i]) <= k.std_uncertainty)
        for j in range(3):
            if j != i:  # the small-angle misalignments; the along-axis component is ≈ 1
                e = ch.sense_axis[j]
                COVERAGE.append(abs(e.value - bench.axes[i, j]) <= e.std_uncertainty)
        assert abs(k.value - bench.k_rad[i]) <= 6 * k.std_uncertainty
    assert res.pulses_to_body_rad is not None and res.pulses_to_body_covariance is not None
    true_m = np.linalg.inv(bench.axes / bench.k_rad[:, None])
    for i in range(3):
        for j in range(3):
            e = res.pulses_to_body_rad[i][j]
            assert e.std_uncertainty == pytest.approx(
                math.sqrt(res.pulses_to_body_covariance[3 * i + j, 3 * i + j]))
            COVERAGE_M.append(abs(e.value - true_m[i, j]) <= e.std_uncertainty)


def test_k_and_sense_axes_are_covered_by_their_uncertainty() -> None:
    """±1σ covers 60–75 % of K_i and misalignment components, and of M's elements.

    60 examples × 9 checks = 540 of each kind: the binomial standard deviation of the coverage is
    2.0 % at 68.3 %, so the band is −4σ … +3σ of the nominal, while a 30 % under- or
    over-statement of u (coverage 52 % or 79 %) falls outside it.
    """
    COVERAGE.clear()
    COVERAGE_M.clear()
    _coverage_examples()
    for checks in (COVERAGE, COVERAGE_M):  # K_i and s_i; the nine elements of M
        n = len(checks)
        assert n >= 500
        coverage = sum(checks) / n
        assert 0.60 <= coverage <= 0.75, f'coverage {coverage:.3f} over {n} checks'


def test_coplanar_directions_are_not_measurable() -> None:
    """α = 90°: every station's u lies in the table's xy plane; without K̃ pairs no row."""
    rng = np.random.default_rng(3)
    bench = Bench(np.ones(3) * ARCSEC, np.eye(3), math.radians(90.0), count_noise=0.3)
    res = triad_calibration(bench.two_axis_run(rng, list(np.radians([0, 90, 180, 270]))))
    assert res.pulses_to_body_rad is None and res.pulses_to_body_covariance is None
    for ch in res.channels:
        assert ch.scale_factor_rad_per_pulse is None
        assert 'do not span 3-D' in ch.not_measurable
        assert 'smallest singular value' in ch.not_measurable
    assert 'do not span 3-D' in res.not_measurable


def test_many_pairs_about_one_axis_do_not_hide_the_stations() -> None:
    """400 K̃ pairs and three stations: the rank test looks at distinct directions."""
    rng = np.random.default_rng(10)
    bench = Bench(np.ones(3) * ARCSEC, random_axes(rng), math.radians(45.0), count_noise=0.1)
    pairs = bench.two_axis_run(rng, list(np.radians([0, 120, 240])), inner_pairs=400)
    res = triad_calibration(pairs)
    assert res.pulses_to_body_rad is not None, res.not_measurable


def test_a_channel_with_rejected_windows_is_solved_if_the_rest_span_it() -> None:
    rng = np.random.default_rng(4)
    bench = Bench(np.array([1.0, 1.0, 1.0]) * ARCSEC, random_axes(rng), math.radians(45.0),
                  count_noise=0.2)
    pairs = bench.two_axis_run(rng, list(np.radians([0, 90, 180, 270])), inner_pairs=2)

    def reject(p: TriadPair, c: int) -> TriadPair:
        lock_in = 'too little rate for the lock-in band'
        why = (lock_in if c == 0 else '', lock_in if c == 1 else '', lock_in if c == 2 else '')
        return TriadPair(p.direction, p.swept_angle_rad, p.count_difference,
                         p.count_difference_std, p.swept_angle_std_rad,
                         p.direction_sensitivity, p.sum_rate, p.sum_rate_std,
                         p.excess_rate_rad_s, p.earth_rate_along_u_rad_s, 7, why)

    # x loses the K̃ pairs and one station: three stations still span 3-D
    spanned = [reject(p, 0) if k in (0, 1, 2) else p for k, p in enumerate(pairs)]
    res = triad_calibration(spanned)
    x = res.channels[0]
    assert x.scale_factor_rad_per_pulse is not None and len(x.rejected) == 3
    assert 'lock-in' in x.rejected[0].reason and x.rejected[0].stamp_ns == 7
    assert abs(x.scale_factor_rad_per_pulse.value - bench.k_rad[0]) \
        <= 4 * x.scale_factor_rad_per_pulse.std_uncertainty
    assert res.pulses_to_body_rad is not None
    # y keeps only two stations (0°, 90°) and the K̃ pairs... then loses the K̃ pairs too
    flat = [reject(p, 1) if k in (0, 1, 4, 5) else p for k, p in enumerate(pairs)]
    res = triad_calibration(flat)
    assert res.channels[1].scale_factor_rad_per_pulse is None
    assert '2 accepted pair(s) about 2 distinct' in res.channels[1].not_measurable
    assert res.channels[0].scale_factor_rad_per_pulse is not None
    assert res.pulses_to_body_rad is None and 'channel y' in res.not_measurable


def test_a_tilt_off_its_stated_value_is_fitted_from_the_data() -> None:
    """α stated 20″ off: as a propagated systematic it biases K_x; fitted, it is recovered."""
    rng = np.random.default_rng(5)
    bench = Bench(np.array([0.84, 0.84, 0.84]) * ARCSEC, random_axes(rng), math.radians(45.0),
                  count_noise=0.1)
    stated = bench.tilt + 20 * ARCSEC
    stations = list(np.radians([0, 45, 90, 135, 180, 225, 270, 315]))
    pairs = bench.two_axis_run(rng, stations, station_turns=5, inner_pairs=8,
                               stated_tilt=stated)
    fixed = triad_calibration(pairs, parameters=[BenchParameter(TILT, 60 * ARCSEC),
                                                 BenchParameter(STATION_OFFSET, 0.0)])
    fitted = triad_calibration(pairs, parameters=[BenchParameter(TILT, 60 * ARCSEC, True),
                                                  BenchParameter(STATION_OFFSET, 0.0)])
    kx_fixed = fixed.channels[0].scale_factor_rad_per_pulse
    kx_fitted = fitted.channels[0].scale_factor_rad_per_pulse
    assert kx_fixed is not None and kx_fitted is not None
    # propagated: the stated 60″ dominates u(K_x) and covers the 20″ error (cot α·δα ≈ 1e-4)
    tilt_line = next(b for b in fixed.budget if b.source == TILT)
    assert tilt_line.scale_factor_relative[0] == pytest.approx(60 * ARCSEC, rel=0.05)
    assert abs(kx_fixed.value / bench.k_rad[0] - 1) > 5e-5
    # fitted: the correction is −20″ within its uncertainty, and K_x is back to ~1e-7
    corr = fitted.parameters[TILT]
    assert abs(corr.value + 20 * ARCSEC) <= 3 * corr.std_uncertainty
    assert corr.std_uncertainty < 0.05 * ARCSEC
    assert abs(kx_fitted.value - bench.k_rad[0]) <= 3 * kx_fitted.std_uncertainty
    assert kx_fitted.relative_uncertainty < 2e-7


def paper_bench_prediction(station_turns: int) -> tuple[np.ndarray, np.ndarray]:
    """u(K_i)/K_i and √trace C(s_i) (″) the model predicts for the paper bench.

    Four stations at 90°, α = 45°, 10 K̃ pairs of m = 5, K = 0.8428″/pulse, ±½-pulse
    quantisation (1/6 pulse² per window), zero-index jitter 0.1″ per window end, α fitted.
    Noise-free counts: the prediction alone (no scatter to widen it).
    """
    rng = np.random.default_rng(6)
    bench = Bench(np.full(3, 0.8428 * ARCSEC), random_axes(rng), math.radians(45.0),
                  quantise=False, jitter=0.1 * ARCSEC)
    bench.jitter = 0.0  # noise-free counts, but the stated jitter below

    def stated(p: TriadPair) -> TriadPair:
        return TriadPair(p.direction, p.swept_angle_rad, p.count_difference,
                         np.full(3, math.sqrt(2 / 6)), 0.1 * ARCSEC, p.direction_sensitivity)

    pairs = [stated(p) for p in bench.two_axis_run(rng, list(np.radians([0, 90, 180, 270])),
                                                   station_turns=station_turns, inner_pairs=10)]
    res = triad_calibration(pairs, parameters=[BenchParameter(TILT, 60 * ARCSEC, True),
                                               BenchParameter(STATION_OFFSET, 0.0)])
    rel = np.array([c.scale_factor_rad_per_pulse.relative_uncertainty  # type: ignore[union-attr]
                    for c in res.channels])
    ang = np.array([math.sqrt(np.trace(c.sense_axis_covariance)) / ARCSEC  # type: ignore[arg-type]
                    for c in res.channels])
    return rel, ang


def test_paper_bench_prediction_against_the_issue_targets() -> None:
    """What the model predicts on the paper bench (docs/methods.md §F.4 table).

    The gyro along the rate-table axis meets |ΔK/K| ≤ 2e-8 and every direction meets 0.5″;
    the other two gyros do NOT meet 1e-7 with one turn per station (≈ 2.5e-7: their K rests
    on the stations' quantisation), and do with five.
    """
    rel, ang = paper_bench_prediction(1)
    assert rel[2] <= 2e-8
    assert np.all(ang <= 0.5)
    assert np.all((rel[:2] > 2e-7) & (rel[:2] < 3e-7))
    rel5, _ = paper_bench_prediction(5)
    assert np.all(rel5 <= 1e-7)


def test_the_station_offset_is_a_rotation_about_the_table_axis() -> None:
    """ψ₀ stated ± 10″: the x and y sense axes carry 10″ (about z), no K moves."""
    rng = np.random.default_rng(7)
    bench = Bench(np.ones(3) * ARCSEC, random_axes(rng), math.radians(45.0), count_noise=0.1)
    pairs = bench.two_axis_run(rng, list(np.radians([0, 90, 180, 270])), inner_pairs=4)
    res = triad_calibration(pairs, parameters=[BenchParameter(TILT, 0.0),
                                               BenchParameter(STATION_OFFSET, 10 * ARCSEC)])
    line = next(b for b in res.budget if b.source == STATION_OFFSET)
    np.testing.assert_allclose(line.direction_rad[:2], 10 * ARCSEC, rtol=0.02)
    assert line.direction_rad[2] < 0.1 * ARCSEC
    assert np.all(line.scale_factor_relative < 1e-9)
    assert {b.source for b in res.budget} == {'counts', 'swept angle', STATION_OFFSET}


def test_bias_without_the_site_is_missing_with_the_reason() -> None:
    rng = np.random.default_rng(8)
    bench = Bench(np.ones(3) * ARCSEC, random_axes(rng), math.radians(45.0), count_noise=0.1)
    pairs = [TriadPair(p.direction, p.swept_angle_rad, p.count_difference,
                       p.count_difference_std, sum_rate=p.sum_rate, sum_rate_std=p.sum_rate_std)
             for p in bench.two_axis_run(rng, list(np.radians([0, 120, 240])), inner_pairs=2)]
    res = triad_calibration(pairs)
    assert res.pulses_to_body_rad is not None and res.bias_body_rad_s is None
    assert all(c.bias_rad_s is None and 'latitude' in c.bias_missing for c in res.channels)
    assert 'latitude' in res.bias_missing


def test_malformed_input_is_refused() -> None:
    with pytest.raises(InsufficientDataError, match='no window pairs'):
        triad_calibration([])
    bad = TriadPair(np.array([0.0, 0.0, 2.0]), 1.0, np.ones(3), np.ones(3))
    with pytest.raises(ValueError, match='unit 3-vector'):
        triad_calibration([bad])
    ok = TriadPair(np.array([0.0, 0.0, 1.0]), 1.0, np.ones(3), np.ones(3))
    with pytest.raises(ValueError, match=r'\(3, 1\) direction_sensitivity'):
        triad_calibration([ok], parameters=[BenchParameter(TILT, 1e-6)])


@pytest.mark.parametrize('complete', [True, False])
def test_a_scatter_above_the_prediction_widens_the_uncertainty(complete: bool) -> None:
    """Counts noisier than stated (×3): the Birge ratio widens u (§F eq. (12))."""
    rng = np.random.default_rng(9)
    bench = Bench(np.ones(3) * ARCSEC, random_axes(rng), math.radians(45.0), count_noise=3.0)
    pairs = bench.two_axis_run(rng, list(np.radians(np.arange(0, 360, 30))), inner_pairs=6)
    honest = triad_calibration(pairs, prediction_complete=complete)
    understated = [TriadPair(p.direction, p.swept_angle_rad, p.count_difference,
                             p.count_difference_std / 3,
                             direction_sensitivity=p.direction_sensitivity) for p in pairs]
    res = triad_calibration(understated, prediction_complete=complete)
    assert 'Birge ratio' in res.basis and res.birge_ratio > 2
    for a, b in zip(res.channels, honest.channels, strict=True):
        ka, kb = a.scale_factor_rad_per_pulse, b.scale_factor_rad_per_pulse
        assert ka is not None and kb is not None
        assert 0.6 < ka.std_uncertainty / kb.std_uncertainty < 1.6
