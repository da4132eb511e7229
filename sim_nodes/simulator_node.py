"""The skeleton every simulator node shares: scenario, run parameters, start gate, progress.

A simulator node keeps only its physics and its messages:

- :class:`SimulatorNode`: a node that publishes its part of /sim/scenario (transient-local)
  with :meth:`~SimulatorNode.publish_scenario` (``rlg_sim``, which follows the table's true
  motion, is one);
- :class:`PacedSimulatorNode`: a simulator that streams a run chunk by chunk. It declares
  ``real_time_factor`` (simulated seconds per wall second; 0 = as fast as the readers
  acknowledge), ``exit_when_done``, ``wait_for_subscribers`` and ``min_subscribers``
  (:meth:`~PacedSimulatorNode.declare_run_parameters`); waits for its readers
  (:class:`~gyro_calib.nodes.ros_io.StartGate`); publishes chunks paced at
  ``real_time_factor`` or, unpaced, a few per timer tick (the reliable writers then wait for
  the readers' acknowledgements); logs the progress (:class:`~gyro_calib.nodes.ros_io.ProgressLog`)
  and 'run finished'; and stops on stalled readers. :func:`run_simulator` runs it until the
  run is done, letting lagging readers acknowledge the last samples.

The chunking and the pacing never change a sample: what is published is the simulator's
run, in stamp order, however the ticks fall.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Iterator, Mapping
from typing import Any

from rclpy.node import Node
from rclpy.publisher import Publisher
from std_msgs.msg import String

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    SCENARIO_QOS,
    ProgressLog,
    StartGate,
    acknowledge_tail,
    described_parameter,
    run_node,
    simulation_done,
    stops_on_stalled_readers,
)
from gyro_calib.topics import relative

PACED = 'Simulated seconds per wall-clock second (0 = as fast as the readers acknowledge).'
"""The usual description of ``real_time_factor``."""

EXIT = 'Shut the node down once the run has been simulated and acknowledged.'
"""The usual description of ``exit_when_done``."""

WAIT = ('Start only once every topic has min_subscribers readers, so nothing is lost at the '
        'start.')
"""The usual description of ``wait_for_subscribers``."""

READERS = 'Readers each topic needs before the run starts.'
"""The usual description of ``min_subscribers``."""

BOTH_READERS = (' (2 when a bag recorder and a calibration node must both hear it from the '
                'start).')
"""What a ``min_subscribers`` description may add."""


class SimulatorNode(Node):
    """A simulator node: publishes its part of /sim/scenario."""

    def publish_scenario(self, scenario: str | Mapping[str, Any]) -> None:
        """Publish ``scenario`` (YAML text, or a mapping dumped with sorted keys) once.

        Published on /sim/scenario, transient-local: a reader that comes later gets it too.
        """
        if not isinstance(scenario, str):
            import yaml

            scenario = yaml.safe_dump(dict(scenario), sort_keys=True)
        self.create_publisher(String, relative(topics.SIM_SCENARIO), SCENARIO_QOS).publish(
            String(data=scenario))


class PacedSimulatorNode(SimulatorNode):
    """A simulator streaming a run chunk by chunk, paced, once its readers are there.

    Subclasses call :meth:`declare_run_parameters` where their parameters are declared,
    and give :attr:`all_publishers`, :attr:`total_s` and :attr:`progress_what`; their run
    either as an iterator of chunks (``_chunks``, each published by ``_publish``, which
    counts ``_n_published`` samples of ``sample_rate_hz``) or by :meth:`run_finished` and
    :meth:`publish_next` (and :meth:`simulated_s` when not counted in samples). With topics
    no recorder reads, :meth:`gate_publishers` and :meth:`internal_publishers`.
    """

    unpaced_chunks = 5
    """Chunks published per timer tick when unpaced (the readers' acknowledgements pace)."""
    samples_what = ''
    """What the samples counted are ('pulse samples'), for 'run finished: N pulse samples'."""
    sample_rate_hz: float
    """Rate of the samples counted in ``_n_published``, Hz."""
    _chunks: Iterator[Any]
    """The run's chunks (for a run given as an iterator)."""
    _scenario_name = ''
    """The scenario :meth:`declare_scenario` took ('' = none)."""

    def __init__(self, node_name: str) -> None:
        """The node; its timer ticks once it is spun (after the subclass has set up)."""
        super().__init__(node_name)
        self.done = False
        self.stalled = ''
        """Why publishing stopped before the end of the run ('' = it did not)."""
        self._wall_start: float | None = None
        self._progress: ProgressLog | None = None
        self._n_published = 0
        """Samples published so far."""
        self._exhausted = False
        self.create_timer(0.005, self._tick)

    def declare_run_parameters(self, *, paced: str = PACED, exit_when_done: str = EXIT,
                               wait: str = WAIT, readers: str = READERS) -> None:
        """Declare the run parameters; the arguments are their descriptions.

        ``real_time_factor`` (default 1.0), ``exit_when_done`` (true),
        ``wait_for_subscribers`` (true) and ``min_subscribers`` (1); the start gate.
        """
        param = functools.partial(described_parameter, self)
        self.real_time_factor = float(param('real_time_factor', 1.0, paced))
        self.exit_when_done = bool(param('exit_when_done', True, exit_when_done))
        self.wait_for_subscribers = bool(param('wait_for_subscribers', True, wait))
        self.min_subscribers = int(param('min_subscribers', 1, readers))
        self._start_gate = StartGate(self.wait_for_subscribers,
                                     min_readers=self.min_subscribers,
                                     logger=self.get_logger())

    def declare_scenario(self, scenarios: Mapping[str, Any], default: str, *, seed: str,
                         rate: str) -> Any:
        """Declare ``scenario``, ``seed``, ``sample_rate_hz`` and the run parameters.

        A scenario node's set-up (triad_sim, imu_multiposition_sim): the scenario named
        (one of ``scenarios``; ``default`` if not given) with the seed and rate given
        (:func:`sim_nodes.scenarios.with_node_parameters`); ``seed`` and ``rate`` are the
        parameters' descriptions. It becomes :attr:`progress_what`'s name.

        Raises:
            ValueError: the scenario is not one of ``scenarios`` (one fatal line, exit 2).
        """
        from sim_nodes.scenarios import with_node_parameters

        param = functools.partial(described_parameter, self)
        name = str(param('scenario', default, f'One of {", ".join(scenarios)}.'))
        seed_value = int(param('seed', -1, seed))
        rate_value = float(param('sample_rate_hz', 0.0, rate))
        self.declare_run_parameters()
        if name not in scenarios:
            raise ValueError(f'{self.get_name()}: scenario {name!r} is not one of '
                             f'{", ".join(scenarios)}.')
        self._scenario_name = name
        return with_node_parameters(name, seed_value, rate_value)

    # -- what a simulator gives -----------------------------------------------------------
    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """Every stream publisher (for the final acknowledgement wait)."""
        raise NotImplementedError

    def gate_publishers(self) -> list[Publisher[Any]]:
        """The topics each needing ``min_subscribers`` readers before the run starts."""
        return self.all_publishers

    def internal_publishers(self) -> list[Publisher[Any]]:
        """Simulator-internal topics, each needing one reader before the run starts."""
        return []

    @property
    def total_s(self) -> float:
        """Simulated seconds of the whole run (progress)."""
        raise NotImplementedError

    @property
    def progress_what(self) -> str:
        """What the progress lines are of (the scenario's name, after :meth:`declare_scenario`)."""
        if not self._scenario_name:
            raise NotImplementedError
        return self._scenario_name

    def start_line(self) -> str:
        """The line logged when the run starts: '<what>: simulating T s at <pace>'."""
        return f'{self.progress_what}: simulating {self.total_s:g} s at {self.pace_line()}'

    def finished_line(self) -> str:
        """The line logged when the run is over: 'run finished[: N <samples_what>]'."""
        return 'run finished' + (f': {self._n_published} {self.samples_what}'
                                 if self.samples_what else '')

    def simulated_s(self) -> float:
        """Simulated seconds published so far (pacing and progress)."""
        return self._n_published / self.sample_rate_hz

    def run_finished(self) -> bool:
        """Whether the whole run has been published (the chunks ran out)."""
        return self._exhausted

    def publish_next(self) -> None:
        """Publish the next chunk of the run (or find that none is left)."""
        chunk = next(self._chunks, None)
        if chunk is None:
            self.run_ended()
            self._exhausted = True
        else:
            self._publish(chunk)

    def _publish(self, chunk: Any) -> None:
        """Publish one chunk of ``_chunks``, adding its samples to ``_n_published``."""
        raise NotImplementedError

    def run_ended(self) -> None:
        """Publish what follows the last chunk (nothing by default)."""

    def pace_line(self) -> str:
        """'2× real time', or "the readers' pace" unpaced."""
        return (f'{self.real_time_factor:g}× real time' if self.real_time_factor > 0
                else "the readers' pace")

    # -- the skeleton ---------------------------------------------------------------------
    @stops_on_stalled_readers
    def _tick(self) -> None:
        if self.done:
            return
        if self._wall_start is None:
            if not self._start_gate.open(self.gate_publishers(),
                                         internal=self.internal_publishers()):
                return  # readers first (see StartGate)
            self._wall_start = self._start_gate.opened_at
            self.get_logger().info(self.start_line())
            self._progress = ProgressLog(self.get_logger(), self.progress_what, self.total_s)
        assert self._wall_start is not None
        budget = self.unpaced_chunks if self.real_time_factor <= 0 else None
        while not self.run_finished() and (budget is None or budget > 0):
            if budget is None:
                due_s = (time.monotonic() - self._wall_start) * self.real_time_factor
                if self.simulated_s() > due_s:
                    break
            else:
                budget -= 1
            self.publish_next()
        if self._progress is not None:
            self._progress.update(self.simulated_s())
        if self.run_finished():
            self.done = True
            self.get_logger().info(self.finished_line())


def run_simulator(node_name: str, make_node: type[PacedSimulatorNode],
                  args: list[str] | None = None) -> None:
    """Run a simulator until its run is done (or it is shut down), then let readers ack."""
    run_node(node_name, make_node, args, done=simulation_done, on_stop=acknowledge_tail)
