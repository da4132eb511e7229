"""The long-run equivalent of the digital loop: its averaged dynamics, linearised where settled.

Stated model (METHODS §B; checked against :mod:`sim_nodes.fog.loop` by a test). Averaged
over its 2τ periods the loop has one state, the optical phase error a, and

    da/dt = dΦ_s/dt − c·(G(a) + j),   c = k_i·g·δ/(2τ),
    y = (Φ_s − a)/(2πτ·g)  (output counts/s),

with G the mean demodulated error including the 2π-reset glitches
(:meth:`FrontEnd.mean_error`). Its fixed point is the loop's static balance
(:meth:`FrontEnd.balance`).

- Settled (|a − balance| < ``SETTLED_RAD``): the loop is linear about its balance, so y
  follows the balanced output u = (Φ_s − a_bal)/(2πτg) with the first-order time constant
  T = −2τ/ln(1 − k_i·G'·g·δ); for u linear within a sample interval this is integrated
  exactly and the counts are ∫u dt − T·(y₁ − y₀). Vectorised: thousands of times
  faster than real time.
- After an injection change, and out of lock (|j| beyond what the front end can balance,
  where a slips through the fringes and the output ramps until the staircase word
  saturates), the averaged equation itself is integrated (RK4, steps of a fraction of the
  loop time constant) until the loop has settled again.
- Noise: the detector noise, referred to the input at a phase error a, is an angle random
  walk N/|cos a|: one normal draw per output interval, in time order.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.fog.config import FogConfig
    from sim_nodes.fog.front_end import FrontEnd
    from sim_nodes.fog.sensing import InjectionSchedule

    FloatArray = npt.NDArray[np.float64]

INTEGRATOR_LIMIT_TURNS = 2.0
"""The staircase-height word saturates at ± this many 2π per step."""
SETTLED_RAD = 1e-4
"""A phase error this close to the balance counts as settled (linear dynamics)."""


class EquivalentLoopModel:
    """Output counts of the closed loop from the Sagnac phase, sample interval by interval."""

    def __init__(self, config: FogConfig, front_end: FrontEnd,
                 rng: np.random.Generator) -> None:
        """Create the model; :meth:`start` sets its state at the first sample."""
        self.config = config
        self.fe = front_end
        self.rng = rng
        self.c_out = 1.0 / (2.0 * math.pi * front_end.tau_s * front_end.g)
        self.k_counts = config.scale_factor_counts_per_rad
        self.arw = config.angle_random_walk_rad_sqrt_s
        self.y_limit = INTEGRATOR_LIMIT_TURNS / front_end.tau_s
        self.c_phase = front_end.phase_rate_per_word
        t_null = float(front_end.loop_time_constant_s(front_end.error_word_slope(0.0)))
        self.ode_step_s = 0.2 * t_null
        self._y = 0.0
        self._transient = False
        self._cache: dict[float, tuple[float, float]] = {}

    def _word_constants(self, word: float, phi_ref: float) -> tuple[float, float]:
        """(time constant s or NaN out of lock, noise factor 1/|cos a|) for a word."""
        if word not in self._cache:
            a, slope = self.fe.balance(phi_ref, word)
            if np.isfinite(a):
                self._cache[word] = (float(self.fe.loop_time_constant_s(slope)),
                                     1.0 / abs(math.cos(float(a))))
            else:
                self._cache[word] = (math.nan, 1.0)
        return self._cache[word]

    def _u(self, phi: FloatArray, word: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Balanced output rate (counts/s) and phase error a at Sagnac phase Φ_s and word j."""
        a, _ = self.fe.balance(phi, word)
        return (phi - a) * self.c_out, a

    def start(self, phi: float, word: float) -> None:
        """Start in balance at Sagnac phase ``phi`` with injected word ``word``."""
        u, _ = self._u(np.array([phi]), np.array([word]))
        self._y = float(u[0]) if np.isfinite(u[0]) else 0.0
        self._transient = not np.isfinite(u[0])

    def advance(self, t0_ns: int, t_ns: npt.NDArray[np.int64], phi: FloatArray,
                phi_prev: float, sagnac_integral: FloatArray,
                schedule: InjectionSchedule) -> FloatArray:
        """Count increments over the intervals ending at ``t_ns`` (the first starts at t0).

        Args:
            t0_ns: stamp of the sample before ``t_ns[0]``.
            t_ns: sample stamps, int64 ns, increasing.
            phi: Sagnac phase (rad) at each stamp (from the sensed rate).
            phi_prev: Sagnac phase at ``t0_ns``.
            sagnac_integral: ∫Φ_s dt over each interval, rad·s (from the sensed angle).
            schedule: the injection in force (counts/s), converted to error words here.
        """
        n = len(t_ns)
        t_all = np.concatenate(([t0_ns], t_ns))
        dt = np.diff(t_all) / 1e9
        phi_start = np.concatenate(([phi_prev], phi[:-1]))
        words = self.fe.injection_word(schedule.values_at(t_all[:-1]))
        u1, a1 = self._u(phi, words)
        # the balance at an interval's start is the previous interval's end unless the word
        # changed there (and for the first interval)
        u0, a0 = np.empty(n), np.empty(n)
        u0[1:], a0[1:] = u1[:-1], a1[:-1]
        redo = np.concatenate(([True], words[1:] != words[:-1]))
        if redo.any():
            u0[redo], a0[redo] = self._u(phi_start[redo], words[redo])
        # intervals with an injection change strictly inside, or out of lock: nonlinear path
        special = ~(np.isfinite(u0) & np.isfinite(u1))
        changes = schedule.changes_in(int(t_all[0]), int(t_all[-1]))
        if changes:
            inside = np.searchsorted(t_ns, np.array([c[0] for c in changes]), side='right')
            special[inside] = True
        unique, inverse = np.unique(words, return_inverse=True)
        consts = np.array([self._word_constants(float(w), float(phi_start[0]))
                           for w in unique]).reshape(-1, 2)
        t_loop = consts[inverse, 0]
        noise_factor = consts[inverse, 1]
        with np.errstate(invalid='ignore'):
            decay = np.exp(-dt / t_loop)
            du = (u1 - u0) / dt
            drive = u1 - t_loop * du - decay * (u0 - t_loop * du)
            integral = self.c_out * (sagnac_integral - 0.5 * (a0 + a1) * dt)
        noise = self.rng.standard_normal(n) if self.arw else np.zeros(n)
        noise_term = self.arw * self.k_counts * noise_factor * np.sqrt(dt) * noise
        y = self._y
        if not special.any() and not self._transient:
            ys = np.empty(n)
            for k, (d, v) in enumerate(zip(decay.tolist(), drive.tolist())):
                y = d * y + v
                ys[k] = y
            y_before = np.concatenate(([self._y], ys[:-1]))
            self._y = y
            return integral - t_loop * (ys - y_before) + noise_term
        out = np.empty(n)
        t_list, sp = t_all.tolist(), special.tolist()
        for k in range(n):
            if sp[k] or self._transient:
                y, out[k] = self._nonlinear_interval(
                    t_list[k], t_list[k + 1], float(phi_start[k]), float(phi[k]),
                    float(sagnac_integral[k]), float(words[k]),
                    schedule.changes_in(t_list[k], t_list[k + 1]), y)
                out[k] += float(noise_term[k]) if math.isfinite(noise_term[k]) else (
                    self.arw * self.k_counts * math.sqrt(float(dt[k])) * float(noise[k]))
                continue
            y_new = float(decay[k]) * y + float(drive[k])
            out[k] = (float(integral[k]) - float(t_loop[k]) * (y_new - y)
                      + float(noise_term[k]))
            y = y_new
        self._y = y
        return out

    def _nonlinear_interval(self, t0: int, t1: int, phi0: float, phi1: float, s_int: float,
                            word0: float, changes: list[tuple[int, float]],
                            y: float) -> tuple[float, float]:
        """Integrate the averaged loop over one interval (RK4); return (y, count increment)."""
        edges = [t0] + [c[0] for c in changes] + [t1]
        words = [word0] + [float(self.fe.injection_word(c[1])) for c in changes]
        total = (t1 - t0) / 1e9
        g2pt = 1.0 / self.c_out
        dphi_dt = (phi1 - phi0) / total
        # the Sagnac phase's exact integral minus its linear interpolation's, spread evenly
        extra = (s_int - 0.5 * (phi0 + phi1) * total) * self.c_out / total
        a = phi0 - y * g2pt
        counts = 0.0
        c, fe = self.c_phase, self.fe
        limit = self.y_limit * g2pt  # the staircase word's limit as a phase
        for ta, tb, word in zip(edges[:-1], edges[1:], words):
            h_all = (tb - ta) / 1e9
            if h_all <= 0:
                continue
            steps = max(1, math.ceil(h_all / self.ode_step_s))
            h = h_all / steps
            t = (ta - t0) / 1e9
            for step in range(steps):
                p0 = phi0 + dphi_dt * t
                p_mid, p1 = p0 + 0.5 * h * dphi_dt, p0 + h * dphi_dt
                k1 = dphi_dt - c * fe.mean_error(a, p0, word)
                if (a <= p0 - limit + 1e-12 and k1 <= dphi_dt) or (
                        a >= p0 + limit - 1e-12 and k1 >= dphi_dt):
                    # the staircase word is saturated and the loop still pushes: it stays
                    rest = (steps - step) * h
                    y_sat = math.copysign(self.y_limit, p0 - a)
                    counts += y_sat * rest
                    a = (phi0 + dphi_dt * (t + rest)) - y_sat * g2pt
                    t += rest
                    break
                k2 = dphi_dt - c * fe.mean_error(a + 0.5 * h * k1, p_mid, word)
                k3 = dphi_dt - c * fe.mean_error(a + 0.5 * h * k2, p_mid, word)
                k4 = dphi_dt - c * fe.mean_error(a + h * k3, p1, word)
                a_new = a + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                a_new = min(max(a_new, p1 - limit), p1 + limit)  # the staircase word saturates
                # ∫y dt over the step by Simpson's rule on a (Φ_s is linear in the step)
                a_mid = 0.5 * (a + a_new) + h / 8.0 * (k1 - k4)
                counts += ((0.5 * (p0 + p1)) * h
                           - h / 6.0 * (a + 4.0 * a_mid + a_new)) * self.c_out
                a = a_new
                t += h
        counts += extra * total
        y_end = (phi1 - a) * self.c_out
        a_bal, _ = fe.balance(phi1, words[-1])
        self._transient = not (np.isfinite(a_bal) and abs(a - float(a_bal)) < SETTLED_RAD)
        return y_end, counts
