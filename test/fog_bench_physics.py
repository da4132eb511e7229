"""A FOG bench written for the tests from the physics (shares nothing with sim_nodes).

The gyro (IEEE Std 952-1997 FOG model, §A.2 scale-factor and bias terms): for an input rate
ω_in about the sense axis the closed loop outputs counts at the rate

    R(ω_in) = K·(ω_in + k₂ω_in² + k₃ω_in³ + (a/2)·|ω_in| + b)        (counts/s)

(K scale factor in counts/rad, k₂, k₃ the quadratic and cubic terms, a the asymmetry —
K₊ = K(1 + a/2), K₋ = K(1 − a/2), so 2(K₊ − K₋)/(K₊ + K₋) = a — and b the bias), with white
rate noise (angle random walk N, rad/√s) added and the cumulative count read out as an
integer. ω_in is the table rate plus the Earth rate along the sense axis: Ω_e·sin φ·cos β
(β the sense-axis tilt from the table axis) and the horizontal part Ω_e·cos φ·sin β turning
with the table.

The turntable holds each rate of the list for its hold time, with constant-acceleration
transitions; joint_states carry the encoder angle (2²³ counts/rev) and the commanded rate;
a zero-index event marks each pass of the reference mark.

Self-calibration (closed-loop phase injection on the stopped table): a digital rate J
(counts/s a linear loop would add) injected into the forward path is balanced by the loop
where the demodulated error A·sin(Δφ) cancels it, so the output moves by

    ΔR(J) = (1 + g)·J_s·arcsin(J / J_s)

(g the injection gain error, J_s = the largest injection the front end can balance); after
each step the output approaches the new level as 1 − exp(−t/τ). The equivalence mapping
ω = J/K_map (K_map the local slope of R at the mapping rates) turns J into a rate; the
self-calibrated scale factor over a set of plateaus is K_map × the slope of R against J.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

EARTH_RATE_RAD_S = 7.2921150e-5
"""Earth rotation rate, rad/s."""

ENCODER_COUNTS = 2**23
"""Table encoder counts per revolution."""

MAPPING_RATES_DEG_S = (20.0, 20.01, 20.1, 21.0)
"""The calibrator's default equivalence-mapping rates, °/s."""


@dataclass(frozen=True)
class FogBench:
    """One bench: the gyro, the turntable programme and the injection ladder."""

    k_counts_per_rad: float
    bias_rad_s: float
    asymmetry: float
    k2_s_per_rad: float
    k3_s2_per_rad2: float
    arw_rad_sqrt_s: float
    latitude_deg: float
    tilt_deg: float
    output_hz: float
    table_hz: float
    rates_deg_s: tuple[float, ...]
    holds_s: tuple[float, ...]
    accel_deg_s2: float
    mark_deg: float
    ladder_counts_s: tuple[float, ...] = ()
    plateau_s: float = 4.0
    settle_tau_s: float = 0.1
    injection_gain_error: float = 0.0
    injection_limit_counts_s: float = math.inf
    seed: int = 0
    lead_s: float = 2.0

    def input_rate(self, omega_table: npt.NDArray[np.float64],
                   psi: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """ω_in: table rate plus the Earth rate along the (tilted) sense axis, rad/s."""
        phi, beta = math.radians(self.latitude_deg), math.radians(self.tilt_deg)
        vertical = EARTH_RATE_RAD_S * math.sin(phi) * math.cos(beta)
        horizontal = EARTH_RATE_RAD_S * math.cos(phi) * math.sin(beta)
        return omega_table + vertical + horizontal * np.cos(psi)

    def output_rate(self, omega_in: npt.NDArray[np.float64] | float) -> npt.NDArray[np.float64]:
        """R(ω_in), counts/s, noise-free (the IEEE Std 952 model above)."""
        w = np.asarray(omega_in, dtype=np.float64)
        return self.k_counts_per_rad * (w + self.k2_s_per_rad * w**2 + self.k3_s2_per_rad2 * w**3
                                        + 0.5 * self.asymmetry * np.abs(w) + self.bias_rad_s)

    def injection_response(self, j: npt.NDArray[np.float64] | float) -> npt.NDArray[np.float64]:
        """ΔR(J) of the balanced loop, counts/s."""
        js = self.injection_limit_counts_s
        j = np.asarray(j, dtype=np.float64)
        if math.isinf(js):
            return (1.0 + self.injection_gain_error) * j
        return (1.0 + self.injection_gain_error) * js * np.arcsin(np.clip(j / js, -1.0, 1.0))

    @property
    def vertical_earth_rad_s(self) -> float:
        """The Earth rate along the table axis that the calibrator removes with the latitude."""
        return EARTH_RATE_RAD_S * math.sin(math.radians(self.latitude_deg))


@dataclass
class Profile:
    """The table programme as pieces (t0, t1, ω0, α) with ψ(t) = ψ0 + ω0·τ + α·τ²/2."""

    t0: list[float] = field(default_factory=list)
    omega0: list[float] = field(default_factory=list)
    alpha: list[float] = field(default_factory=list)
    psi0: list[float] = field(default_factory=list)
    end_s: float = 0.0
    holds: list[tuple[float, float, float]] = field(default_factory=list)
    """(start s, end s, rate rad/s) of each constant-rate hold."""

    def add(self, duration: float, omega0: float, alpha: float) -> None:
        psi = 0.0
        if self.t0:
            tau = self.end_s - self.t0[-1]
            psi = self.psi0[-1] + self.omega0[-1] * tau + 0.5 * self.alpha[-1] * tau**2
        self.t0.append(self.end_s)
        self.omega0.append(omega0)
        self.alpha.append(alpha)
        self.psi0.append(psi)
        if alpha == 0.0:
            self.holds.append((self.end_s, self.end_s + duration, omega0))
        self.end_s += duration

    def state(self, t: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64],
                                                           npt.NDArray[np.float64]]:
        """(ψ, ω) at times t (s from the start)."""
        k = np.clip(np.searchsorted(np.array(self.t0), t, side='right') - 1, 0, len(self.t0) - 1)
        tau = t - np.array(self.t0)[k]
        w0, a, p0 = np.array(self.omega0)[k], np.array(self.alpha)[k], np.array(self.psi0)[k]
        return p0 + w0 * tau + 0.5 * a * tau**2, w0 + a * tau


@dataclass
class Recording:
    """What the bench published, as the calibrator's batch function takes it."""

    output_t_ns: npt.NDArray[np.int64]
    output_counts: npt.NDArray[np.float64]
    table_t_ns: npt.NDArray[np.int64]
    table_angle_rad: npt.NDArray[np.float64]
    table_rate_rad_s: npt.NDArray[np.float64]
    zero_index_ns: npt.NDArray[np.int64]
    injection_t_ns: npt.NDArray[np.int64]
    injection_counts_s: npt.NDArray[np.float64]
    holds: list[tuple[float, float, float]]
    """(start ns, end ns, rate rad/s) of each turntable hold."""
    plateaus: list[tuple[int, int, float]]
    """(start ns, end ns, J counts/s) of each injected plateau."""


START_NS = 1_000_000_000_000


def programme(bench: FogBench) -> Profile:
    """Rest, the rates, then rest for the ladder.

    Rest, then each rate for its hold (constant-acceleration transitions), then rest for
    the ladder.
    """
    prof = Profile()
    prof.add(bench.lead_s, 0.0, 0.0)
    alpha = math.radians(bench.accel_deg_s2)
    omega = 0.0
    for rate_deg_s, hold in zip(bench.rates_deg_s, bench.holds_s):
        target = math.radians(rate_deg_s)
        if target != omega:
            prof.add(abs(target - omega) / alpha, omega, math.copysign(alpha, target - omega))
        prof.add(hold, target, 0.0)
        omega = target
    if omega != 0.0:
        prof.add(abs(omega) / alpha, omega, -math.copysign(alpha, omega))
    ladder_s = len(bench.ladder_counts_s) * bench.plateau_s
    prof.add(bench.lead_s + ladder_s + bench.lead_s, 0.0, 0.0)
    return prof


def record(bench: FogBench) -> Recording:
    """Simulate the bench: output counts, table states, zero-index events, injections."""
    rng = np.random.default_rng(bench.seed)
    prof = programme(bench)
    duration = prof.end_s
    # the ladder on the stopped table, after the programme's moves
    ladder_start = duration - bench.lead_s - len(bench.ladder_counts_s) * bench.plateau_s
    plateaus_s = [(ladder_start + i * bench.plateau_s, ladder_start + (i + 1) * bench.plateau_s,
                   j) for i, j in enumerate(bench.ladder_counts_s)]

    # output: counts integrated sample by sample (rate at the interval's midpoint)
    dt = 1.0 / bench.output_hz
    t_out = np.arange(0.0, duration, dt)
    mid = t_out[:-1] + 0.5 * dt
    psi_mid, omega_mid = prof.state(mid)
    rate = bench.output_rate(bench.input_rate(omega_mid, psi_mid))
    if plateaus_s:
        rate += _injected(bench, plateaus_s, mid)
    increments = rate * dt + bench.k_counts_per_rad * bench.arw_rad_sqrt_s * math.sqrt(dt) \
        * rng.standard_normal(len(mid))
    phase = rng.uniform(0.0, 1.0)
    counts = np.floor(phase + np.concatenate(([0.0], np.cumsum(increments))))

    # table: encoder angle (quantised) and rate
    t_tab = np.arange(0.0, duration, 1.0 / bench.table_hz)
    psi_tab, omega_tab = prof.state(t_tab)
    lsb = 2.0 * math.pi / ENCODER_COUNTS
    angle = np.round(psi_tab / lsb) * lsb

    # zero index: each pass of the mark (crossing found between dense samples, interpolated)
    t_fine = np.arange(0.0, duration, 1e-3)
    psi_fine, _ = prof.state(t_fine)
    turns = np.floor((psi_fine - math.radians(bench.mark_deg)) / (2.0 * math.pi))
    cross = np.nonzero(np.diff(turns) != 0)[0]
    index_s = []
    for i in cross:
        level = (max(turns[i], turns[i + 1])) * 2.0 * math.pi + math.radians(bench.mark_deg)
        f = (level - psi_fine[i]) / (psi_fine[i + 1] - psi_fine[i])
        index_s.append(t_fine[i] + f * 1e-3)

    def ns(t: npt.NDArray[np.float64] | list[float]) -> npt.NDArray[np.int64]:
        return START_NS + np.round(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64)

    inj_t = ns([p[0] for p in plateaus_s])
    inj_v = np.array([p[2] for p in plateaus_s], dtype=np.float64)
    if plateaus_s:  # the last plateau ends with a zero injection message
        inj_t = np.append(inj_t, ns([plateaus_s[-1][1]]))
        inj_v = np.append(inj_v, 0.0)
    return Recording(
        output_t_ns=ns(t_out), output_counts=counts.astype(np.float64),
        table_t_ns=ns(t_tab), table_angle_rad=angle, table_rate_rad_s=omega_tab,
        zero_index_ns=ns(index_s), injection_t_ns=inj_t, injection_counts_s=inj_v,
        holds=[(int(ns([a])[0]), int(ns([b])[0]), w) for a, b, w in prof.holds if w != 0.0],
        plateaus=[(int(ns([a])[0]), int(ns([b])[0]), j) for a, b, j in plateaus_s])


def _injected(bench: FogBench, plateaus_s: list[tuple[float, float, float]],
              t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Output-rate change from the injections at times t, counts/s.

    Output-rate change from the injections at times t: a first-order approach to each new
    balanced level, counts/s.
    """
    out = np.zeros_like(t)
    level = 0.0
    for start, end, j in plateaus_s:
        target = float(bench.injection_response(j))
        sel = (t >= start) & (t < end)
        out[sel] = target + (level - target) * np.exp(-(t[sel] - start) / bench.settle_tau_s)
        level = target
    after = t >= plateaus_s[-1][1]
    out[after] = level * np.exp(-(t[after] - plateaus_s[-1][1]) / bench.settle_tau_s)
    return out
