"""Live input in stamp order: the watermark merge a live node puts before its session.

Whatever the arrival order across topics and however the releases are cut, the merge hands
on the samples in the order of a recording; a FOG bag delivered with its topics lagging one
another gives the offline numbers bit for bit; a sample that arrives later than the node may
wait rejects the window that needs it, with a line, and leaves every other window as offline.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import SampleBatch, iter_sample_batches
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.fog.session import TOPICS, FogSession
from gyro_calib.session import CalibrationOptions
from gyro_calib.streams import WatermarkMerge

BAGS = Path(__file__).resolve().parents[1] / 'bags'
NAMES = ('a', 'b', 'c')
SPACING_S = 1e-4
"""Between two messages an unpaced player sends, s."""


@st.composite
def deliveries(draw: Any) -> tuple[list[tuple[str, int]], list[int]]:
    """Per-topic stamp-ordered samples interleaved at random; where releases happen."""
    per_topic = {name: sorted(set(draw(st.lists(st.integers(0, 60), max_size=25))))
                 for name in NAMES}
    queues = {name: list(s) for name, s in per_topic.items()}
    arrivals: list[tuple[str, int]] = []
    while any(queues.values()):
        name = draw(st.sampled_from([n for n in NAMES if queues[n]]))
        arrivals.append((name, queues[name].pop(0)))
    cuts = sorted(set(draw(st.lists(st.integers(0, len(arrivals)), max_size=10))))
    return arrivals, cuts


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(deliveries())
def test_any_arrival_order_and_cut_releases_the_recording_order(
        case: tuple[list[tuple[str, int]], list[int]]) -> None:
    arrivals, cuts = case
    merge = WatermarkMerge(NAMES, hold_s=math.inf)  # stamps alone decide
    released: list[tuple[str, int, object]] = []
    for i, (name, t) in enumerate(arrivals):
        if i in cuts:
            released += merge.release(0.0)
        merge.add(name, t, (name, t), 0.0)
    released += merge.release(0.0, flush=True)
    recording = sorted(arrivals, key=lambda a: (a[1], NAMES.index(a[0])))
    assert [(n, t) for n, t, _ in released] == recording
    assert [p for *_, p in released] == recording
    assert merge.take_late() == [] and merge.held() == 0


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(deliveries(), st.lists(st.floats(0.0, 3.0), min_size=3, max_size=3))
def test_a_silent_topic_holds_the_others_only_for_the_hold_and_late_ones_are_named(
        case: tuple[list[tuple[str, int]], list[int]], lag_s: list[float]) -> None:
    """Each topic reaches the node ``lag_s`` after it was sent (sent 0.1 s apart in order)."""
    arrivals, _ = case
    sent = sorted(arrivals, key=lambda a: (a[1], NAMES.index(a[0])))
    lag = dict(zip(NAMES, lag_s))
    timed = sorted(((0.1 * i + lag[n], n, t) for i, (n, t) in enumerate(sent)))
    merge = WatermarkMerge(NAMES, hold_s=1.0)
    released: list[tuple[str, int]] = []
    released_before: dict[tuple[str, int], int | None] = {}
    for now, name, t in timed:
        released += [(n, s) for n, s, _ in merge.release(now)]
        released_before[(name, t)] = merge.released_ns
        merge.add(name, t, None, now)
    released += [(n, s) for n, s, _ in merge.release(math.inf, flush=True)]
    late = merge.take_late()
    assert sorted(released) == sorted(arrivals)  # nothing lost, nothing twice
    on_time = [r for r in released if r not in late]
    assert on_time == sorted(on_time, key=lambda a: (a[1], NAMES.index(a[0])))
    assert late == [a for a, mark in released_before.items()
                    if mark is not None and a[1] <= mark]
    if max(lag_s) - min(lag_s) < 1.0 - 0.1:  # no reader lagged another by the hold
        assert late == [] and released == sent


def test_a_sparse_topic_is_not_silent_between_its_readings_on_a_live_bench() -> None:
    """Real time: pulses every second, a temperature every minute reaching the node 8 s late.

    Once the temperature has shown its cadence (two readings), its reader may lag by more
    than the hold: the pulses' stamps must also run twice its largest gap past its newest.
    """
    arrivals = sorted([(float(t), 'pulses', t) for t in range(400)]
                      + [(t + (8.0 if t > 60 else 0.0), 'temp', t) for t in range(0, 400, 60)])
    merge = WatermarkMerge(('temp', 'pulses'), hold_s=5.0)
    released: list[tuple[str, int]] = []
    for now, name, t in arrivals:
        released += [(n, s) for n, s, _ in merge.release(now)]
        merge.add(name, t, None, now)
    released += [(n, s) for n, s, _ in merge.release(math.inf, flush=True)]
    assert merge.take_late() == []
    assert released == sorted(released, key=lambda r: (r[1], r[0] == 'pulses'))


def test_readings_that_share_a_stamp_on_one_topic_are_never_late() -> None:
    """Three temperature sensors read at the same stamps on one topic, pulses in between."""
    merge = WatermarkMerge(('temp', 'pulses'), hold_s=math.inf)
    late = []
    for t in range(0, 50, 5):
        merge.add('pulses', t + 5, None, 0.0)
        for sensor in range(3):
            merge.release(0.0)
            merge.add('temp', t, sensor, 0.0)
        late += merge.take_late()
    assert late == []


def test_when_every_topic_pauses_for_the_hold_everything_held_goes_on() -> None:
    """The end of a recording: a node that fits once its input went quiet gets all of it."""
    merge = WatermarkMerge(('temp', 'pulses'), hold_s=5.0)
    for t in range(10):
        merge.add('pulses', t, None, 0.0)
        merge.add('temp', t, None, 0.0)
    assert [t for _, t, _ in merge.release(4.9)] == [t for t in range(9) for _ in '12']
    assert [t for _, t, _ in merge.release(5.1)] == [9, 9] and merge.held() == 0


def test_a_restarted_source_is_merged_afresh_after_the_old_timeline() -> None:
    merge = WatermarkMerge(('a', 'b'), hold_s=math.inf, restart_ns=10)
    for t in (100, 101, 102):
        merge.add('a', t, None, 0.0)
        merge.add('b', t, None, 0.0)
    merge.add('a', 5, None, 0.0)  # 'a' restarted: its stamps went back by far more than 10
    merge.add('b', 5, None, 0.0)
    merge.add('a', 6, None, 0.0)
    out = [(n, t) for n, t, _ in merge.release(0.0)]
    assert out == [('a', 100), ('b', 100), ('a', 101), ('b', 101), ('a', 102), ('b', 102)]
    merge.add('b', 7, None, 0.0)
    assert [(n, t) for n, t, _ in merge.release(0.0)] == [('a', 5), ('b', 5)]
    assert merge.take_late() == []


# -- the FOG session fed as a live node feeds it ---------------------------------------------
def _recording(name: str) -> dict[str, TopicColumns]:
    (batch,) = iter_sample_batches(BAGS / name, TOPICS, batch_messages=10**9)
    return dict(batch.columns)


def _rows(cols: TopicColumns, idx: list[int]) -> TopicColumns:
    i = np.asarray(idx, dtype=np.int64)
    return dataclasses.replace(
        cols, log_time_ns=cols.log_time_ns[i], stamp_ns=cols.stamp_ns[i],
        frame_id=FrameIds(cols.frame_id.codes[i], cols.frame_id.names),
        values={k: v[i] for k, v in cols.values.items()})


def _live(recording: dict[str, TopicColumns], lag_s: dict[str, float], every: int,
          stall: tuple[str, int, float] | None = None) -> FogSession:
    """The bag as an unpaced player sends it, each topic ``lag_s`` late.

    Log order, 10 000 messages a second: 1 s of lag is 40 s of this bag's stamps, more than
    the session's ``stream_lag_s``. The session is fed what the merge releases every
    ``every`` arrivals. ``stall`` = (topic, index, seconds): that reader stalls that long at
    that sample (the ones after it on the topic come after it, as a reader delivers in
    order).
    """
    sent = sorted(((int(c.log_time_ns[i]), topic, i) for topic, c in recording.items()
                   for i in range(len(c))))
    arrival = {(topic, i): k * SPACING_S + lag_s.get(topic, 0.0)
               for k, (_, topic, i) in enumerate(sent)}
    if stall is not None:
        topic, first, seconds = stall
        free = arrival[(topic, first)] + seconds
        for i in range(first, len(recording[topic])):
            free = arrival[(topic, i)] = max(arrival[(topic, i)], free)
    timed = sorted((when, topic, i) for (topic, i), when in arrival.items())
    session = FogSession(CalibrationOptions(latitude_deg=45.75))
    merge = WatermarkMerge(tuple(recording), hold_s=2.0)

    def hand_over(out: list[tuple[str, int, object]]) -> None:
        idx: dict[str, list[int]] = {}
        for topic, _, i in out:
            idx.setdefault(topic, []).append(int(i))  # type: ignore[call-overload]
        if idx:
            cols = {t: _rows(recording[t], ii) for t, ii in idx.items()}
            session.feed(SampleBatch(cols, sum(len(ii) for ii in idx.values()), 0))
        late_ones = merge.take_late()
        if late_ones:
            session.late_input(late_ones)
        session.process()

    for k, (now, topic, i) in enumerate(timed):
        merge.add(topic, int(recording[topic].stamp_ns[i]), i, now)
        if k % every == every - 1:
            hand_over(merge.release(now))
    hand_over(merge.release(math.inf, flush=True))
    session.end_of_recording()
    session.process()
    return session


@settings(max_examples=4, deadline=None, derandomize=True, database=None)
@given(st.lists(st.floats(0.0, 1.5), min_size=4, max_size=4), st.integers(50, 5000))
def test_fog_bag_with_lagging_topics_gives_the_offline_numbers(
        lags: list[float], every: int) -> None:
    name = 'fog_fault_silent_injection'
    recording = _recording(name)
    offline = calibrate_bags([BAGS / name]).sessions['fog']
    live = _live(recording, dict(zip(sorted(recording), lags)), every)
    assert live.results() == offline.results()
    assert live.rejections() == offline.rejections()
    assert live.missing() == offline.missing()


def test_fog_zero_index_reader_stalled_beyond_the_hold_rejects_windows_never_changes_them(
        ) -> None:
    """Every segment is the offline one or rejected with a line naming the late event."""
    name = 'fog_turntable'
    recording = _recording(name)
    offline = calibrate_bags([BAGS / name]).sessions['fog']
    assert isinstance(offline, FogSession)
    stamp = int(recording[topics.RATE_TABLE_ZERO_INDEX].stamp_ns[10])
    live = _live(recording, {}, 500, stall=(topics.RATE_TABLE_ZERO_INDEX, 10, 3.0))
    kept = live.calibrator.active_segments
    assert all(s in offline.calibrator.active_segments for s in kept)
    lines = [r.reason for r in live.rejections() if 'reached the node after' in r.reason]
    assert len(lines) == len(offline.calibrator.active_segments) - len(kept) > 0
    assert all('rejected' in line and 'not used' in line for line in lines)
    assert any(f't={stamp / 1e9:.6f} s' in line for line in lines), lines
    assert {r for r in offline.rejections()} <= set(live.rejections())
    k_live = live.results()['fog_scale_factor_counts_per_rad']
    k_offline = offline.results()['fog_scale_factor_counts_per_rad']
    assert k_live.n_used == k_offline.n_used - len(lines)
