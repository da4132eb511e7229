"""Bags of several benches, one namespace each (issue 19 part 2): calibrated per namespace.

A lab records two benches on one graph, the second under ``__ns:=/bench2``: their topics are
'/bench1/fog/output', '/bench2/fog/output', ... in one bag. ``--namespace`` reads one bench
as if it were alone; a bag holding a single namespace is read under it without being told.
"""

from __future__ import annotations

import heapq
import json
from pathlib import Path

import pytest

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags, resolve_namespace
from gyro_calib.bagio import BagMessage, bag_info, iter_raw_messages, write_bag
from gyro_calib.cli import main
from gyro_calib.errors import ConfigError

BAGS = Path(__file__).resolve().parent.parent / 'bags'
BENCHES = {'/bench1': BAGS / 'fog_fault_short_plateau',
           '/bench2': BAGS / 'fog_fault_silent_injection'}
"""Two FOG benches with different gyros (their scenarios differ in seed and faults)."""


def _namespaced(out: Path, benches: dict[str, Path]) -> Path:
    """One bag of every bench's messages, each under its namespace, in log-time order."""
    streams = [[BagMessage(ns + topic, log_ns, cdr) for topic, _, log_ns, cdr
                in iter_raw_messages(path)] for ns, path in benches.items()]
    types = {ns + t.name: t.msgtype for ns, path in benches.items()
             for t in bag_info(path).topics.values()}
    write_bag(out, heapq.merge(*streams, key=lambda m: m.log_time_ns), types=types,
              namespace_scenarios={ns: bag_info(p).scenario for ns, p in benches.items()})
    return out


def _values(path: Path, **kwargs: object) -> dict[str, tuple[float, float, int]]:
    outcome = calibrate_bags([path], **kwargs)  # type: ignore[arg-type]
    return {k: (e.value, e.std_uncertainty, e.n_used)
            for k, e in outcome.sessions['fog'].results().items()}


def test_each_namespace_gives_its_own_bench_bit_for_bit(tmp_path: Path) -> None:
    both = _namespaced(tmp_path / 'two_benches', BENCHES)
    alone = {ns: _values(path) for ns, path in BENCHES.items()}
    assert alone['/bench1'] != alone['/bench2']  # two different gyros
    for ns in BENCHES:
        assert _values(both, namespace=ns) == alone[ns]
        assert _values(both, namespace=ns.lstrip('/') + '/') == alone[ns]  # bench2/ = /bench2
    assert bag_info(both).in_namespace('/bench2').scenario == bag_info(BENCHES['/bench2']).scenario


def test_a_single_namespace_is_found_and_said(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    one = _namespaced(tmp_path / 'bench2_only', {'/lab/bench2': BENCHES['/bench2']})
    outcome = calibrate_bags([one])
    assert outcome.namespace == '/lab/bench2'
    assert 'under /lab/bench2, the one namespace' in outcome.notes[0]
    assert {k: (e.value, e.std_uncertainty, e.n_used)
            for k, e in outcome.sessions['fog'].results().items()} == _values(BENCHES['/bench2'])
    assert main(['info', str(one)]) == 0
    out = capsys.readouterr().out
    assert 'note: reading the topics under /lab/bench2' in out
    assert main(['calibrate', str(one), '--json', '--no-progress']) == 0
    assert json.loads(capsys.readouterr().out)['methods']['fog']['results']


def test_several_benches_without_a_namespace_are_refused_naming_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    both = _namespaced(tmp_path / 'two_benches', BENCHES)
    for argv in (['calibrate', str(both)], ['info', str(both)],
                 ['noise', str(both), '--scale-factor-counts-per-rad', '1.0e5']):
        assert main(argv) == 2
        captured = capsys.readouterr()
        assert captured.out == ''
        assert 'several benches, under /bench1, /bench2: choose one with --namespace' \
            in captured.err
    assert main(['calibrate', str(both), '--namespace', '/bench3']) == 2
    err = capsys.readouterr().err
    assert '--namespace /bench3: no topic of the bag(s) lies under it' in err
    assert 'are: /bench1, /bench2' in err


def test_namespace_names_are_checked_and_the_root_wins_when_it_holds_the_contract() -> None:
    infos = [bag_info(BENCHES['/bench1'])]
    assert resolve_namespace(infos, None) == ('', '')
    assert resolve_namespace(infos, '/') == ('', '')
    with pytest.raises(ConfigError, match="namespace '/2bench' is not a ROS namespace"):
        resolve_namespace(infos, '/2bench')
    assert topics.namespaces_holding(
        ['/gyro/pulses', '/a/gyro/pulses', '/a/b/fog/output', '/xgyro/pulses'],
        ['/gyro/pulses', '/fog/output']) == ['', '/a', '/a/b']
    assert topics.relative(topics.GYRO_PULSES) == 'gyro/pulses'
