"""Bad input to the K̃ calibrator: a clear reason for every fault, never a wrong number.

Each test simulates (or reuses) a clean rate-bias bench with the noise sources
off, corrupts a copy of its arrays the way a real bench or a bag goes wrong, and
checks three things (METHODS §A.1–A.2):

* the fault is named in a rejection reason (or a notice of ``process()``);
* every accepted pair still gives the true K̃ = K/cos θ to |rel. error| < 1e-7;
* the pairs completed before the fault are kept unchanged.

The fault is put in the third window of the run (the second forward one), so
one clean pair precedes it and several follow.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import TYPE_CHECKING

import numpy as np
import pytest

from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.rbrlg.calibrator import CalibrationUpdate, RateBiasCalibrator, calibrate_k_tilde
from gyro_calib.rbrlg.config import KTildeConfig, k_tilde_config_from_mapping, load_k_tilde_config
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S
from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator
from sim_nodes.rbrlg.bench import (
    BenchRecording,
    simulate_rate_bias_bench,
    true_k_tilde_arcsec_per_pulse,
)
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.windows import RevolutionWindow

CLEAN_TABLE = RateTableConfig(duration_s=150.0, zero_index_jitter_arcsec=0.0)
CLEAN_GYRO = RingLaserGyroConfig(angle_random_walk_deg_sqrt_h=0.0)
TRUTH = true_k_tilde_arcsec_per_pulse(CLEAN_GYRO)
REL_TOL = 1e-7
"""Largest |K̃/truth − 1| of any accepted pair (noise off: integer pulses alone give ~1e-9)."""
FAULT_WINDOW = 2
"""Index of the clean window every corruption targets (forward, t ≈ 29.7 s → 41.7 s)."""


# -- fixtures and helpers --------------------------------------------------------------------
@pytest.fixture(scope='module')
def clean_run() -> BenchRecording:
    return simulate_rate_bias_bench(CLEAN_TABLE, CLEAN_GYRO)


@pytest.fixture(scope='module')
def clean_cal(clean_run: BenchRecording) -> RateBiasCalibrator:
    cal = _batch(clean_run)
    # the reference every test compares with: 10 windows, 5 pairs, nothing rejected
    assert len(cal.windows) == 10 and len(cal.pairs) == 5 and not cal.rejections
    assert cal.windows[FAULT_WINDOW].direction == 1
    return cal


@pytest.fixture(scope='module')
def victim(clean_cal: RateBiasCalibrator) -> RevolutionWindow:
    return clean_cal.windows[FAULT_WINDOW]


def _batch(run: BenchRecording, config: KTildeConfig | None = None) -> RateBiasCalibrator:
    return calibrate_k_tilde(run.pulse_t_ns, run.pulse_counts, run.table_t_ns,
                             run.table_angle_rad, run.table_rate_rad_s, run.zero_index_ns,
                             config)


def _copy(run: BenchRecording, **changes: np.ndarray) -> BenchRecording:
    """A deep copy of ``run`` with some arrays replaced."""
    fields = {f.name: np.array(getattr(run, f.name)) for f in dataclasses.fields(run)}
    fields.update(changes)
    return BenchRecording(**fields)


def _s(t_s: float) -> int:
    return int(round(t_s * NS_PER_S))


def _arrival_order(*stamps: np.ndarray) -> list[tuple[int, int]]:
    """(stream, index) in the order a subscriber would see them.

    (stream, index) in the order a subscriber would see them: each stream in array order,
    the streams interleaved by the newest stamp each has reached.
    """
    keys = np.concatenate([np.maximum.accumulate(t) for t in stamps])
    which = np.concatenate([np.full(len(t), k) for k, t in enumerate(stamps)])
    index = np.concatenate([np.arange(len(t)) for t in stamps])
    order = np.lexsort((which, keys))
    return list(zip(which[order].tolist(), index[order].tolist()))


def _stream_samples(cal: RateBiasCalibrator, run: BenchRecording, *,
                    process_every: int = 100) -> list[CalibrationUpdate]:
    """Feed ``run`` one sample at a time, calling ``process()`` every ``process_every``."""
    updates = []
    pt, pc = run.pulse_t_ns.tolist(), run.pulse_counts.tolist()
    st, sa = run.table_t_ns.tolist(), run.table_angle_rad.tolist()
    sr = run.table_rate_rad_s.tolist()
    zt = run.zero_index_ns.tolist()
    order = _arrival_order(run.pulse_t_ns, run.table_t_ns, run.zero_index_ns)
    for n, (stream, i) in enumerate(order, start=1):
        if stream == 0:
            cal.add_pulses(pt[i], pc[i])
        elif stream == 1:
            cal.add_table_state(st[i], sa[i], sr[i])
        else:
            cal.add_zero_index(zt[i])
        if n % process_every == 0:
            updates.append(cal.process())
    return updates


def _stream_chunks(cal: RateBiasCalibrator, run: BenchRecording, *,
                   chunk_s: float = 1.0) -> list[CalibrationUpdate]:
    """Feed ``run`` as chunks of ``chunk_s`` seconds, calling ``process()`` after each."""
    updates = []
    t0 = int(run.pulse_t_ns[0])
    edges = range(t0, int(run.pulse_t_ns[-1]) + _s(chunk_s), _s(chunk_s))
    for lo in edges:
        hi = lo + _s(chunk_s)
        p = (run.pulse_t_ns >= lo) & (run.pulse_t_ns < hi)
        s = (run.table_t_ns >= lo) & (run.table_t_ns < hi)
        z = (run.zero_index_ns >= lo) & (run.zero_index_ns < hi)
        cal.extend_pulses(run.pulse_t_ns[p], run.pulse_counts[p])
        cal.extend_table_states(run.table_t_ns[s], run.table_angle_rad[s],
                                run.table_rate_rad_s[s])
        cal.extend_zero_index(run.zero_index_ns[z])
        updates.append(cal.process())
    return updates


def _truncate(run: BenchRecording, end_ns: int) -> BenchRecording:
    p, s, z = run.pulse_t_ns < end_ns, run.table_t_ns < end_ns, run.zero_index_ns < end_ns
    return BenchRecording(run.pulse_t_ns[p], run.pulse_counts[p], run.table_t_ns[s],
                          run.table_angle_rad[s], run.table_rate_rad_s[s],
                          run.zero_index_ns[z])


def _k_values(cal: RateBiasCalibrator) -> list[float]:
    return [p.k_tilde_arcsec_per_pulse for p in cal.pairs]


def _spans(windows: list[RevolutionWindow]) -> list[tuple[int, int]]:
    return [(w.start_ns, w.end_ns) for w in windows]


def _assert_no_wrong_number(cal: RateBiasCalibrator, truth: float = TRUTH) -> None:
    """Every accepted pair gives the true K̃; no NaN or inf anywhere in the results."""
    for w in cal.windows:
        assert math.isfinite(w.pulses) and math.isfinite(w.pulses_std), w
    for p in cal.pairs:
        k = p.k_tilde_arcsec_per_pulse
        assert math.isfinite(k) and math.isfinite(p.k_tilde_std), p
        assert abs(k / truth - 1) < REL_TOL, (
            f'wrong K̃ accepted: pair {p.forward.start_ns / 1e9:.3f} s / '
            f'{p.reverse.start_ns / 1e9:.3f} s gives K̃/truth − 1 = {k / truth - 1:.3e}')


def _assert_reason(cal: RateBiasCalibrator, pattern: str, *,
                   stamp_ns: int | None = None) -> list[str]:
    """At least one rejection (at ``stamp_ns`` if given) whose reason matches ``pattern``."""
    hits = [r.reason for r in cal.rejections
            if re.search(pattern, r.reason, re.IGNORECASE)
            and (stamp_ns is None or r.stamp_ns == stamp_ns)]
    where = '' if stamp_ns is None else f' at {stamp_ns / 1e9:.6f} s'
    assert hits, (f'no rejection{where} matching {pattern!r}; rejections: '
                  f'{[(r.stamp_ns / 1e9, r.reason) for r in cal.rejections]}')
    return hits


def _assert_pairs_before_kept(cal: RateBiasCalibrator, clean: RateBiasCalibrator,
                              fault_ns: int) -> None:
    """Every clean pair that ended before the fault is still there, unchanged."""
    before = [p for p in clean.pairs if max(p.forward.end_ns, p.reverse.end_ns) < fault_ns]
    assert before, 'the fault must come after at least one clean pair'
    assert cal.pairs[:len(before)] == before


def _assert_victim_only_rejected(cal: RateBiasCalibrator, clean: RateBiasCalibrator,
                                 victim: RevolutionWindow) -> None:
    """The corrupted window is gone, every other clean window is still accepted as it was."""
    assert _spans(cal.windows) == [s for s in _spans(clean.windows)
                                   if s != (victim.start_ns, victim.end_ns)]
    assert len(cal.pairs) >= len(clean.pairs) - 1


# -- zero-index events ----------------------------------------------------------------------
@pytest.mark.parametrize('revolutions_per_window', [5, 2])
def test_zero_index_missing_at_window_end_rejects_that_window_with_reason(
        clean_run: BenchRecording, revolutions_per_window: int) -> None:
    config = KTildeConfig(revolutions_per_window=revolutions_per_window)
    clean = _batch(clean_run, config)
    victim = next(w for w in clean.windows if w.start_ns >= _s(29.0))
    dropped = victim.end_ns
    run = _copy(clean_run, zero_index_ns=clean_run.zero_index_ns[
        clean_run.zero_index_ns != dropped])

    cal = _batch(run, config)

    _assert_reason(cal, r'missing zero-index', stamp_ns=victim.start_ns)
    assert (victim.start_ns, victim.end_ns) not in _spans(cal.windows)
    untouched = [s for s in _spans(clean.windows) if not s[0] <= dropped <= s[1]]
    assert set(untouched) <= set(_spans(cal.windows))
    _assert_no_wrong_number(cal)
    _assert_pairs_before_kept(cal, clean, victim.start_ns)


def test_zero_index_missing_inside_window_keeps_window_and_k_tilde(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow) -> None:
    inside = clean_run.zero_index_ns[(clean_run.zero_index_ns > victim.start_ns)
                                     & (clean_run.zero_index_ns < victim.end_ns)]
    assert len(inside) == 4
    run = _copy(clean_run, zero_index_ns=clean_run.zero_index_ns[
        clean_run.zero_index_ns != inside[1]])

    cal = _batch(run)

    assert cal.windows == clean_cal.windows  # counts are cumulative: inner events are not needed
    assert _k_values(cal) == _k_values(clean_cal)
    assert not cal.rejections
    _assert_no_wrong_number(cal)


SPURIOUS_AT = {
    # where the spurious event is stamped: (reference window, offset from its start or end, s)
    'mid_window': ('victim', 'start', 5.3),
    'half_degree_after_window_start': ('victim', 'start', 0.5 / 150.0),
    'half_degree_before_window_end': ('victim', 'end', -0.5 / 150.0),
    'half_degree_before_first_event': ('first', 'start', -0.5 / 150.0),
}


@pytest.mark.parametrize('where', list(SPURIOUS_AT))
def test_zero_index_spurious_event_rejected_naming_reference_mark(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow, where: str) -> None:
    ref, edge, offset_s = SPURIOUS_AT[where]
    window = victim if ref == 'victim' else clean_cal.windows[0]
    spurious = (window.start_ns if edge == 'start' else window.end_ns) + _s(offset_s)
    # the table is at constant rate there and the event is well off the reference mark
    angle = np.interp(spurious, clean_run.table_t_ns, clean_run.table_angle_rad)
    mark = np.interp(window.start_ns, clean_run.table_t_ns, clean_run.table_angle_rad)
    off_arcsec = abs((angle - mark + math.pi) % (2 * math.pi) - math.pi) * ARCSEC_PER_RAD
    assert off_arcsec > 1000.0
    run = _copy(clean_run, zero_index_ns=np.sort(np.append(clean_run.zero_index_ns, spurious)))

    cal = _batch(run)

    _assert_reason(cal, r'reference mark')  # (the clean run has no rejections at all)
    _assert_no_wrong_number(cal)
    # every clean window is still cut between the true marks, with the same counts
    assert cal.windows == clean_cal.windows
    assert _k_values(cal) == _k_values(clean_cal)


# -- stamps ---------------------------------------------------------------------------------
def test_streams_drop_and_count_duplicate_stamps_without_changing_k_tilde(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator) -> None:
    p_reps = np.ones(len(clean_run.pulse_t_ns), dtype=np.int64)
    p_reps[::1000] = 2
    p_reps[::7919] = 3
    s_reps = np.ones(len(clean_run.table_t_ns), dtype=np.int64)
    s_reps[3::200] = 2
    run = _copy(
        clean_run,
        pulse_t_ns=np.repeat(clean_run.pulse_t_ns, p_reps),
        pulse_counts=np.repeat(clean_run.pulse_counts, p_reps),
        table_t_ns=np.repeat(clean_run.table_t_ns, s_reps),
        table_angle_rad=np.repeat(clean_run.table_angle_rad, s_reps),
        table_rate_rad_s=np.repeat(clean_run.table_rate_rad_s, s_reps),
        zero_index_ns=np.repeat(clean_run.zero_index_ns, 2),
    )

    cal = _batch(run)

    assert cal.pulses.stats.duplicate == int(np.sum(p_reps - 1))
    assert cal.table.stats.duplicate == int(np.sum(s_reps - 1))
    assert cal.pulses.stats.out_of_order == cal.table.stats.out_of_order == 0
    assert cal.windows == clean_cal.windows
    assert _k_values(cal) == _k_values(clean_cal)
    assert not cal.rejections


def _swap_neighbours(t_ns: np.ndarray, every: int, first: int, before_ns: int) -> np.ndarray:
    """Index order swapping samples i and i + 1, i = first, first + every, ... (< before_ns)."""
    order = np.arange(len(t_ns))
    i = np.arange(first, len(t_ns) - 1, every)
    i = i[t_ns[i + 1] < before_ns]
    order[i], order[i + 1] = i + 1, i
    return order


@pytest.mark.parametrize('feed', ['batch', 'one_sample_at_a_time'])
def test_streams_resort_out_of_order_stamps_to_identical_k_tilde(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator, feed: str) -> None:
    # swaps stop before the last index event: later samples are never needed, so a
    # streaming calibrator need not have sorted (and counted) them yet
    last = int(clean_run.zero_index_ns[-1])
    p_order = _swap_neighbours(clean_run.pulse_t_ns, 777, 5, last)
    s_order = _swap_neighbours(clean_run.table_t_ns, 333, 7, last)
    # two index events less than restart_backstep_s apart (around a reversal) swapped
    backstep_ns = _s(KTildeConfig().restart_backstep_s)
    close = int(np.argmax(np.diff(clean_run.zero_index_ns) < backstep_ns))
    z_order = _swap_neighbours(clean_run.zero_index_ns, len(clean_run.zero_index_ns), close, last)
    assert not np.array_equal(z_order, np.arange(len(z_order)))
    run = _copy(
        clean_run,
        pulse_t_ns=clean_run.pulse_t_ns[p_order], pulse_counts=clean_run.pulse_counts[p_order],
        table_t_ns=clean_run.table_t_ns[s_order],
        table_angle_rad=clean_run.table_angle_rad[s_order],
        table_rate_rad_s=clean_run.table_rate_rad_s[s_order],
        zero_index_ns=clean_run.zero_index_ns[z_order],
    )

    if feed == 'batch':
        cal = _batch(run)
    else:
        cal = RateBiasCalibrator()
        _stream_samples(cal, run)
        cal.process(flush=True)

    # one descent in the stamps per swapped pair
    assert cal.pulses.stats.out_of_order == int(np.sum(p_order != np.arange(len(p_order)))) // 2
    assert cal.table.stats.out_of_order == int(np.sum(s_order != np.arange(len(s_order)))) // 2
    assert cal.pulses.stats.late == cal.table.stats.late == 0
    assert cal.windows == clean_cal.windows
    assert _k_values(cal) == _k_values(clean_cal)


# -- table motion ---------------------------------------------------------------------------
def _simulate_with_profile(table: RateTableConfig, gyro: RingLaserGyroConfig,
                           profile: MotionProfile) -> BenchRecording:
    """The bench of sim_nodes.rbrlg.bench, but with the table driven by ``profile``."""
    table_sim = RateTableSimulator(table, profile=profile)
    gyro_sim = RingLaserGyroSimulator(gyro)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ('pt', 'pc', 'st', 'sa', 'sr', 'z')}
    dec, n_done = table.joint_state_decimation, 0
    while not table_sim.finished:
        chunk = table_sim.step(50)
        parts['pt'].append(chunk.t_ns)
        parts['pc'].append(gyro_sim.step(chunk.t_ns, chunk.true_angle_rad))
        keep = (np.arange(n_done, n_done + len(chunk.t_ns)) % dec) == 0
        n_done += len(chunk.t_ns)
        parts['st'].append(chunk.t_ns[keep])
        parts['sa'].append(chunk.encoder_angle_rad[keep])
        parts['sr'].append(chunk.encoder_rate_rad_s[keep])
        parts['z'].append(chunk.zero_index_ns)
    return BenchRecording(*(np.concatenate(parts[k]) for k in ('pt', 'pc', 'st', 'sa', 'sr', 'z')))


def _profile_with_backoff(table: RateTableConfig, segment: int, after_s: float) -> MotionProfile:
    """Rate-bias motion whose ``segment``-th constant-rate segment briefly turns backwards.

    ``after_s`` into that segment the table decelerates through zero to −50 °/s and
    accelerates back to the full rate (0.4 s, no zero-index crossing); the segment is
    lengthened so that it still spans the same angles as in the plain profile.
    """
    rate = math.radians(table.rate_deg_s)
    acc = math.radians(table.acceleration_deg_s2)
    t_const = table.revolutions_per_segment * 2 * math.pi / rate
    dip_s = 0.2  # rate → rate − 0.2·acc = −50 °/s
    lost_s = (2 * dip_s * rate - 2 * dip_s * (rate - acc * dip_s / 2)) / rate
    durations, accels = [rate / acc], [acc]
    direction = 1.0
    for k in range(int(table.duration_s / t_const) + 1):
        if k == segment:
            durations += [after_s, dip_s, dip_s, t_const - after_s + lost_s]
            accels += [0.0, -direction * acc, direction * acc, 0.0]
        else:
            durations.append(t_const)
            accels.append(0.0)
        durations.append(2 * rate / acc)
        accels.append(-direction * acc)
        direction = -direction
    return MotionProfile(durations, accels)


def test_table_direction_change_inside_window_rejected_with_reason(
        clean_cal: RateBiasCalibrator, victim: RevolutionWindow) -> None:
    table = dataclasses.replace(CLEAN_TABLE, duration_s=75.0)
    profile = _profile_with_backoff(table, segment=2, after_s=5.0)
    run = _simulate_with_profile(table, CLEAN_GYRO, profile)
    t_s = run.table_t_ns / NS_PER_S
    backwards = t_s[run.table_rate_rad_s < 0]
    inside = backwards[(backwards > victim.start_ns / 1e9) & (backwards < victim.end_ns / 1e9)]
    assert len(inside) > 0  # the table does turn backwards inside the victim window ...
    assert np.all(np.diff(run.table_angle_rad[(t_s > inside[0] - 1) & (t_s < inside[0])]) > 0)
    assert np.any(np.diff(run.table_angle_rad[(t_s >= inside[0]) & (t_s <= inside[-1])]) < 0)

    cal = _batch(run)

    _assert_reason(cal, r'direction', stamp_ns=victim.start_ns)
    assert victim.start_ns not in [w.start_ns for w in cal.windows]
    assert _spans(cal.windows)[:FAULT_WINDOW] == _spans(clean_cal.windows)[:FAULT_WINDOW]
    _assert_no_wrong_number(cal)
    _assert_pairs_before_kept(cal, clean_cal, victim.start_ns)


@pytest.mark.parametrize('factor', [1.02, 0.98])
def test_table_rate_excursion_inside_window_rejected_with_reason(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow, factor: float) -> None:
    rate = clean_run.table_rate_rad_s.copy()
    span = ((clean_run.table_t_ns > victim.start_ns + _s(3.0))
            & (clean_run.table_t_ns < victim.start_ns + _s(5.0)))
    rate[span] *= factor
    run = _copy(clean_run, table_rate_rad_s=rate)

    cal = _batch(run)

    _assert_reason(cal, r'rate excursion: the table rate was 1(53|47)\.000 °/s at t=32\.725000 s, '
                   r'2\.000 % from', stamp_ns=victim.start_ns)
    _assert_victim_only_rejected(cal, clean_cal, victim)
    _assert_no_wrong_number(cal)
    _assert_pairs_before_kept(cal, clean_cal, victim.start_ns)


def test_lock_in_at_reversals_leaves_k_tilde_right() -> None:
    table = dataclasses.replace(CLEAN_TABLE, duration_s=75.0)
    gyro = dataclasses.replace(CLEAN_GYRO, lock_in_rate_deg_s=5.0)
    run = simulate_rate_bias_bench(table, gyro)
    # the wide dead band is really there: the counts stand still through every reversal
    still = np.diff(run.pulse_counts) == 0
    reversals = int(np.sum(np.diff(np.sign(run.table_rate_rad_s[run.table_rate_rad_s != 0]))
                           != 0))
    assert reversals >= 4 and int(np.sum(still)) >= 8 * reversals

    cal = _batch(run)

    assert len(cal.pairs) == 2 and not cal.rejections
    _assert_no_wrong_number(cal, true_k_tilde_arcsec_per_pulse(gyro))


# -- sample values --------------------------------------------------------------------------
def _non_finite_case(run: BenchRecording, victim: RevolutionWindow,
                     case: str) -> tuple[BenchRecording, str | None]:
    """Corrupted copy of ``run`` and the reason pattern expected for the victim window."""
    pc = run.pulse_counts.copy()
    sa, sr = run.table_angle_rad.copy(), run.table_rate_rad_s.copy()
    if case == 'scattered':
        pc[11::997] = np.nan
        pc[500::1009] = np.inf
        pc[250::4001] = -np.inf
        sa[7::503] = np.nan
        sr[250::401] = -np.inf
        sr[100::1201] = np.nan
        return _copy(run, pulse_counts=pc, table_angle_rad=sa, table_rate_rad_s=sr), None
    if case == 'pulse_nan_burst_at_index_event':
        near = np.abs(run.pulse_t_ns - victim.end_ns) < _s(0.03)
        pc[near] = np.nan
        return _copy(run, pulse_counts=pc), r'gap'
    if case == 'table_inf_burst_inside_window':
        mid = (run.table_t_ns > victim.start_ns + _s(6.0)) & (
            run.table_t_ns < victim.start_ns + _s(6.3))
        rows = np.nonzero(mid)[0]
        sa[rows[:len(rows) // 2]] = np.inf  # angle bad in the first half, rate in the second
        sr[rows[len(rows) // 2:]] = np.nan
        return _copy(run, table_angle_rad=sa, table_rate_rad_s=sr), r'gap.*joint_states'
    raise AssertionError(case)


@pytest.mark.parametrize('case', ['scattered', 'pulse_nan_burst_at_index_event',
                                  'table_inf_burst_inside_window'])
def test_non_finite_samples_dropped_counted_and_never_reach_k_tilde(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow, case: str) -> None:
    run, pattern = _non_finite_case(clean_run, victim, case)
    bad_p = int(np.sum(~np.isfinite(run.pulse_counts)))
    bad_s = int(np.sum(~(np.isfinite(run.table_angle_rad) & np.isfinite(run.table_rate_rad_s))))
    assert bad_p + bad_s > 0

    cal = _batch(run)

    assert cal.pulses.stats.non_finite == bad_p
    assert cal.table.stats.non_finite == bad_s
    _assert_no_wrong_number(cal)
    if pattern is None:  # isolated samples: every window survives, K̃ stays right
        assert _spans(cal.windows) == _spans(clean_cal.windows)
        assert not cal.rejections
    else:
        _assert_reason(cal, pattern, stamp_ns=victim.start_ns)
        _assert_victim_only_rejected(cal, clean_cal, victim)
        _assert_pairs_before_kept(cal, clean_cal, victim.start_ns)


GAPS = {
    # name: (centre of the deleted span, relative to the victim window, its length, s; accepted?)
    'around_end_index_event_300ms': ('end', 0.0, 0.3, False),
    'mid_window_300ms': ('start', 6.1, 0.3, True),
    'mid_window_800ms': ('start', 6.1, 0.8, False),
}


@pytest.mark.parametrize('name', list(GAPS))
def test_pulse_gap_rejects_window_only_when_it_spoils_the_count(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow, name: str) -> None:
    edge, offset_s, length_s, accepted = GAPS[name]
    centre = (victim.start_ns if edge == 'start' else victim.end_ns) + _s(offset_s)
    keep = np.abs(clean_run.pulse_t_ns - centre) > _s(length_s / 2)
    run = _copy(clean_run, pulse_t_ns=clean_run.pulse_t_ns[keep],
                pulse_counts=clean_run.pulse_counts[keep])

    cal = _batch(run)

    _assert_no_wrong_number(cal)
    if accepted:
        assert cal.windows[FAULT_WINDOW].pulses == victim.pulses  # cumulative counts
        assert cal.windows[FAULT_WINDOW].pulse_samples_missing == int(np.sum(~keep))
        assert _spans(cal.windows) == _spans(clean_cal.windows)
        assert _k_values(cal) == _k_values(clean_cal)
        assert not cal.rejections
    else:
        _assert_reason(cal, r'gap', stamp_ns=victim.start_ns)
        _assert_victim_only_rejected(cal, clean_cal, victim)
        _assert_pairs_before_kept(cal, clean_cal, victim.start_ns)


@pytest.mark.parametrize(('step', 'where'), [
    (-100.0, 'mid_window'),
    (+100.0, 'mid_window'),
    (-100.0, 'just_after_end_index_event'),
])
def test_pulse_count_jump_without_direction_change_rejected_with_reason(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator,
        victim: RevolutionWindow, step: float, where: str) -> None:
    at = victim.start_ns + _s(6.1) if where == 'mid_window' else victim.end_ns + _s(0.03)
    counts = clean_run.pulse_counts.copy()
    counts[clean_run.pulse_t_ns >= at] += step  # every later count shifted: one jump
    run = _copy(clean_run, pulse_counts=counts)

    cal = _batch(run)

    _assert_reason(cal, r'count (jump|glitch)|count jumped', stamp_ns=victim.start_ns)
    _assert_victim_only_rejected(cal, clean_cal, victim)
    _assert_no_wrong_number(cal)
    _assert_pairs_before_kept(cal, clean_cal, victim.start_ns)


# -- streaming --------------------------------------------------------------------------------
def test_streaming_one_sample_at_a_time_gives_same_pairs_as_batch(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator) -> None:
    cal = RateBiasCalibrator()
    updates = _stream_samples(cal, clean_run, process_every=100)
    updates.append(cal.process(flush=True))

    assert _k_values(cal) == _k_values(clean_cal)
    assert cal.windows == clean_cal.windows
    assert [p for u in updates for p in u.pairs] == cal.pairs  # each pair reported once
    assert not [r for u in updates for r in u.rejections]
    assert not [n for u in updates for n in u.notices]


@pytest.mark.parametrize('feed', ['chunks', 'one_sample_at_a_time'])
def test_simulator_restart_mid_run_noticed_and_earlier_pairs_kept(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator, feed: str) -> None:
    first = _truncate(clean_run, _s(90.0))
    cal = RateBiasCalibrator()
    stream = _stream_chunks if feed == 'chunks' else _stream_samples
    before = stream(cal, first)
    n_before = len(cal.pairs)
    assert n_before == 3 and cal.pairs == clean_cal.pairs[:3]
    assert not [n for u in before for n in u.notices]

    after = stream(cal, clean_run)  # the simulator started again: stamps from 0
    after.append(cal.process(flush=True))

    notices = [n for u in after for n in u.notices]
    assert any(re.search(r'restart', n, re.IGNORECASE) for n in notices), notices
    assert cal.pairs[:n_before] == clean_cal.pairs[:3]
    # only the window open at the restart is lost: the second run (the same recording,
    # stamps from 0 again) gives every one of its pairs, as a fresh calibrator would
    new = cal.pairs[n_before:]
    assert [(p.forward.start_ns, p.reverse.start_ns) for p in new] == [
        (p.forward.start_ns, p.reverse.start_ns) for p in clean_cal.pairs]
    assert new == clean_cal.pairs
    assert [p for u in after for p in u.pairs] == new
    _assert_no_wrong_number(cal)
    restarts = (cal.pulses.stats.restarts, cal.table.stats.restarts)
    assert sum(restarts) == 1, f'one restart counted as {restarts} (pulses, joint_states)'


def test_batch_calibration_over_restart_keeps_pairs_of_both_runs(
        clean_run: BenchRecording, clean_cal: RateBiasCalibrator) -> None:
    """A bag holding a simulator restart, given whole to calibrate_k_tilde."""
    first = _truncate(clean_run, _s(90.0))
    both = BenchRecording(*(np.concatenate((getattr(first, f.name), getattr(clean_run, f.name)))
                            for f in dataclasses.fields(BenchRecording)))

    cal = _batch(both)

    # as the streaming form: the first run's pairs are kept, the second run's all follow
    assert [(p.forward.start_ns, p.reverse.start_ns) for p in cal.pairs] == [
        (p.forward.start_ns, p.reverse.start_ns) for p in clean_cal.pairs[:3] + clean_cal.pairs]
    assert cal.pairs == clean_cal.pairs[:3] + clean_cal.pairs
    _assert_no_wrong_number(cal)
    restarts = (cal.pulses.stats.restarts, cal.table.stats.restarts)
    assert restarts == (1, 1), f'one restart counted as {restarts} (pulses, joint_states)'


# -- not enough data --------------------------------------------------------------------------
@pytest.mark.parametrize(('method', 'n_pairs', 'min_pairs'), [
    ('k_tilde', 0, 2),
    ('k_tilde', 1, 3),
    ('earth_plus_bias_deg_h', 0, 2),
    ('earth_plus_bias_deg_h', 1, 3),
])
def test_calibrator_without_enough_pairs_raises_naming_counts(
        clean_run: BenchRecording, method: str, n_pairs: int, min_pairs: int) -> None:
    cal = RateBiasCalibrator(KTildeConfig(min_pairs=min_pairs))
    if n_pairs:
        _stream_chunks(cal, _truncate(clean_run, _s(31.0)))
    else:
        assert cal.process(flush=True) == CalibrationUpdate()
    assert len(cal.pairs) == n_pairs

    with pytest.raises(InsufficientDataError) as info:
        getattr(cal, method)()

    message = str(info.value)
    assert re.search(rf'(?<![\d.]){n_pairs}(?!\.?\d).*pair', message), message
    assert re.search(rf'(?<![\d.]){min_pairs}(?!\.?\d)', message), message


# -- configuration ----------------------------------------------------------------------------
@pytest.mark.parametrize(('field', 'value'), [
    ('revolutions_per_window', 0),
    ('revolutions_per_window', -5),
    ('revolutions_per_window', 2.5),
    ('fit_order', 3),
    ('fit_order', 0),
    ('rate_tolerance', 2.0),
    ('rate_tolerance', 0.0),
    ('fit_half_width_s', -0.1),
    ('fit_half_width_s', math.nan),
    ('max_pulse_gap_s', math.nan),
    ('window_angle_tolerance_arcsec', 648000.0),
    ('min_fit_samples_per_side', 1),
    ('min_pairs', 1),
    ('stall_timeout_s', 0.0),
])
def test_config_invalid_value_raises_config_error_naming_field(field: str, value: float) -> None:
    with pytest.raises(ConfigError, match=rf'\b{field}\b'):
        KTildeConfig(**{field: value})


@pytest.mark.parametrize(('values', 'named'), [
    ({'bogus': 1}, 'bogus'),
    ({'fit_order': 2, 'revolutions_per_windw': 5}, 'revolutions_per_windw'),
    ({'fit_order': 'two'}, 'fit_order'),
    ({'revolutions_per_window': 2.5}, 'revolutions_per_window'),
    ({'rate_tolerance': True}, 'rate_tolerance'),
    ({'fit_order': 3}, 'fit_order'),
])
def test_config_mapping_with_bad_field_raises_config_error_naming_it(
        values: dict[str, object], named: str) -> None:
    with pytest.raises(ConfigError, match=rf'\b{named}\b'):
        k_tilde_config_from_mapping(values)


def test_config_file_missing_raises_config_error_naming_file(tmp_path: Path) -> None:
    path = tmp_path / 'no_such_dir' / 'k_tilde.yaml'
    with pytest.raises(ConfigError, match=re.escape(str(path))):
        load_k_tilde_config(path)


@pytest.mark.parametrize(('text', 'named'), [
    ('revolutions_per_window: [5\nfit_order: 1\n', 'YAML'),
    ('fit_order: 1\n  rate_tolerance: 0.1\n', 'YAML'),
    ('- 5\n- 1\n', 'mapping'),
    ('calibration_node:\n  ros__parameters:\n    fit_order: 7\n', 'fit_order'),
    ('calibration_node:\n  ros__parameters:\n    bogus: 7\n', 'bogus'),
])
def test_config_file_invalid_raises_config_error_naming_file(
        tmp_path: Path, text: str, named: str) -> None:
    path = tmp_path / 'k_tilde.yaml'
    path.write_text(text, encoding='utf-8')
    with pytest.raises(ConfigError) as info:
        load_k_tilde_config(path)
    assert str(path) in str(info.value)
    assert named in str(info.value)
