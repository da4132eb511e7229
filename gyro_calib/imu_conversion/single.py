"""Streaming single-gyro rates; a thermal bias is held by stamp (:class:`PulseRateConverter`)."""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from gyro_calib.estimate import Rejection
from gyro_calib.imu_conversion.calibration import PulseCalibration
from gyro_calib.imu_conversion.rate import ImuAngularVelocity, angular_velocity_from_pulses

if TYPE_CHECKING:
    from gyro_calib.thermal.compensate import CompensatedPair
    from gyro_calib.thermal.live import OrderedThermalCompensator


class PulseRateConverter:
    """Streaming form of :func:`angular_velocity_from_pulses` for a node.

    Feed messages in arrival order (:meth:`add_pulse`, :meth:`add_temperature`); each call
    returns the rates (or :class:`Rejection` s) it releases, in pulse stamp order. Each
    sample after the first gives the rate since the one before. Skipped (a Rejection, no
    rate):

    * a non-finite count — the previous sample stays the reference;
    * a stamp not after the previous one — it becomes the new reference, so a source that
      restarted (stamps jumped back) is followed again from its next sample;
    * with a thermal model: a sample for which the model gives no bias (package docstring;
      the sample is still the next one's reference).

    Without a thermal model a sample's rate is released at once and temperatures are
    ignored. With one, samples are held by stamp until the temperatures that decide their
    bias have arrived, then released with the bias the offline compensation gives them,
    whatever the interleaving of the two topics
    (:class:`~gyro_calib.thermal.live.OrderedThermalCompensator`; at most
    ``thermal_max_age_s`` of stamps and a few intervals later). The calibration may be
    replaced between samples (the reference sample stays; held samples and the
    temperature history are kept when the new model reduces temperatures the same way).
    """

    def __init__(self, calibration: PulseCalibration, *, thermal_max_age_s: float = 30.0) -> None:
        """Start with no reference sample.

        Args:
            calibration: K, bias or thermal model, ARW.
            thermal_max_age_s: with a thermal model, how far (in stamp time) beyond a
                sample's averaging interval the temperatures deciding its bias may lie, s
                (:class:`~gyro_calib.thermal.live.OrderedThermalCompensator`).
        """
        self._live: OrderedThermalCompensator | None = None
        self._calibration = calibration
        self.thermal_max_age_s = thermal_max_age_s
        self._last: tuple[int, float] | None = None
        self.last_bias: tuple[float, float] | None = None
        """The thermal bias (rad/s) and its uncertainty of the latest rate released."""
        self.calibration = calibration

    @property
    def calibration(self) -> PulseCalibration:
        """The calibration in use."""
        return self._calibration

    @calibration.setter
    def calibration(self, calibration: PulseCalibration) -> None:
        model = calibration.thermal_model
        if model is None:
            self._live = None
        elif self._live is None or (
                self._live.model.averaging_interval_s, self._live.model.hdot_window_s,
                self._live.model.max_temperature_gap_s) != (
                model.averaging_interval_s, model.hdot_window_s, model.max_temperature_gap_s):
            from gyro_calib.thermal.live import OrderedThermalCompensator

            self._live = OrderedThermalCompensator(model, max_wait_s=self.thermal_max_age_s)
        else:
            self._live.model = model
        self._calibration = calibration

    @property
    def held(self) -> int:
        """Pulse samples waiting for their thermal bias."""
        return 0 if self._live is None else self._live.held

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str
                        ) -> list[ImuAngularVelocity | Rejection]:
        """One /gyro/temperature reading; the rates it releases (none without a model)."""
        if self._live is None:
            return []
        return self._convert(self._live.add_temperature(t_ns, celsius, frame_id))

    def add_pulse(self, t_ns: int, count: float) -> list[ImuAngularVelocity | Rejection]:
        """One /gyro/pulses sample; the rates (or Rejections) it releases, in stamp order."""
        if self._live is not None:
            return self._convert(self._live.add_pulse(t_ns, count))
        out = self._add_plain(t_ns, count)
        return [] if out is None else [out]

    def add(self, t_ns: int, count: float) -> ImuAngularVelocity | Rejection | None:
        """The rate since the previous sample, a Rejection saying why not, or None.

        The single-result form of :meth:`add_pulse` (None: nothing released — the first
        sample, or, with a thermal model, a sample still held).
        """
        outs = self.add_pulse(t_ns, count)
        return outs[-1] if outs else None

    def _add_plain(self, t_ns: int, count: float) -> ImuAngularVelocity | Rejection | None:
        if not math.isfinite(count):
            return Rejection(t_ns, f'pulse count {count!r} at stamp {t_ns} ns is not finite.')
        last, self._last = self._last, (t_ns, count)
        if last is None:
            return None
        if t_ns <= last[0]:
            return Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, {last[0]} '
                                   'ns; it becomes the new reference.')
        return angular_velocity_from_pulses(last[0], last[1], t_ns, count, self._calibration)

    def _convert(self, outcomes: list[CompensatedPair | Rejection]
                 ) -> list[ImuAngularVelocity | Rejection]:
        out: list[ImuAngularVelocity | Rejection] = []
        for o in outcomes:
            if isinstance(o, Rejection):
                out.append(o)
                continue
            self.last_bias = (o.bias_rad_s, o.bias_std)
            cal = dataclasses.replace(self._calibration, bias_rad_s=o.bias_rad_s,
                                      bias_std=o.bias_std)
            out.append(angular_velocity_from_pulses(o.t0_ns, o.count0, o.t1_ns, o.count1, cal))
        return out
