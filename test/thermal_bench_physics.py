"""Chamber benches for the thermal property test.

Chamber benches for the thermal property test, written from the physics for the tests
(sharing nothing with sim_nodes): a chamber programme, a lumped thermal network with
self-heating, lagging temperature sensors read on their own clocks, and a gyro whose bias
follows a hidden law of H, Ḣ and the gradients (METHODS §D.2–3, §D.5).

Physics (all first-order lags, integrated on a 1 s grid with the exact solution for an input
linear over the step):

- chamber air: piecewise linear (soaks and ramps), starting hot or cold;
- shell: lags the air (τ_s) and sits ΔT_s above it; cavity arms a, b lag the shell (τ_a, τ_b)
  with their own rises ΔT_a, ΔT_b — the gyro starts either at the chamber temperature
  (switched on cold) or settled;
- H = (T_a + T_b)/2, Ḣ from the network's own equations, ΔT_ab = T_a − T_b,
  ΔT_cs = H − T_shell;
- hidden law, °/h: b0 + c1·x + c2·x² + r1·Ḣ[°C/min] + g_ab·ΔT_ab + g_cs·ΔT_cs, x = (H − 10)/30;
  plus a Gauss–Markov bias instability the model cannot know;
- pulses: Earth rate along a vertical axis + bias, angle random walk, whole pulses of K;
- each sensor: a first-order lag of its part (τ_sen), read every r_j s from its own first
  reading o_j with a clock rate error, white noise, rounded to its LSB; drop-outs (no message)
  and a stuck sensor (a frozen reading) as faults.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

DEG_H = math.pi / 180 / 3600
"""1 °/h in rad/s."""
K_RAD = 2.0 * math.pi / 180 / 3600
"""2″/pulse."""
LATITUDE_DEG = 40.0
EARTH_RAD_S = 15.041 * DEG_H * math.sin(math.radians(LATITUDE_DEG))
SENSORS = ('cavity_a', 'cavity_b', 'shell')
T0_NS = 1_800_000_000 * 10**9


@dataclass(frozen=True)
class Law:
    """The hidden bias law, °/h (see the module docstring)."""

    b0: float
    c1: float
    c2: float
    r1: float
    g_ab: float
    g_cs: float

    def bias_deg_h(self, h: np.ndarray, hdot_c_s: np.ndarray, dtab: np.ndarray,
                   dtcs: np.ndarray) -> np.ndarray:
        x = (h - 10.0) / 30.0
        return (self.b0 + self.c1 * x + self.c2 * x * x + self.r1 * hdot_c_s * 60.0
                + self.g_ab * dtab + self.g_cs * dtcs)

    def terms(self, shell: bool) -> str:
        """The candidate term list holding the law."""
        return 'H,H^2,Hdot,dTab' + (',dTcs' if shell else '')


@dataclass(frozen=True)
class Sensor:
    """How one temperature sensor is read."""

    interval_s: float
    offset_s: float
    drift_ppm: float
    lsb_c: float
    noise_c: float
    dropout_s: tuple[float, float] | None = None
    stuck_from_s: float | None = None


@dataclass(frozen=True)
class Bench:
    """One chamber run of one gyro (every number the generator needs)."""

    knots_t_s: tuple[float, ...]
    knots_c: tuple[float, ...]
    law: Law
    warm_start: bool
    tau_shell_s: float
    tau_a_s: float
    tau_b_s: float
    rise_shell_c: float
    rise_a_c: float
    rise_b_c: float
    tau_sensor_s: float
    pulse_rate_hz: float
    sensors: dict[str, Sensor] = field(default_factory=dict)
    arw_deg_sqrt_h: float = 0.003
    instability_deg_h: float = 0.003
    seed: int = 0

    @property
    def duration_s(self) -> float:
        return float(self.knots_t_s[-1])

    @property
    def faults(self) -> bool:
        """A drop-out or a stuck sensor."""
        return any(s.dropout_s is not None or s.stuck_from_s is not None
                   for s in self.sensors.values())


def programme(rng: np.random.Generator, kind: str, hot: bool) -> tuple[list[float],
                                                                      list[float]]:
    """Chamber knots (s, °C) of a programme.

    Chamber knots (s, °C): 'soaks' (set points joined by ramps), 'ramps' (back and forth at
    changing rates, never dwelling) or 'mix'; starting at the hot or the cold end.
    """
    low = float(rng.uniform(-35, -5))
    high = float(rng.uniform(max(low + 30, 15), 45))
    t, c = [0.0], [high if hot else low]
    if kind == 'soaks':
        n = int(rng.integers(4, 6))
        points = np.linspace(low, high, n)
        points = points[::-1] if hot else points
        for p in points:
            if p != c[-1]:
                t.append(t[-1] + abs(p - c[-1]) / rng.uniform(0.5, 1.5) * 60)
                c.append(float(p))
            t.append(t[-1] + rng.uniform(1200, 2400))
            c.append(float(p))
        return t, c
    total = rng.uniform(2.0, 3.5) * 3600
    while t[-1] < total:
        target = low if c[-1] >= high - 1e-9 else high
        if kind == 'mix' and rng.uniform() < 0.5:  # stop part-way and soak
            target = float(rng.uniform(low, high))
        t.append(t[-1] + abs(target - c[-1]) / rng.uniform(0.3, 1.0) * 60 + 1.0)
        c.append(float(target))
        if kind == 'mix' and rng.uniform() < 0.5:
            t.append(t[-1] + rng.uniform(600, 1800))
            c.append(c[-1])
    return t, c


def _lag(u: np.ndarray, tau_s: float, x0: float, dt: float = 1.0) -> np.ndarray:
    """First-order lag of a sampled input, exact for an input linear over each step."""
    if tau_s <= 0:
        return u.copy()
    a = math.exp(-dt / tau_s)
    s = np.diff(u) / dt
    x = np.empty_like(u)
    x[0] = x0
    for i in range(len(s)):
        x[i + 1] = u[i + 1] - s[i] * tau_s + (x[i] - u[i] + s[i] * tau_s) * a
    return x


@dataclass(frozen=True)
class Truth:
    """True temperatures and bias on the 1 s grid."""

    t_s: np.ndarray
    shell: np.ndarray
    a: np.ndarray
    b: np.ndarray
    sensed: dict[str, np.ndarray]
    law_rad_s: np.ndarray
    instability_rad_s: np.ndarray

    @property
    def h(self) -> np.ndarray:
        return 0.5 * (self.a + self.b)


def truth(bench: Bench) -> tuple[Truth, dict[str, np.ndarray]]:
    """The network on the 1 s grid; also the variables (H, Hdot, dTab, dTcs)."""
    t = np.arange(0.0, bench.duration_s + 2.0, 1.0)
    air = np.interp(t, bench.knots_t_s, bench.knots_c)
    start = bench.knots_c[0]
    s0 = start + (bench.rise_shell_c if bench.warm_start else 0.0)
    shell = _lag(air + bench.rise_shell_c, bench.tau_shell_s, s0)
    a = _lag(shell + bench.rise_a_c, bench.tau_a_s,
             s0 + (bench.rise_a_c if bench.warm_start else 0.0))
    b = _lag(shell + bench.rise_b_c, bench.tau_b_s,
             s0 + (bench.rise_b_c if bench.warm_start else 0.0))
    da = (shell + bench.rise_a_c - a) / bench.tau_a_s
    db = (shell + bench.rise_b_c - b) / bench.tau_b_s
    h = 0.5 * (a + b)
    variables = {'H': h, 'Hdot': 0.5 * (da + db), 'dTab': a - b, 'dTcs': h - shell}
    law = bench.law.bias_deg_h(h, variables['Hdot'], variables['dTab'],
                               variables['dTcs']) * DEG_H
    rng = np.random.default_rng([bench.seed, 1])
    rho = math.exp(-1.0 / 300.0)
    sigma = bench.instability_deg_h * DEG_H
    drive = sigma * math.sqrt(1 - rho * rho) * rng.standard_normal(len(t))
    gm = np.empty(len(t))
    gm[0] = sigma * rng.standard_normal()
    for i in range(1, len(t)):
        gm[i] = rho * gm[i - 1] + drive[i]
    sensed = {name: _lag(part, bench.tau_sensor_s, float(part[0]))
              for name, part in zip(SENSORS, (a, b, shell))}
    return Truth(t, shell, a, b, sensed, law, gm), variables


def pulse_chunks(bench: Bench, tr: Truth, chunk_s: float = 600.0
                 ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """/gyro/pulses in chunks of ``chunk_s``.

    /gyro/pulses in chunks of ``chunk_s``: stamps (ns) at the pulse rate and cumulative
    whole pulses (the random draws continue from chunk to chunk, so 10 kHz for hours stays
    in bounded memory).
    """
    rng = np.random.default_rng([bench.seed, 2])
    period_ns = int(round(1e9 / bench.pulse_rate_hz))
    n_total = int(bench.duration_s * 1e9) // period_ns + 1
    per_chunk = max(1, int(chunk_s * 1e9) // period_ns)
    dt = period_ns / 1e9
    n = bench.arw_deg_sqrt_h * math.pi / 180 / 60
    phase = float(rng.uniform())
    for first in range(0, n_total, per_chunk):
        i = np.arange(first, min(first + per_chunk, n_total), dtype=np.int64)
        t_ns = T0_NS + i * period_ns
        t_s = (t_ns - T0_NS) / 1e9
        rate = EARTH_RAD_S + np.interp(t_s - dt / 2, tr.t_s,
                                       tr.law_rad_s + tr.instability_rad_s)
        angle = rate * dt + n * math.sqrt(dt) * rng.standard_normal(len(i))
        if first == 0:
            angle[0] = 0.0
        cum = phase + np.cumsum(angle / K_RAD)
        phase = float(cum[-1])
        yield t_ns, np.floor(cum)


def pulses(bench: Bench, tr: Truth) -> tuple[np.ndarray, np.ndarray]:
    """/gyro/pulses whole (see :func:`pulse_chunks`)."""
    parts = list(pulse_chunks(bench, tr))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def temperatures(bench: Bench, tr: Truth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """/gyro/temperature: every sensor on its own clock, in stamp order."""
    rng = np.random.default_rng([bench.seed, 3])
    ts, vs, ids = [], [], []
    for name, sen in bench.sensors.items():
        period = sen.interval_s * (1 + sen.drift_ppm * 1e-6)
        rel = sen.offset_s + period * np.arange(int((bench.duration_s - sen.offset_s)
                                                    // period) + 1)
        value = np.interp(rel, tr.t_s, tr.sensed[name])
        value = value + sen.noise_c * rng.standard_normal(len(rel))
        if sen.lsb_c:
            value = np.round(value / sen.lsb_c) * sen.lsb_c
        if sen.stuck_from_s is not None:
            frozen = rel >= sen.stuck_from_s
            if np.any(frozen):
                value[frozen] = value[np.argmax(frozen) - 1] if np.argmax(frozen) else value[0]
        keep = np.ones(len(rel), bool)
        if sen.dropout_s is not None:
            keep = ~((rel >= sen.dropout_s[0]) & (rel < sen.dropout_s[1]))
        ts.append(T0_NS + np.round(rel[keep] * 1e9).astype(np.int64))
        vs.append(value[keep])
        ids.append(np.full(int(np.count_nonzero(keep)), name))
    t = np.concatenate(ts)
    order = np.argsort(t, kind='stable')
    return t[order], np.concatenate(vs)[order], np.concatenate(ids)[order]


def draw_bench(seed: int, *, kind: str, hot: bool, pulse_rate_hz: float,
               sensor_rate_hz: float, shell: bool, dropout: bool, stuck: bool) -> Bench:
    """A bench from a seed and the structural choices (the rest is drawn from the seed)."""
    rng = np.random.default_rng([seed, 0])
    t, c = programme(rng, kind, hot)
    law = Law(b0=float(rng.normal(0.3, 0.2)),
              c1=float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.3)),
              c2=float(rng.uniform(-0.15, 0.15)), r1=float(rng.uniform(-0.1, 0.1)),
              g_ab=float(rng.normal(0, 0.05)), g_cs=float(rng.normal(0, 0.03)) if shell else 0.0)
    names = SENSORS if shell else SENSORS[:2]
    sensors = {}
    duration = t[-1]
    for name in names:
        interval = 1.0 / sensor_rate_hz * float(rng.uniform(0.8, 1.25))
        sensors[name] = Sensor(
            interval_s=min(interval, 100.0), offset_s=float(rng.uniform(0, min(interval, 100))),
            drift_ppm=float(rng.uniform(-200, 200)),
            lsb_c=float(rng.choice([0.0, 0.01, 1 / 16, 1 / 64])),
            noise_c=float(rng.uniform(0, 0.01)))
    if dropout:
        name = str(rng.choice(names))
        start = float(rng.uniform(0.2, 0.7) * duration)
        sensors[name] = _replace(sensors[name], dropout_s=(start, start + rng.uniform(60, 900)))
    if stuck:
        name = str(rng.choice(names))
        sensors[name] = _replace(sensors[name],
                                 stuck_from_s=float(rng.uniform(0.6, 0.9) * duration))
    return Bench(tuple(t), tuple(c), law, warm_start=bool(rng.uniform() < 0.5),
                 tau_shell_s=float(rng.uniform(300, 800)), tau_a_s=float(rng.uniform(150, 400)),
                 tau_b_s=float(rng.uniform(250, 600)), rise_shell_c=float(rng.uniform(0, 1.5)),
                 rise_a_c=float(rng.uniform(0.5, 2.0)), rise_b_c=float(rng.uniform(0.5, 2.0)),
                 tau_sensor_s=float(rng.uniform(0, 5)), pulse_rate_hz=pulse_rate_hz,
                 sensors=sensors, seed=seed)


def _replace(sensor: Sensor, **kw: object) -> Sensor:
    import dataclasses

    return dataclasses.replace(sensor, **kw)  # type: ignore[arg-type]
