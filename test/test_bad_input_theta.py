"""Bad input to the θ phase: a clear reason for every fault, never a wrong θ (METHODS §A.3).

Each faulty run is the whole calibration (K̃ phase, then the θ stations) on the
noise-free two-axis bench, with one station spoiled. Every test checks:

* the fault is named, in ``cal.stations.rejections`` (a station) or in
  ``results.fix_error_problem`` (θ as a whole);
* θ, whenever it is reported, is within 0.05″ of the simulated 646.75″, and is not
  reported when the stations cannot give it;
* every accepted station matches the station at the same β of a clean run, the
  stations before the fault and the K̃ pairs unchanged.

The spoiled station is the third one (β = 135°) of 0°, 90°, 135°, 180°, 270°, so
two good stations precede it and two follow; without it the four good stations
still give θ.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

import numpy as np
import pytest

from gyro_calib.rbrlg.calibration import RbrlgCalibrator, RbrlgResults, calibrate_rbrlg
from gyro_calib.units import ARCSEC_PER_RAD, RAD_PER_ARCSEC
from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import (
    TwoAxisRecording,
    simulate_full_procedure,
    simulate_theta_procedure,
    simulate_two_axis_bench,
)
from sim_nodes.rbrlg.procedure import (
    ThetaProcedureConfig,
    _move,
    full_procedure_profiles,
    theta_procedure_profiles,
)
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig

TABLE = RateTableConfig(zero_index_jitter_arcsec=0.0)
GYRO = RingLaserGyroConfig(angle_random_walk_deg_sqrt_h=0.0, sense_axis_azimuth_deg=23.0)
MOUNT = TiltedMountConfig()
THETA_TRUTH_ARCSEC = GYRO.fix_error_angle_arcsec  # 646.75″
THETA_TOL_ARCSEC = 0.05
"""Largest |θ − truth| of any reported θ (noise off: integer pulses alone give < 0.01″)."""
N_OG_TOL_PULSES = 0.05
"""Largest |N_og − clean N_og| of an accepted station (≈ 0.01″ of θ; quantisation ~0.01)."""
STATIONS_DEG = (0.0, 90.0, 135.0, 180.0, 270.0)
FAULT = 2
"""Index of the spoiled station (β = 135°)."""
K_PAIRS = 2
CHUNK = 2000


# -- profiles with one spoiled station ------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Fault:
    """How the spoiled station differs from a clean one.

    Attributes:
        forward_revolutions, reverse_revolutions: position-table revolutions at constant
            rate each way (None: n + 1, as in a clean station).
        creep_arcsec_s: constant rate the rate table creeps at during the station, ″/s.
    """

    forward_revolutions: float | None = None
    reverse_revolutions: float | None = None
    creep_arcsec_s: float = 0.0


Profiles = tuple[MotionProfile, MotionProfile, list[tuple[float, float]]]


def _profiles(stations_deg: tuple[float, ...], n: int, fault: Fault | None) -> Profiles:
    """The full procedure (K̃ phase then θ stations), station ``FAULT`` spoiled by ``fault``.

    Built like ``theta_procedure_profiles`` (same moves, settles, accelerations); the K̃
    phase is taken from ``full_procedure_profiles``, so a clean build equals it.
    """
    cfg = ThetaProcedureConfig(stations_deg=stations_deg, position_table_revolutions=n)
    full_rate, full_position, _ = full_procedure_profiles(
        cfg, k_tilde_pairs=K_PAIRS, rate_deg_s=TABLE.rate_deg_s,
        acceleration_deg_s2=TABLE.acceleration_deg_s2,
        revolutions_per_segment=TABLE.revolutions_per_segment)
    theta_rate, _, _ = theta_procedure_profiles(cfg)
    k_len = len(full_rate.pieces[0]) - len(theta_rate.pieces[0])
    rate_d, rate_a = full_rate.pieces[0][:k_len], full_rate.pieces[1][:k_len]
    pos_d, pos_a = full_position.pieces[0][:1], full_position.pieces[1][:1]
    acc = math.radians(cfg.acceleration_deg_s2)
    w = math.radians(cfg.position_table_rate_deg_s)
    t, psi, stations = sum(rate_d), 0.0, []
    for i, deg in enumerate(stations_deg):
        spoil = fault if (fault is not None and i == FAULT) else Fault()
        d, a = _move(math.radians(deg) - psi, acc, math.radians(60.0))
        if not d:
            d, a = [1e-3], [0.0]
        rate_d, rate_a = rate_d + d, rate_a + a
        pos_d, pos_a = pos_d + [sum(d)], pos_a + [0.0]
        t += sum(d)
        psi = math.radians(deg)
        fwd = spoil.forward_revolutions if spoil.forward_revolutions is not None else n + 1
        rev = spoil.reverse_revolutions if spoil.reverse_revolutions is not None else n + 1
        run_d = [cfg.settle_s, w / acc, fwd * 2 * math.pi / w, 2 * w / acc,
                 rev * 2 * math.pi / w, w / acc, cfg.settle_s]
        run_a = [0.0, acc, 0.0, -acc, 0.0, acc, 0.0]
        run_s = sum(run_d)
        creep = spoil.creep_arcsec_s * RAD_PER_ARCSEC  # reached in 1 s, kept, stopped in 1 s
        if creep:
            rate_d, rate_a = rate_d + [1.0, run_s - 2.0, 1.0], rate_a + [creep, 0.0, -creep]
            psi += creep * (run_s - 1.0)  # the next move goes to the commanded β again
        else:
            rate_d, rate_a = rate_d + [run_s], rate_a + [0.0]
        pos_d, pos_a = pos_d + run_d, pos_a + run_a
        stations.append((t, t + run_s))
        t += run_s
    return MotionProfile(rate_d, rate_a), MotionProfile(pos_d, pos_a), stations


def _simulate(n: int = 1, fault: Fault | None = None,
              stations_deg: tuple[float, ...] = STATIONS_DEG) -> TwoAxisRecording:
    rate, position, stations = _profiles(stations_deg, n, fault)
    return simulate_two_axis_bench(rate, position, stations, TABLE, GYRO, MOUNT,
                                   chunk_samples=CHUNK)


@dataclass(frozen=True, slots=True, repr=False)
class Run:
    """A recording and what ``calibrate_rbrlg`` made of it."""

    rec: TwoAxisRecording
    res: RbrlgResults
    cal: RbrlgCalibrator

    def __repr__(self) -> str:
        """Short, for failure reports: counts and the problem, not the arrays."""
        return (f'Run({len(self.cal.k_tilde.pairs)} K̃ pairs, '
                f'{len(self.cal.stations.stations)} stations, '
                f'{len(self.cal.stations.rejections)} station rejections, '
                f'problem={self.res.fix_error_problem!r})')


def _run(n: int = 1, fault: Fault | None = None) -> Run:
    rec = _simulate(n, fault)
    res, cal = calibrate_rbrlg(rec, position_table_revolutions=n)
    return Run(rec, res, cal)


def _truncate(rec: TwoAxisRecording, end_s: float) -> TwoAxisRecording:
    """``rec`` with every stream cut at ``end_s`` (s from the start)."""
    end_ns = int(end_s * 1e9)

    def cut(t: np.ndarray, *values: np.ndarray) -> tuple[np.ndarray, ...]:
        keep = t < end_ns
        return (t[keep], *(v[keep] for v in values))

    pt, pn = cut(rec.pulse_t_ns, rec.pulse_counts)
    return dataclasses.replace(
        rec, pulse_t_ns=pt, pulse_counts=pn, rate_table=cut(*rec.rate_table),
        rate_zero_index_ns=cut(rec.rate_zero_index_ns)[0],
        position_table=cut(*rec.position_table),
        position_zero_index_ns=cut(rec.position_zero_index_ns)[0],
        stations_s=[s for s in rec.stations_s if s[1] <= end_s])


def _feed(cal: RbrlgCalibrator, rec: TwoAxisRecording) -> RbrlgResults:
    """Feed a whole recording to ``cal`` (what ``calibrate_rbrlg`` does) and resolve it."""
    cal.k_tilde.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    cal.k_tilde.extend_table_states(*rec.rate_table)
    cal.k_tilde.extend_zero_index(rec.rate_zero_index_ns)
    cal.stations.extend((rec.pulse_t_ns, rec.pulse_counts), rec.position_table,
                        rec.position_zero_index_ns, rec.rate_table)
    cal.process(flush=True)
    return cal.results()


# -- checks ------------------------------------------------------------------------------------
def _theta_arcsec(res: RbrlgResults) -> float:
    assert res.fix_error is not None
    return res.fix_error.fix_error_angle_rad.value * ARCSEC_PER_RAD


def _assert_no_wrong_number(res: RbrlgResults, cal: RbrlgCalibrator, clean: Run) -> None:
    """θ right if reported; every station equal to the clean one at its β; K̃ pairs kept."""
    clean_res, clean_cal = clean.res, clean.cal
    if res.fix_error is not None:
        assert abs(_theta_arcsec(res) - THETA_TRUTH_ARCSEC) < THETA_TOL_ARCSEC, res
    by_beta = {round(math.degrees(s.rate_table_angle_rad), 3): s
               for s in clean_cal.stations.stations}
    for s in cal.stations.stations:
        beta = round(math.degrees(s.rate_table_angle_rad), 3)
        assert beta in by_beta, f'station at β = {beta}° was never commanded: {s}'
        assert abs(s.half_difference_pulses - by_beta[beta].half_difference_pulses) \
            < N_OG_TOL_PULSES, (s, by_beta[beta])
    assert cal.k_tilde.pairs == clean_cal.k_tilde.pairs
    assert res.k_tilde_arcsec_per_pulse == clean_res.k_tilde_arcsec_per_pulse


def _assert_earlier_stations_kept(rec: TwoAxisRecording, cal: RbrlgCalibrator,
                                  clean: Run) -> None:
    fault_start_ns = rec.stations_s[FAULT][0] * 1e9
    before = [s for s in clean.cal.stations.stations if s.end_ns < fault_start_ns]
    assert len(before) == FAULT
    assert cal.stations.stations[:FAULT] == before


def _reasons_during_fault(rec: TwoAxisRecording, cal: RbrlgCalibrator) -> list[str]:
    """Station-stage rejections stamped inside the spoiled station's span."""
    start, end = (x * 1e9 for x in rec.stations_s[FAULT])
    return [r.reason for r in cal.stations.rejections if start <= r.stamp_ns <= end]


def _assert_good_stations_give_theta(res: RbrlgResults, cal: RbrlgCalibrator) -> None:
    betas = sorted(round(math.degrees(s.rate_table_angle_rad), 3) for s in cal.stations.stations)
    assert betas == [0.0, 90.0, 180.0, 270.0], (betas, [r.reason for r in cal.stations.rejections])
    assert res.fix_error is not None, res.fix_error_problem
    assert abs(_theta_arcsec(res) - THETA_TRUTH_ARCSEC) < THETA_TOL_ARCSEC
    assert res.fix_error_problem == ''
    assert res.scale_factor_arcsec_per_pulse is not None


# -- fixtures ------------------------------------------------------------------------------------
@pytest.fixture(scope='module')
def clean_n1() -> Run:
    run = _run(1)
    res, cal = run.res, run.cal
    # the reference: 2 K̃ pairs, all 5 stations, nothing rejected, θ right
    assert len(cal.k_tilde.pairs) == K_PAIRS and not cal.k_tilde.rejections
    assert len(cal.stations.stations) == len(STATIONS_DEG) and not cal.stations.rejections
    assert abs(_theta_arcsec(res) - THETA_TRUTH_ARCSEC) < THETA_TOL_ARCSEC
    return run


@pytest.fixture(scope='module')
def clean_n2() -> Run:
    run = _run(2)
    res, cal = run.res, run.cal
    assert len(cal.k_tilde.pairs) == K_PAIRS
    assert len(cal.stations.stations) == len(STATIONS_DEG) and not cal.stations.rejections
    assert abs(_theta_arcsec(res) - THETA_TRUTH_ARCSEC) < THETA_TOL_ARCSEC
    return run


# -- 1. too few position-table revolutions ---------------------------------------------------
def test_station_is_skipped_with_reason_when_fewer_than_n_revolutions_between_marks(
        clean_n2: Run) -> None:
    """A spoiled station that fits no 2-revolution window.

    n = 2, but the spoiled station turns 1.5 revolutions each way: its index marks
    are 1 revolution apart, so no 2-revolution window fits.
    """
    run = _run(2, Fault(forward_revolutions=1.5, reverse_revolutions=1.5))
    rec, res, cal = run.rec, run.res, run.cal
    _assert_no_wrong_number(res, cal, clean_n2)
    _assert_earlier_stations_kept(rec, cal, clean_n2)
    reasons = _reasons_during_fault(rec, cal)
    assert any(re.search(r'no window in the constant-rate cruise.*span 1 revolution\(s\), fewer '
                         r'than the m = 2', r)
               for r in reasons), cal.stations.rejections
    _assert_good_stations_give_theta(res, cal)


def test_station_is_skipped_with_reason_when_under_one_revolution_between_marks(
        clean_n1: Run) -> None:
    """A spoiled station that fits no window at all.

    n = 1, but the spoiled station turns half a revolution each way: it passes the
    index mark once per direction, so no window at all can be cut from it.
    """
    run = _run(1, Fault(forward_revolutions=0.5, reverse_revolutions=0.5))
    rec, res, cal = run.rec, run.res, run.cal
    _assert_no_wrong_number(res, cal, clean_n1)
    _assert_earlier_stations_kept(rec, cal, clean_n1)
    reasons = _reasons_during_fault(rec, cal)
    assert any(re.search(r'revolution|no window|index', r) for r in reasons), (
        'the short station vanished without a reason; rejections: '
        f'{[r.reason for r in cal.stations.rejections]}')
    _assert_good_stations_give_theta(res, cal)


# -- 2. β drifts -----------------------------------------------------------------------------
def test_station_is_skipped_as_beta_drift_when_rate_table_creeps(clean_n1: Run) -> None:
    """The rate table creeps at 20″/s through the spoiled station (≈ 900″ in all)."""
    run = _run(1, Fault(creep_arcsec_s=20.0))
    rec, res, cal = run.rec, run.res, run.cal
    _assert_no_wrong_number(res, cal, clean_n1)
    _assert_earlier_stations_kept(rec, cal, clean_n1)
    reasons = _reasons_during_fault(rec, cal)
    assert any(re.search(r'rate table moved \d+\.\d″ during it \(tolerance 5″\): β drifts', r)
               for r in reasons), cal.stations.rejections
    _assert_good_stations_give_theta(res, cal)


# -- 3. position table reverses inside a window -----------------------------------------------
def test_station_is_skipped_with_reason_when_position_table_reverses_inside_window(
        clean_n1: Run) -> None:
    """A station reversing half a revolution past its index mark.

    The position table passes its index mark (37°), turns half a revolution more and
    reverses; the reverse run is the normal one (2 revolutions). The forward window is
    cut by the reversal; the lone reverse window must not be paired with a window of
    another station, and the later stations must still count.
    """
    half_past_mark = (37.0 + 180.0 - 9.0) / 360.0  # − the 4.5° each of speed-up and reversal
    run = _run(1, Fault(forward_revolutions=half_past_mark))
    rec, res, cal = run.rec, run.res, run.cal
    _assert_no_wrong_number(res, cal, clean_n1)
    _assert_earlier_stations_kept(rec, cal, clean_n1)
    reasons = _reasons_during_fault(rec, cal)
    assert any(re.search(r'revers|direction|no window|unpaired', r) for r in reasons), (
        'no reason names the reversal; rejections during the spoiled station: '
        f'{reasons}')
    _assert_good_stations_give_theta(res, cal)


# -- 4. stations all at one β -----------------------------------------------------------------
def test_fix_error_is_withheld_as_unobservable_when_all_stations_share_one_beta() -> None:
    rec = simulate_full_procedure(ThetaProcedureConfig(stations_deg=(30.0, 30.0, 30.0, 30.0)),
                                  TABLE, GYRO, MOUNT, k_tilde_pairs=K_PAIRS, chunk_samples=CHUNK)
    res, cal = calibrate_rbrlg(rec)
    assert len(cal.stations.stations) == 4 and len(cal.k_tilde.pairs) == K_PAIRS
    assert res.fix_error is None and res.scale_factor_arcsec_per_pulse is None
    assert res.k_tilde_arcsec_per_pulse is not None
    assert re.search(r'span only 0\.0° of rate-table angle β: θ and β₀ are unobservable',
                     res.fix_error_problem), res.fix_error_problem


# -- 5. α far from the nominal tilt -----------------------------------------------------------
def test_fix_error_is_withheld_naming_tilt_when_alpha_far_from_nominal(clean_n1: Run) -> None:
    rec = clean_n1.rec
    cal = RbrlgCalibrator(nominal_tilt_deg=30.0)
    res = _feed(cal, rec)
    assert len(cal.stations.stations) == len(STATIONS_DEG)
    assert res.fix_error is None and res.scale_factor_arcsec_per_pulse is None
    problem = res.fix_error_problem
    assert re.search(r'fitted tilt α = 45\.000° is far from the nominal 30° '
                     r'\(tolerance 5°\)', problem), problem


def test_fix_error_is_reported_when_alpha_matches_nominal(clean_n1: Run) -> None:
    cal = RbrlgCalibrator(nominal_tilt_deg=45.0)
    res = _feed(cal, clean_n1.rec)
    assert res.fix_error_problem == ''
    assert res.fix_error is not None
    assert abs(_theta_arcsec(res) - THETA_TRUTH_ARCSEC) < THETA_TOL_ARCSEC
    assert abs(math.degrees(res.fix_error.tilt_rad.value) - 45.0) < 1e-3


# -- 6. fewer than 3 stations -----------------------------------------------------------------
@pytest.mark.parametrize('n_stations', [1, 2])
def test_fix_error_is_withheld_naming_station_count_when_fewer_than_three_stations(
        clean_n1: Run, n_stations: int) -> None:
    rec = _truncate(clean_n1.rec, clean_n1.rec.stations_s[n_stations - 1][1])
    res, cal = calibrate_rbrlg(rec)
    assert cal.stations.stations == clean_n1.cal.stations.stations[:n_stations]
    assert res.fix_error is None and res.scale_factor_arcsec_per_pulse is None
    assert res.k_tilde_arcsec_per_pulse == clean_n1.res.k_tilde_arcsec_per_pulse
    assert re.search(rf'θ not reported: {n_stations} station\(s\); the fix-error angle needs '
                     r'at least 3 at different β', res.fix_error_problem), res.fix_error_problem


# -- 7. K̃ not available yet ---------------------------------------------------------------------
@pytest.fixture(scope='module')
def theta_only() -> TwoAxisRecording:
    return simulate_theta_procedure(ThetaProcedureConfig(), TABLE, GYRO, MOUNT,
                                    chunk_samples=CHUNK)


def test_fix_error_waits_for_k_tilde_when_recording_has_no_k_tilde_phase(
        theta_only: TwoAxisRecording) -> None:
    res, cal = calibrate_rbrlg(theta_only)
    assert len(cal.stations.stations) == 4 and not cal.k_tilde.pairs
    assert res.k_tilde_arcsec_per_pulse is None
    assert res.fix_error is None and res.scale_factor_arcsec_per_pulse is None
    assert re.search(r'θ waits for K̃', res.fix_error_problem), res.fix_error_problem


def test_fix_error_waits_for_k_tilde_when_k_tilde_phase_gave_one_pair() -> None:
    rec = simulate_full_procedure(ThetaProcedureConfig(), TABLE, GYRO, MOUNT, k_tilde_pairs=1,
                                  chunk_samples=CHUNK)
    res, cal = calibrate_rbrlg(rec)
    assert len(cal.stations.stations) == 4 and len(cal.k_tilde.pairs) == 1
    assert res.k_tilde_arcsec_per_pulse is None
    assert res.fix_error is None and res.scale_factor_arcsec_per_pulse is None
    assert re.search(r'θ waits for K̃', res.fix_error_problem), res.fix_error_problem
