"""The live multiposition session finishes by itself once the pose set is well-conditioned.

Specification (issue 38, docs/methods/multiposition.md §G.5): a live session analyses the data
up to each stamp first stamp + n·analysis_period_s in turn, says which static poses it has and
what the set still lacks, and at the first whose pose set is well-conditioned it stops taking
data; its result is then the offline calibration of the data up to that stamp, bit for bit,
however the samples were chunked into batches (stamps, not arrival).
"""

from __future__ import annotations

import numpy as np
import pytest
from multiposition_physics import random_unit, record

from gyro_calib.bagio import SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.errors import ConfigError
from gyro_calib.multiposition.calibrator import MAX_CONDITION, calibrate, lacking
from gyro_calib.multiposition.recording import Recording
from gyro_calib.multiposition.session import IMU, MultipositionSession
from gyro_calib.session import CalibrationOptions

START_NS = 1_700_000_000_000_000_000
TOPIC = '/imu/data'


def batch(t_ns: np.ndarray, gyro: np.ndarray, acc: np.ndarray) -> SampleBatch:
    cols = TopicColumns(TOPIC, IMU, t_ns.copy(), t_ns,
                        FrameIds(np.zeros(len(t_ns), dtype=np.int32), ('imu',)),
                        {'angular_velocity_rad_s': gyro, 'linear_acceleration_m_s2': acc})
    return SampleBatch({TOPIC: cols}, len(t_ns), int(t_ns[-1]))


@pytest.fixture(scope='module')
def turned() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """30 random poses (seed 1: gravity comes near all six axis directions by pose 26)."""
    rng = np.random.default_rng(1)
    t, acc, gyro, _ = record(random_unit(rng), rng, poses=30)
    return START_NS + np.round(t * 1e9).astype(np.int64), acc, gyro


def live_session(**settings: object) -> MultipositionSession:
    session = MultipositionSession(CalibrationOptions(settings=dict(settings)))
    session.live = True
    return session


def feed_in_chunks(session: MultipositionSession, data: tuple[np.ndarray, ...],
                   chunks: np.ndarray) -> list[str]:
    t, acc, gyro = data
    lines = []
    for a, b in zip(chunks[:-1], chunks[1:], strict=True):
        session.feed(batch(t[a:b], gyro[a:b], acc[a:b]))
        lines += session.process()
        if session.finished():
            break
    return lines


def test_the_live_session_finishes_with_the_offline_result_of_the_data_up_to_then(
        turned: tuple[np.ndarray, ...]) -> None:
    t, acc, gyro = turned
    finished_at = set()
    for seed, n_chunks in ((0, 40), (1, 7)):  # small and large batches
        cuts = np.sort(np.random.default_rng(seed).choice(np.arange(1, len(t)), n_chunks - 1,
                                                            replace=False))
        session = live_session()
        lines = feed_in_chunks(session, turned, np.concatenate(([0], cuts, [len(t)])))
        assert session.finished(), lines
        assert 'well-conditioned' in session.finished()
        cut = session.conditions()['finished_at_stamp_ns']
        finished_at.add(cut)
        assert (cut - t[0]) % 10 ** 10 == 0  # on the grid of analysis_period_s = 10 s
        assert cut < t[-1]  # before the end of the data
        keep = t <= cut
        offline = MultipositionSession(CalibrationOptions())
        offline.feed(batch(t[keep], gyro[keep], acc[keep]))
        offline.process(flush=True)
        got, expected = session.imu_calibration(), offline.imu_calibration()
        assert got is not None and expected is not None
        assert got.pulses_to_body_rad is not None and expected.pulses_to_body_rad is not None
        np.testing.assert_array_equal(got.pulses_to_body_rad, expected.pulses_to_body_rad)
        np.testing.assert_array_equal(got.accelerometer['raw_to_body'],
                                      expected.accelerometer['raw_to_body'])
        # later data are not taken, and the summary says how many were left out
        session.feed(batch(t[-10:] + 10 ** 9, gyro[-10:], acc[-10:]))
        assert session.process(flush=True) == []
        assert any('later samples not used' in line for line in session.summary_lines())
        assert any('still needed: ' in line for line in lines)
        assert any('static poses (new: #1 from' in line for line in lines)
    assert len(finished_at) == 1  # the same stamp however the data were chunked


def test_it_says_which_directions_it_still_needs(turned: tuple[np.ndarray, ...]) -> None:
    t, acc, gyro = turned
    keep = t <= t[0] + 40 * 10 ** 9
    session = live_session()
    lines = feed_in_chunks(session, (t[keep], acc[keep], gyro[keep]),
                           np.array([0, int(keep.sum())]))
    assert not session.finished()
    pose_lines = [line for line in lines if 'static poses (new:' in line]
    assert pose_lines and 'a pose with gravity near' in pose_lines[-1], lines
    assert 'more static poses' in pose_lines[-1]


def test_a_set_never_well_conditioned_runs_on_and_offline_ignores_the_criterion(
        turned: tuple[np.ndarray, ...]) -> None:
    t, acc, gyro = turned
    session = live_session(max_condition=1.0)  # no fit is that well conditioned
    feed_in_chunks(session, turned, np.array([0, len(t) // 2, len(t)]))
    assert not session.finished()
    off = live_session(finish_when_conditioned=False)
    feed_in_chunks(off, turned, np.array([0, len(t) // 2, len(t)]))
    assert not off.finished()
    offline = MultipositionSession(CalibrationOptions())
    offline.feed(batch(t, gyro, acc))
    offline.process()
    offline.process(flush=True)
    assert not offline.finished()
    r = offline.result
    assert r is not None and r.gyro is not None and r.well_conditioned
    assert any(line == 'pose set: well-conditioned (§G.5)' for line in offline.summary_lines())


def test_the_criterion_names_each_thing_lacking() -> None:
    u = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    got = lacking(2, u, (None, None), MAX_CONDITION)
    assert got[0] == '10 more static poses (the accelerometer needs 12)'
    assert got[1] == 'a pose with gravity near −x, +y, −y, −z'
    rng = np.random.default_rng(3)
    t, acc, gyro, _ = record(random_unit(rng), rng, poses=13)
    r = calibrate(Recording(t, acc, gyro, 'm/s²', 'rad/s'), gravity_m_s2=9.80665,
                  gravity_std_m_s2=0.0, max_condition=1.0)
    assert r.gyro is not None and r.accelerometer is not None
    assert any(x.startswith('accelerometer cond(JᵀJ) = ') and x.endswith(
        '> 1 (more poses, spread over the sphere, turns about every axis)') for x in r.lacking)
    assert not r.well_conditioned


@pytest.mark.parametrize('value', ['yes', 1.0])
def test_finish_when_conditioned_takes_only_true_or_false(value: object) -> None:
    with pytest.raises(ConfigError, match="'finish_when_conditioned' must be true or false"):
        MultipositionSession(CalibrationOptions(settings={'finish_when_conditioned': value}))
