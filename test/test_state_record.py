"""The state directory resumes bit for bit.

The state directory: a node killed at any instant resumes to the numbers of an
uninterrupted run, bit for bit (issue 19, part 1).

A live node appends every batch to its :class:`~gyro_calib.state_record.StateRecord` before
its session sees it. Here the node's life is played without ROS: committed bags are cut
into small batches, recorded and fed; the "kill" cuts each topic's record file at any byte
(a write in progress), a new session replays what the record holds and is fed the samples
the record lacks; its results must equal ``gyro-calib calibrate`` of the whole bag.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import SampleBatch, bag_info, iter_bags
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.state_record import StateRecord, StateRecordError

BAGS = Path(__file__).resolve().parent.parent / 'bags'
CASES = {'rbrlg': 'k_tilde_mark_in_acceleration', 'fog': 'fog_fault_short_plateau',
         'thermal': 'thermal_fault_stuck_sensor', 'dither': 'dither_small_table'}


def _slice(cols: TopicColumns, part: slice) -> TopicColumns:
    return dataclasses.replace(
        cols, log_time_ns=cols.log_time_ns[part], stamp_ns=cols.stamp_ns[part],
        frame_id=FrameIds(cols.frame_id.codes[part], cols.frame_id.names),
        values={k: v[part] for k, v in cols.values.items()})


def _small_batches(method: str, bag: Path, size: int) -> list[dict[str, TopicColumns]]:
    """The bag's samples of the method's topics as a live node would hand them over."""
    options = CalibrationOptions(scenario=bag_info(bag).scenario or {})
    types = {t: m for t, m in METHODS[method].make_session(options).topics().items()
             if t in bag_info(bag).topics}
    out: list[dict[str, TopicColumns]] = []
    for _, batch in iter_bags([bag], types, batch_messages=size):
        out.append({t: c for t, c in batch.columns.items() if len(c)})
    return out


def _feed(session: MethodSession, columns: dict[str, TopicColumns]) -> None:
    n = sum(len(c) for c in columns.values())
    if n:
        last = max(int(c.stamp_ns.max()) for c in columns.values() if len(c))
        session.feed(SampleBatch(columns, n, last))
        session.process()


def _numbers(session: MethodSession) -> dict[str, tuple[float, float, int]]:
    return {k: (float(e.value), float(e.std_uncertainty), int(e.n_used))
            for k, e in session.results().items()}


@pytest.fixture(scope='module')
def offline() -> dict[str, tuple[dict[str, tuple[float, float, int]], CalibrationOptions]]:
    out = {}
    for method, name in CASES.items():
        bag = BAGS / name
        result = calibrate_bags([bag], methods=[method])
        options = CalibrationOptions(scenario=bag_info(bag).scenario or {})
        out[method] = (_numbers(result.sessions[method]), options)
    return out


@settings(max_examples=12, derandomize=True, deadline=None, phases=[Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(method=st.sampled_from(sorted(CASES)), kill_at=st.floats(0.0, 1.0),
       cut=st.floats(0.0, 1.0), batch=st.sampled_from([97, 1000, 5000]))
def test_a_node_killed_at_any_instant_resumes_to_the_uninterrupted_numbers(
        tmp_path_factory: pytest.TempPathFactory, offline: dict, method: str, kill_at: float,
        cut: float, batch: int) -> None:
    expected, options = offline[method]
    batches = _small_batches(method, BAGS / CASES[method], batch)
    directory = tmp_path_factory.mktemp('state')
    identity = {'method': method, 'gyro_id': 'G-1'}
    # the first life: record, then feed, until killed during the write of batch k
    k = int(kill_at * (len(batches) - 1))
    record = StateRecord(directory, identity)
    first = METHODS[method].make_session(options)
    sizes_before = {}
    for i, columns in enumerate(batches[:k + 1]):
        if i == k:
            sizes_before = {p.name: p.stat().st_size for p in directory.glob('*.rec')}
        record.append(columns)
        _feed(first, columns)
    for path in directory.glob('*.rec'):  # the kill cut the last write anywhere
        full, before = path.stat().st_size, sizes_before.get(path.name, 0)
        with open(path, 'r+b') as f:
            f.truncate(before + int(cut * (full - before)))
    del record, first
    # the second life: replay what the record holds, then the samples it lacks
    record = StateRecord(directory, identity)
    second = METHODS[method].make_session(options)
    held: dict[str, int] = {}
    for columns in record.replay():
        _feed(second, columns)
        for t, c in columns.items():
            held[t] = held.get(t, 0) + len(c)
    seen: dict[str, int] = {}
    for columns in batches:
        rest = {}
        for t, c in columns.items():
            start = seen.get(t, 0)
            seen[t] = start + len(c)
            skip = min(len(c), max(0, held.get(t, 0) - start))
            if skip < len(c):
                rest[t] = _slice(c, slice(skip, None))
        record.append(rest)
        _feed(second, rest)
    second.process(flush=True)
    assert _numbers(second) == expected


def test_a_record_holds_exactly_what_was_appended(tmp_path: Path) -> None:
    batches = _small_batches('fog', BAGS / CASES['fog'], 1000)
    record = StateRecord(tmp_path, {'method': 'fog'})
    for columns in batches:
        record.append(columns)
    record.close()
    again = StateRecord(tmp_path, {'method': 'fog'})
    got = list(again.replay(batch_messages=10**9))
    assert len(got) == 1
    for topic in {t for b in batches for t in b}:
        parts = [b[topic] for b in batches if topic in b]
        np.testing.assert_array_equal(got[0][topic].stamp_ns,
                                      np.concatenate([p.stamp_ns for p in parts]))
        for name in parts[0].values:
            np.testing.assert_array_equal(got[0][topic].values[name],
                                          np.concatenate([p.values[name] for p in parts]))
        assert list(got[0][topic].frame_id.strings()) == [
            s for p in parts for s in p.frame_id.strings()]
    summary = again.summary()
    assert summary.messages == sum(len(c) for b in batches for c in b.values())
    assert summary.batches == len(batches)
    assert summary.dropped_bytes == 0


def test_a_record_of_another_gyro_or_method_is_refused_in_one_line(tmp_path: Path) -> None:
    first = StateRecord(tmp_path, {'method': 'fog', 'gyro_id': 'A-1'})
    first.append(_small_batches('fog', BAGS / CASES['fog'], 50)[0])
    first.close()
    with pytest.raises(StateRecordError, match="gyro_id 'A-1', not 'B-2'.*state_dir"):
        StateRecord(tmp_path, {'method': 'fog', 'gyro_id': 'B-2'})
    with pytest.raises(StateRecordError, match="method 'fog', not 'thermal'"):
        StateRecord(tmp_path, {'method': 'thermal', 'gyro_id': 'A-1'})


def test_a_cut_frame_name_drops_the_samples_that_use_it(tmp_path: Path) -> None:
    cols = _small_batches('fog', BAGS / CASES['fog'], 50)[0]
    record = StateRecord(tmp_path, {'method': 'fog'})
    record.append(cols)
    record.close()
    for path in tmp_path.glob('*.frames.jsonl'):
        path.write_bytes(path.read_bytes()[:-3])  # the name line cut mid-way
    again = StateRecord(tmp_path, {'method': 'fog'})
    assert list(again.replay()) == []
    assert again.summary().dropped_bytes > 0


def test_a_record_that_never_got_a_sample_leaves_no_directory(tmp_path: Path) -> None:
    """A node refused at start-up (or stopped before any data) leaves nothing behind."""
    record = StateRecord(tmp_path / 'gyro.yaml.state', {'method': 'noise'})
    record.close()
    assert not (tmp_path / 'gyro.yaml.state').exists()
    assert list(record.replay()) == [] and record.summary().messages == 0


def test_a_node_moves_a_record_of_other_parameters_aside_and_starts_anew(
        tmp_path: Path) -> None:
    from fake_node import FakeNode

    from gyro_calib.nodes.node_state import NodeState

    directory = tmp_path / 'gyro.yaml.state'
    first = NodeState(FakeNode(), 'rbrlg', '', directory, False, {'min_pairs': 2})
    assert first.record is not None
    first.record.append(_small_batches('fog', BAGS / CASES['fog'], 50)[0])
    first.finish(complete=False)  # the first node stops (its lock released)
    node = FakeNode()
    again = NodeState(node, 'rbrlg', '', directory, False, {'min_pairs': 3}).record
    assert again is not None and again.summary().messages == 0
    aside = [p for p in tmp_path.iterdir() if p.name.startswith('gyro.yaml.state.superseded-')]
    assert len(aside) == 1
    assert StateRecord(aside[0], {}).summary().messages > 0  # nothing of it lost
    assert any("parameter min_pairs '2', not '3'" in line and 'moved to' in line
               for line in node.logger.lines)
