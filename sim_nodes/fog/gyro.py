"""The closed-loop digital FOG: table motion (and injections) in, cumulative output counts out.

Two models of the same loop (METHODS §B):

- ``model='equivalent'`` (default, long runs): the loop's averaged dynamics — static
  balance and first-order response where settled (:mod:`sim_nodes.fog.equivalent`),
  about 200× faster than real time at a 1 kHz output with the table simulator;
- ``model='loop'``: the loop simulated every transit time τ (:mod:`sim_nodes.fog.loop`)
  for step responses and short runs, about 2 µs of CPU per τ = 4.9 µs step (≈ 2× faster
  than real time).

A test checks that the two agree. Either way the output is the cumulative count at each
sample stamp (one count = 2π of digital feedback phase, K = D/(n·λ) counts per rad),
whole counts with the fraction carried (``quantise_output``), starting from a random
fraction. Chunks are processed in time order and every random draw is consumed in time
order, so the output does not depend on how a run is cut into chunks.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.fog.equivalent import EquivalentLoopModel
from sim_nodes.fog.front_end import FrontEnd
from sim_nodes.fog.loop import LoopPeriodModel
from sim_nodes.fog.sensing import InjectionSchedule, SenseAxis

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.fog.config import FogConfig

    FloatArray = npt.NDArray[np.float64]


class FogSimulator:
    """Streams the output counts of a closed-loop digital FOG on a (possibly turning) table."""

    def __init__(self, config: FogConfig, *, model: str = 'equivalent',
                 injection: InjectionSchedule | None = None) -> None:
        """Create the gyro.

        Args:
            config: optics, front end, loop, error sources, mount, site, seed.
            model: ``'equivalent'`` (long runs) or ``'loop'`` (every τ).
            injection: self-calibration injections (more may be added with :meth:`inject`).
        """
        if model not in ('equivalent', 'loop'):
            raise ValueError("model must be 'equivalent' or 'loop'")
        self.config = config
        self.model_name = model
        self.front_end = FrontEnd(config)
        self.sense = SenseAxis(config)
        self.injection = injection or InjectionSchedule()
        seeds = np.random.SeedSequence(config.seed).spawn(3)
        self._fraction = float(np.random.default_rng(seeds[0]).uniform())
        noise_rng = np.random.default_rng(seeds[1] if model == 'equivalent' else seeds[2])
        self._model: EquivalentLoopModel | LoopPeriodModel
        if model == 'equivalent':
            self._model = EquivalentLoopModel(config, self.front_end, noise_rng)
        else:
            self._model = LoopPeriodModel(config, self.front_end, noise_rng)
        self._last: tuple[int, float, float, float] | None = None  # t, ψ, ω, sensed rate
        self._phase = self._fraction

    @property
    def last_stamp_ns(self) -> int | None:
        """Stamp of the last sample produced (None before the first)."""
        return None if self._last is None else self._last[0]

    def inject(self, t_ns: int, rate_counts_s: float) -> None:
        """Schedule an injection (counts/s a linear loop would add) from ``t_ns`` on."""
        if self._last is not None and t_ns <= self._last[0]:
            raise ValueError('an injection must lie after the last simulated sample')
        self.injection.add(int(t_ns), float(rate_counts_s))

    def step(self, t_ns: npt.ArrayLike, table_angle_rad: npt.ArrayLike,
             table_rate_rad_s: npt.ArrayLike) -> FloatArray:
        """Advance to the stamps ``t_ns``; return the cumulative output count at each.

        Args:
            t_ns: sample stamps, int64 ns, strictly increasing (also across calls).
            table_angle_rad: true table angle at each stamp (unwrapped), rad.
            table_rate_rad_s: true table rate at each stamp, rad/s.

        Raises:
            ValueError: if the stamps do not increase strictly.
        """
        t = np.asarray(t_ns, dtype=np.int64)
        psi = np.asarray(table_angle_rad, dtype=np.float64)
        w = np.asarray(table_rate_rad_s, dtype=np.float64)
        if len(t) == 0:
            return np.zeros(0)
        rate = self.sense.rate_rad_s(psi, w)
        sag = self.config.sagnac_scale_rad_per_rad_s
        counts = np.empty(len(t))
        start = 0
        if self._last is None:
            word = float(self.front_end.injection_word(self.injection.value_at(int(t[0]))))
            if isinstance(self._model, EquivalentLoopModel):
                self._model.start(sag * float(rate[0]), word)
            else:
                self._model.start(int(t[0]), sag * float(rate[0]), word)
            counts[0] = self._output(np.zeros(1))[0]
            self._last = (int(t[0]), float(psi[0]), float(w[0]), float(rate[0]))
            start = 1
            if len(t) == 1:
                return counts
        t0, psi0, w0, rate0 = self._last
        tt, pp, ww, rr = t[start:], psi[start:], w[start:], rate[start:]
        if np.any(np.diff(np.concatenate(([t0], tt))) <= 0):
            raise ValueError('sample stamps must increase strictly')
        if isinstance(self._model, EquivalentLoopModel):
            dt = np.diff(np.concatenate(([t0], tt))) / 1e9
            angle = self.sense.angle_increments_rad(
                dt, np.concatenate(([psi0], pp[:-1])), pp,
                np.concatenate(([w0], ww[:-1])), ww)
            inc = self._model.advance(t0, tt, sag * rr, sag * rate0, sag * angle,
                                      self.injection)
        else:
            inc = self._model.advance(t0, tt, rate0, rr, self.injection)
        counts[start:] = self._output(inc)
        self._last = (int(tt[-1]), float(pp[-1]), float(ww[-1]), float(rr[-1]))
        return counts

    def _output(self, increments: FloatArray) -> FloatArray:
        phase = np.cumsum(np.concatenate(([self._phase], increments)))[1:]
        self._phase = float(phase[-1])
        return np.floor(phase) if self.config.quantise_output else phase
