"""Streaming triad body rates for imu_corrector's triad mode (METHODS §F.6)."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import GyroCalibError
from gyro_calib.estimate import Rejection
from gyro_calib.imu_body_rate import (
    Array,
    TriadRateModel,
    bias_with_channel_biases,
    body_rate,
    equal_variances,
)
from gyro_calib.imu_calibration import ImuCalibration, ImuSectionError
from gyro_calib.imu_conversion.rate import ImuAngularVelocity

if TYPE_CHECKING:
    from gyro_calib.thermal.compensate import CompensatedPair
    from gyro_calib.thermal.model import ThermalBiasModel


def channel_thermal_models(cal: ImuCalibration, model: TriadRateModel
                           ) -> dict[str, ThermalBiasModel]:
    """The ``imu.thermal.<channel>.thermal_model`` of each channel that has one.

    Raises:
        ImuSectionError: a channel's model is invalid, or was fitted with a scale factor
            other than that channel's K_i = 1/|r_i| by more than 100 ppm.
    """
    from gyro_calib.thermal.model import ThermalBiasModel

    out: dict[str, ThermalBiasModel] = {}
    for i, channel in enumerate(model.channels):
        data = cal.thermal.get(channel, {}).get('thermal_model')
        if data is None:
            continue
        try:
            m = ThermalBiasModel.from_dict(
                data, source=f'the imu.thermal.{channel}.thermal_model of the calibration')
        except GyroCalibError as exc:
            raise ImuSectionError(str(exc)) from None
        k = float(model.scale_factor_rad_per_pulse[i])
        if abs(m.scale_factor_rad_per_pulse / k - 1.0) > 1e-4:
            raise ImuSectionError(
                f'the thermal_model of channel {channel!r} was fitted with K = '
                f'{m.scale_factor_rad_per_pulse!r} rad/pulse, but the channel\'s K (1/|row| of '
                f'M⁻¹) is {k!r}: more than 100 ppm apart; refit the model with this K.')
        out[channel] = m
    return out


class TriadRateConverter:
    """Streaming triad body rates for imu_corrector's triad mode (METHODS §F.6).

    Feed ``/imu/pulses`` samples (:meth:`add_pulses`, names and positions as in the message)
    and, where channels have thermal models, their temperatures (:meth:`add_temperature`) in
    arrival order; each call returns the body rates (or :class:`Rejection` s) it releases,
    in stamp order. A sample whose names are not the calibration's three channels (in any
    order) is refused and not used. As :class:`PulseRateConverter`: a sample with a non-finite
    count is skipped (the previous one stays the reference); a stamp not after the previous
    one is refused and becomes the new reference. With thermal models, each such channel's
    pulses go to its own :class:`~gyro_calib.thermal.live.OrderedThermalCompensator` and a
    sample is released when every one of them has decided its bias (by stamps only), with
    b and C_b of §F.6 eq. (19); if any has none the sample gets a Rejection.
    """

    def __init__(self, model: TriadRateModel,
                 thermal: dict[str, ThermalBiasModel] | None = None, *,
                 thermal_max_age_s: float = 30.0, equal: bool = False) -> None:
        """Start with no reference sample.

        Args:
            model: M, its covariance, b, noise.
            thermal: channel → its thermal model (channels without one use the section's b).
            thermal_max_age_s: as :class:`PulseRateConverter`.
            equal: publish :func:`~gyro_calib.imu_body_rate.equal_variances` (§F.6 eq. (18)).
        """
        from gyro_calib.thermal.live import OrderedThermalCompensator

        self.model = model
        self.equal = equal
        self.thermal = dict(thermal or {})
        self._live = {c: OrderedThermalCompensator(m, max_wait_s=thermal_max_age_s)
                      for c, m in self.thermal.items()}
        self._queues: dict[str, deque[CompensatedPair | Rejection]] = {
            c: deque() for c in self._live}
        self._counts: dict[int, Array] = {}
        self._last: tuple[int, Array] | None = None

    @property
    def held(self) -> int:
        """Samples waiting for their thermal biases."""
        return max((c.held for c in self._live.values()), default=0)

    def _ordered(self, t_ns: int, names: Sequence[str], positions: Sequence[float]
                 ) -> Array | Rejection:
        channels = self.model.channels
        if sorted(names) != sorted(channels) or len(positions) != len(names):
            return Rejection(t_ns, f'channel names {list(names)} (with {len(positions)} '
                                   f'positions) do not match the calibration\'s channels '
                                   f'{list(channels)}: sample not used.')
        return np.array([float(positions[list(names).index(c)]) for c in channels])

    def add_pulses(self, t_ns: int, names: Sequence[str], positions: Sequence[float]
                   ) -> list[ImuAngularVelocity | Rejection]:
        """One /imu/pulses sample; the rates (or Rejections) it releases, in stamp order."""
        counts = self._ordered(t_ns, names, positions)
        if isinstance(counts, Rejection):
            return [counts]
        if self._live:
            if not np.all(np.isfinite(counts)):
                counts = np.full(3, math.nan)
            else:
                self._counts[t_ns] = counts
            for i, c in enumerate(self.model.channels):
                if c in self._live:
                    self._queues[c].extend(self._live[c].add_pulse(t_ns, float(counts[i])))
            return self._release()
        if not np.all(np.isfinite(counts)):
            return [Rejection(t_ns, f'pulse counts {list(counts)} at stamp {t_ns} ns are not '
                                    'all finite.')]
        last, self._last = self._last, (t_ns, counts)
        if last is None:
            return []
        if t_ns <= last[0]:
            return [Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, {last[0]} '
                                    'ns; it becomes the new reference.')]
        return [self._rate(last[0], last[1], t_ns, counts)]

    def add_temperature(self, channel: str, t_ns: int, celsius: float, frame_id: str
                        ) -> list[ImuAngularVelocity | Rejection]:
        """One temperature reading of a channel's sensor; the rates it releases."""
        live = self._live.get(channel)
        if live is None:
            return []
        self._queues[channel].extend(live.add_temperature(t_ns, celsius, frame_id))
        return self._release()

    def _rate(self, t0_ns: int, c0: Array, t1_ns: int, c1: Array,
              channel_bias: dict[int, tuple[float, float]] | None = None
              ) -> ImuAngularVelocity:
        bias, c_b = (None, None) if not channel_bias else bias_with_channel_biases(
            self.model, channel_bias)
        omega, cov = body_rate(c0, c1, (t1_ns - t0_ns) / 1e9, self.model, bias_rad_s=bias,
                               bias_covariance=c_b)
        if self.equal:
            cov = equal_variances(cov)
        return ImuAngularVelocity(t1_ns, (float(omega[0]), float(omega[1]), float(omega[2])),
                                  tuple(float(v) for v in cov.reshape(9)))

    def _release(self) -> list[ImuAngularVelocity | Rejection]:
        out: list[ImuAngularVelocity | Rejection] = []
        queues = list(self._queues.values())
        while all(queues):
            heads = [q.popleft() for q in queues]
            stamp = heads[0].stamp_ns if isinstance(heads[0], Rejection) else heads[0].t1_ns
            rejected = [h for h in heads if isinstance(h, Rejection)]
            if rejected:
                out.append(Rejection(stamp, rejected[0].reason))
                # the next pair starts at the latest finite sample up to here: older go
                ref = max((t for t in self._counts if t <= stamp), default=None)
                for t in [t for t in self._counts if ref is not None and t < ref]:
                    del self._counts[t]
                continue
            done = [h for h in heads if not isinstance(h, Rejection)]
            pairs = dict(zip(self._queues, done, strict=True))
            t0 = done[0].t0_ns
            c0, c1 = self._counts.get(t0), self._counts.get(stamp)
            for t in [t for t in self._counts if t < t0]:
                del self._counts[t]
            if c0 is None or c1 is None or any((h.t0_ns, h.t1_ns) != (t0, stamp) for h in done):
                out.append(Rejection(stamp, f'the channels\' thermal compensators disagree on '
                                            f'the sample pair ending at {stamp} ns.'))
                continue
            bias: dict[int, tuple[float, float]] = {}
            for i, c in enumerate(self.model.channels):
                p = pairs.get(c)
                if p is not None:
                    k = self.thermal[c].scale_factor_rad_per_pulse
                    bias[i] = (p.bias_rad_s / k, p.bias_std / k)
            out.append(self._rate(t0, c0, stamp, c1, bias))
        return out
