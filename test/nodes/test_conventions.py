"""The ROS conventions a lab expects (issue 19 part 4).

The ROS conventions a lab expects (issue 19 part 4): ``~/reset`` and ``~/save``
(std_srvs/Trigger) on every calibration node, and the opt-in managed (lifecycle) mode.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from gyro_calib.bagio import iter_sample_batches
from gyro_calib.handoff import load_calibration

from .dds_harness import NodeProcess, launch
from .test_adaptive_qos import Graph

BAGS = Path(__file__).resolve().parents[2] / 'bags'


@pytest.fixture
def graph() -> Iterator[Graph]:
    g = Graph()
    yield g
    g.close()


def _call(graph: Graph, client: Any, request: Any, timeout_s: float = 60.0,
          log: Any = None) -> Any:
    """The service's response (a node starting on a loaded CI machine may take long)."""
    said = log() if log is not None else ''
    assert client.wait_for_service(timeout_sec=timeout_s), f'{client.srv_name}\n{said}'
    future = client.call_async(request)
    assert graph.spin_until(future.done, timeout_s), f'{client.srv_name}: no answer\n{said}'
    return future.result()


def test_save_writes_what_is_measured_and_reset_starts_over(
        graph: Graph, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every calibration node offers ``~/save`` and ``~/reset``.

    Every calibration node offers both services; the FOG node is fed a bag's data, saved
    on request (not only at shutdown), then reset to an empty session and state record.
    """
    from std_srvs.srv import Trigger

    from gyro_calib.nodes.calibration_node import CalibrationNode
    from gyro_calib.nodes.fog_calibration_node import FogCalibrationNode

    monkeypatch.chdir(tmp_path)  # calibration_node's default output and state directory
    out = tmp_path / 'fog.yaml'
    fog = graph.add(FogCalibrationNode())
    fog.output_file, fog.gyro_id = str(out), 'FOG-7'
    client = graph.node('client')
    save = client.create_client(Trigger, '/fog_calibration_node/save')
    reset = client.create_client(Trigger, '/fog_calibration_node/reset')
    empty = _call(graph, save, Trigger.Request())
    assert (empty.success, empty.message) == (False, f'nothing measured yet: {out} not written.')
    assert not out.exists()
    for batch in iter_sample_batches(BAGS / 'fog_turntable', fog.session.topics()):
        fog._feed(batch.columns)
    saved = _call(graph, save, Trigger.Request())
    assert saved.success, saved.message
    assert saved.message.startswith(f'{out} written with ')
    written = load_calibration(out)
    measured = fog.session.results()
    assert written.get('fog_scale_factor_counts_per_rad') == \
        measured['fog_scale_factor_counts_per_rad'].value
    done = _call(graph, reset, Trigger.Request())
    assert done.success
    assert done.message.startswith(f'new session: {len(measured)} measured quantities')
    assert not fog.session.results() and not fog.session.rejections()
    assert load_calibration(out).get('fog_scale_factor_counts_per_rad') is not None  # kept

    node = graph.add(CalibrationNode())  # the RBRLG node is not a MethodNode: it has them too
    assert node.get_name() == 'calibration_node'
    assert graph.spin_until(lambda: {'/calibration_node/reset', '/calibration_node/save'} <= {
        n for n, _ in client.get_service_names_and_types_by_node('calibration_node', '/')})
    names = {n for n, _ in client.get_service_names_and_types_by_node('calibration_node', '/')}
    assert not any('change_state' in n for n in names)  # not managed: no lifecycle services


def test_managed_node_consumes_only_while_active(graph: Graph,
                                                 nodes: list[NodeProcess]) -> None:
    """The managed-node lifecycle transitions.

    managed:=true: unconfigured at start with no input subscribed; configure → inactive;
    activate → the inputs are subscribed; deactivate pauses; cleanup starts over.
    """
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState

    from gyro_calib import topics

    node = launch('dither_calibration_node', {'managed': True})
    nodes.append(node)
    client = graph.node('lifecycle_client')
    get = client.create_client(GetState, '/dither_calibration_node/get_state')
    change = client.create_client(ChangeState, '/dither_calibration_node/change_state')

    def state() -> str:
        return str(_call(graph, get, GetState.Request(), log=node.log).current_state.label)

    def readers() -> int:
        graph.spin_until(lambda: False, 1.0)  # let discovery settle
        return int(client.count_subscribers(topics.GYRO_PULSES))

    def go(transition: int) -> None:
        assert _call(graph, change, ChangeState.Request(
            transition=Transition(id=transition)), log=node.log).success, node.log()

    def settles_at(count: int) -> bool:
        deadline = time.monotonic() + 40  # discovery on a loaded CI machine
        while readers() != count and time.monotonic() < deadline:
            pass
        return readers() == count

    assert state() == 'unconfigured', node.log()
    assert readers() == 0, node.log()
    go(Transition.TRANSITION_CONFIGURE)
    assert (state(), readers()) == ('inactive', 0), node.log()
    go(Transition.TRANSITION_ACTIVATE)
    assert state() == 'active', node.log()
    assert settles_at(1), node.log()
    go(Transition.TRANSITION_DEACTIVATE)
    assert state() == 'inactive', node.log()
    assert settles_at(0), node.log()
    go(Transition.TRANSITION_CLEANUP)
    assert state() == 'unconfigured', node.log()
    deadline = time.monotonic() + 20  # the node's log reaches us after its service answer
    while 'cleaned up: new session' not in node.log() and time.monotonic() < deadline:
        time.sleep(0.1)
    log = node.log()
    assert 'managed node: unconfigured' in log
    assert 'active: consuming /gyro/pulses, /vibration_table/joint_states' in log
    assert 'cleaned up: new session: 0 measured quantities' in log
