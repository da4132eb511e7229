"""The thermal model's current bias, live, for a consumer that subtracts it itself.

Autoware's imu_corrector subtracts a dynamic gyro bias it receives on ``gyro_bias_input``
(geometry_msgs/Vector3Stamped). :class:`ThermalBiasPublisher` gives that bias from the
thermal model (METHODS §D.3, §D.5) with the rules of imu_corrector's rate output: each
pulse pair's bias is decided by :class:`~gyro_calib.thermal.live.OrderedThermalCompensator`
(the bias ``gyro-calib compensate --out`` subtracts, whatever the arrival order), one bias is
published per averaging interval, and while the model cannot give one (no temperature, a
stuck or silent sensor, temperatures not decided within ``thermal_max_age_s``, a temperature
outside the calibrated range) nothing is published and the log says why once per kind of
reason (and again when it resumes). Pure core: the node passes its logger and a publish
callable (:mod:`gyro_calib.nodes.thermal_bias_node`).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from gyro_calib.estimate import Rejection
from gyro_calib.thermal.compensate import CompensatedPair
from gyro_calib.thermal.live import OrderedThermalCompensator
from gyro_calib.thermal.model import ThermalBiasModel


class _HasLogger(Protocol):
    def get_logger(self) -> Any: ...


@dataclass(frozen=True, slots=True)
class LiveBias:
    """The model bias of one averaging interval.

    Attributes:
        stamp_ns: the stamp of the pulse sample it was decided for (the pair's later one).
        bias_rad_s: the bias along the gyro's sense axis, rad/s (ω = K·Δn/Δt − bias).
        bias_std: its standard uncertainty, rad/s.
    """

    stamp_ns: int
    bias_rad_s: float
    bias_std: float


class ThermalBiasPublisher:
    """Feeds pulses and temperatures in arrival order; publishes one bias per interval."""

    def __init__(self, model: ThermalBiasModel, node: _HasLogger,
                 publish: Callable[[LiveBias], None], *, topic: str,
                 max_wait_s: float = 30.0) -> None:
        """Create the ordered compensator for ``model``; ``publish`` gets each bias."""
        self.compensator = OrderedThermalCompensator(model, max_wait_s=max_wait_s)
        self._interval_ns = int(round(model.averaging_interval_s * 1e9))
        self._node, self._publish, self._topic = node, publish, topic
        self._last_interval: int | None = None
        self._state = ''
        self.published = 0

    def add_pulse(self, t_ns: int, count: float) -> None:
        """One /gyro/pulses sample."""
        self._handle(self.compensator.add_pulse(t_ns, count))

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str) -> None:
        """One /gyro/temperature reading."""
        self._handle(self.compensator.add_temperature(t_ns, celsius, frame_id))

    def _handle(self, outs: list[CompensatedPair | Rejection]) -> None:
        log = self._node.get_logger()
        for out in outs:
            if isinstance(out, Rejection):
                if out.reason.startswith('no thermal compensation'):
                    kind = re.sub(r'[-+0-9.:]+', '#', out.reason)
                    if kind != self._state:
                        self._state = kind
                        log.warning(f'{out.reason} Publishing nothing on {self._topic} until '
                                    'the thermal model can give the bias.')
                continue
            interval = (out.t0_ns + (out.t1_ns - out.t0_ns) // 2) // self._interval_ns
            if interval == self._last_interval:
                continue
            self._last_interval = interval
            if self._state:
                self._state = ''
                log.info(f'thermal bias resumed at stamp {out.t1_ns} ns; publishing '
                         f'{self._topic} again.')
            self._publish(LiveBias(out.t1_ns, out.bias_rad_s, out.bias_std))
            self.published += 1
