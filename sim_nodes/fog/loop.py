"""The digital closed loop simulated at its own period τ (step responses, short runs).

Each transit time τ (METHODS §B; seed 001 eqs. 2–7):

1. the staircase accumulator R ← (R + S) mod 2^N; the DAC drives the Y-waveguide with
   g·δ·⌊R⌋ plus the square-wave bias ±π/4, so the two counter-propagating waves, which
   pass the modulator τ apart, differ by Φ_f = g·δ·(⌊R_k⌋ − ⌊R_{k−1}⌋) ± π/2 — the
   staircase step, a 2π·g jump at a reset, and the ±π/2 bias;
2. the detector sees I = A·[1 + cos(Φ_s + Φ_f)] plus white noise (its ARW);
3. the AC-coupled pre-amplifier (gain G, soft rail V_sat·tanh) and the ADC (clip at
   ±full scale, round to the LSB) give a code; demodulation multiplies by ∓1 (the bias
   sign), so a pair of half periods gives ΔI = −2A·sin(Φ_s + Φ_f) (eq. 7);
4. after each 2τ period the integrator sets S ← S − k_i·(mean error + j), where j is the
   self-calibration word the FPGA adds in the error path (0 = none), and S saturates at
   ± INTEGRATOR_LIMIT_TURNS·2^N;
5. every step adds −S/2^N to the output count (one count per 2π of digital feedback
   phase); an output sample taken inside a step counts that step pro rata.

Noise is drawn once per step, in step order, so chunking never changes a sample.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.fog.equivalent import INTEGRATOR_LIMIT_TURNS

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.fog.config import FogConfig
    from sim_nodes.fog.front_end import FrontEnd
    from sim_nodes.fog.sensing import InjectionSchedule

    FloatArray = npt.NDArray[np.float64]

class LoopPeriodModel:
    """State of the digital loop, stepped once per transit time τ."""

    def __init__(self, config: FogConfig, front_end: FrontEnd,
                 rng: np.random.Generator) -> None:
        """Create the loop; :meth:`start` balances it at the first sample."""
        self.config = config
        self.fe = front_end
        self.rng = rng
        self.tau_s = config.transit_time_s
        self.modulus = float(2**config.dac_bits)
        self.s_limit = INTEGRATOR_LIMIT_TURNS * self.modulus
        self.sag = config.sagnac_scale_rad_per_rad_s
        self._origin_ns = 0
        self._k = 0
        self._s = 0.0
        self._r = 0.0
        self._phi_mod_prev = 0.0
        self._err = 0.0
        self._count_done = 0.0
        self._count_reported = 0.0

    @property
    def steps_done(self) -> int:
        """Transit-time steps simulated so far."""
        return self._k

    def start(self, t0_ns: int, phi: float, word: float) -> None:
        """Balance the loop at Sagnac phase ``phi`` with word ``word`` at stamp ``t0_ns``."""
        a, _ = self.fe.balance(phi, word)
        a = float(a) if np.isfinite(a) else 0.0
        self._origin_ns = int(t0_ns)
        self._s = (a - phi) / (self.fe.g * self.fe.delta_rad)
        self._r = 0.0  # the accumulator before the first step; its word was 0
        self._phi_mod_prev = -0.25 * math.pi

    def _steps_until(self, t_rel_s: float) -> int:
        """Number of steps k·τ-completed by ``t_rel_s``: the smallest k with (k + 1)·τ > t."""
        k = max(int(t_rel_s // self.tau_s) - 1, 0)
        while (k + 1) * self.tau_s <= t_rel_s:
            k += 1
        return k

    def advance(self, t0_ns: int, t_ns: npt.NDArray[np.int64], rate_prev_rad_s: float,
                rate_rad_s: FloatArray, schedule: InjectionSchedule) -> FloatArray:
        """Count increments over the intervals ending at ``t_ns`` (the first starts at t0).

        The sensed rate is interpolated linearly between stamps to each step's midpoint.
        """
        cfg, fe = self.config, self.fe
        tau, mod, s_lim = self.tau_s, self.modulus, self.s_limit
        g_delta = fe.g * fe.delta_rad
        amp, gain, rail, fs = fe.amplitude_v, fe.gain, fe.rail_v, fe.full_scale_v
        lsb = fe.lsb_v
        half_codes = 2 ** (cfg.adc_bits - 1) if cfg.adc_bits else 0
        sigma = cfg.detector_noise_v if cfg.angle_random_walk_deg_sqrt_h else 0.0
        k_i = fe.k_i
        quarter = 0.25 * math.pi
        sag = self.sag
        origin = self._origin_ns
        t_rel = ((np.asarray(t_ns, dtype=np.int64) - origin) / 1e9).tolist()
        rates = np.asarray(rate_rad_s, dtype=np.float64).tolist()
        t_prev, w_prev = (t0_ns - origin) / 1e9, float(rate_prev_rad_s)
        k, s, r, phi_prev, err = self._k, self._s, self._r, self._phi_mod_prev, self._err
        count = self._count_done
        word = float(fe.injection_word(schedule.value_at(origin + int(round(k * tau * 1e9)))))
        pending = schedule.changes_in(origin + int(round(k * tau * 1e9)) - 1,
                                      int(t_ns[-1]) + 1) if len(t_ns) else []
        next_change = (pending[0][0] - origin) / 1e9 if pending else math.inf
        # steps completed by the last stamp: the largest k with k·τ ≤ t_end (as the loop tests)
        k_last = self._steps_until(t_rel[-1]) if t_rel else k
        n_steps = max(k_last - k, 0)
        noise = (sigma * self.rng.standard_normal(n_steps)).tolist() if sigma else []
        n_used = 0
        m = 1.0 if k % 2 == 0 else -1.0
        out = np.empty(len(t_rel))
        for i, (t_end, w_end) in enumerate(zip(t_rel, rates)):
            n_here = self._steps_until(t_end) - k
            if n_here > 0:
                slope = sag * (w_end - w_prev) / (t_end - t_prev)
                phi_s = sag * w_prev + slope * ((k + 0.5) * tau - t_prev)
                dphi_s = slope * tau
                for _ in range(n_here):
                    r = (r + s) % mod
                    phi_mod = g_delta * math.floor(r) + m * quarter
                    intensity = amp * math.cos(phi_s + phi_mod - phi_prev)
                    phi_prev = phi_mod
                    phi_s += dphi_s
                    if sigma:
                        intensity += noise[n_used]
                        n_used += 1
                    v = gain * intensity
                    if rail:
                        v = rail * math.tanh(v / rail)
                    if fs:
                        v = fs if v > fs else (-fs if v < -fs else v)
                    code = v / lsb
                    if half_codes:
                        code = math.floor(code + 0.5)
                        code = (half_codes - 1 if code >= half_codes
                                else (-half_codes if code < -half_codes else code))
                    count -= s / mod
                    k += 1
                    if m > 0.0:
                        err = -code
                        m = -1.0
                        continue
                    err += code
                    m = 1.0
                    if k * tau >= next_change:
                        while k * tau >= next_change:
                            word = float(fe.injection_word(pending.pop(0)[1]))
                            next_change = ((pending[0][0] - origin) / 1e9 if pending
                                           else math.inf)
                    s -= k_i * (0.5 * err + word)
                    s = s_lim if s > s_lim else (-s_lim if s < -s_lim else s)
            frac = (t_end - k * tau) / tau
            reported = count - frac * s / mod
            out[i] = reported - self._count_reported
            self._count_reported = reported
            t_prev, w_prev = t_end, w_end
        err = err if m < 0.0 else 0.0
        self._k, self._s, self._r, self._phi_mod_prev, self._err = k, s, r, phi_prev, err
        self._count_done = count
        return out
