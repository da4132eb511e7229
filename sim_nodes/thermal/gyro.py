"""A prism laser gyro in a temperature chamber: thermal network, bias law, pulses (physics).

Thermal network (lumped, linear; METHODS §D.2–3). The shell lags the chamber air with
time constant τ_s and sits ``shell_self_heating_c`` above it in steady state (power
electronics); each cavity arm (a, b) lags the shell with its own τ_a, τ_b and its own
self-heating rise (discharge current)::

    dT_s/dt = (T_air + ΔT_s − T_s)/τ_s
    dT_a/dt = (T_s + ΔT_a − T_a)/τ_a          dT_b/dt = (T_s + ΔT_b − T_b)/τ_b

At switch-on (t = 0) every part is at the chamber temperature (cold start), so the
self-heating appears as a warm-up transient. Because τ_a ≠ τ_b and the arms heat
differently, an arm-to-arm gradient T_a − T_b and a cavity-to-shell gradient H − T_s
appear during ramps and warm-up; H = (T_a + T_b)/2 is the mean cavity temperature.
The network is integrated exactly on a fixed grid (matrix exponential of the system
augmented with the chamber's piecewise-linear drive; steps are split at the chamber's
breakpoints), so the grid values are exact, and derivatives are exact at grid points.
Temperature sensors are first-order lags of the part they sit on, with white noise and
rounding to their resolution.

Bias: the hidden law :class:`ThermalBiasLaw` of H, Ḣ and the gradients of the *true*
temperatures (the estimator sees only the sensors), plus a term no candidate model holds
(a sinusoid in H: the polarisation/mode effect the paper describes as periodic with about
2 °C of cavity temperature), plus bias instability (first-order Gauss–Markov process).

Output: the angle sensed over each sample step is the Earth rate along the sense axis
plus the bias, integrated over the step (evaluated at its midpoint), plus angle random
walk; it becomes whole pulses of K rad with the fractional pulse carried over.

Random draws come from three streams spawned from the seed (angle random walk per pulse
sample, bias instability per grid step, sensor noise per temperature sample), each
consumed in time order, so any chunking of the run gives bit-identical output.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import expm

from gyro_calib.units import NS_PER_S, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.thermal.chamber import ChamberProfile

RAD_S_PER_DEG_H = math.pi / 180.0 / 3600.0
"""1 °/h in rad/s."""
RAD_PER_SQRT_S_PER_DEG_SQRT_H = math.pi / 180.0 / 60.0
"""1 °/√h in rad/√s."""
SENSORS = ('cavity_a', 'cavity_b', 'shell')
"""Temperature sensor names (header.frame_id of /gyro/temperature)."""


def earth_rate_along_axis_deg_h(latitude_deg: float, elevation_deg: float = 90.0,
                                azimuth_deg: float = 0.0,
                                earth_rate_deg_h: float = 15.041) -> float:
    """Earth rate projected on a sense axis fixed to the ground, °/h (METHODS §E).

    The axis points ``elevation_deg`` above the horizon towards ``azimuth_deg`` (from North
    towards East); the Earth rate in East-North-Up is Ω(0, cos φ, sin φ).
    """
    lat, el, az = (math.radians(v) for v in (latitude_deg, elevation_deg, azimuth_deg))
    return earth_rate_deg_h * (math.cos(el) * math.cos(az) * math.cos(lat)
                               + math.sin(el) * math.sin(lat))


@dataclass(frozen=True, slots=True)
class ThermalBiasLaw:
    """One gyro's hidden bias law, °/h, in the true temperatures (METHODS §D.2–3, eq. 17, (2)).

    bias = b₀ + Σ_j h_j (H − H_ref)^j + Σ_j r_j Ḣ^j + g_ab ΔT_ab + g_cs ΔT_cs
           + c_hr (H − H_ref)Ḣ + c_hg (H − H_ref)ΔT_ab + c_rg Ḣ ΔT_ab + g_ab2 ΔT_ab²
           + p sin(2π (H − H_ref)/P)

    with Ḣ in °C/min, ΔT_ab = T_a − T_b and ΔT_cs = H − T_shell in °C. Every coefficient 0
    switches its term off.
    """

    bias_deg_h: float = 0.0
    """b₀: bias at H = H_ref, Ḣ = 0 and no gradient, °/h."""
    reference_c: float = 0.0
    """H_ref, °C."""
    h_deg_h: tuple[float, ...] = ()
    """h_j: coefficient of (H − H_ref)^j, j = 1, 2, …, in °/h per °C^j."""
    hdot_deg_h: tuple[float, ...] = ()
    """r_j: coefficient of Ḣ^j, j = 1, 2, …, in °/h per (°C/min)^j."""
    dtab_deg_h_per_c: float = 0.0
    """g_ab: arm-to-arm gradient coefficient, °/h per °C."""
    dtcs_deg_h_per_c: float = 0.0
    """g_cs: cavity-to-shell gradient coefficient, °/h per °C."""
    h_hdot_deg_h: float = 0.0
    """c_hr, °/h per (°C · °C/min)."""
    h_dtab_deg_h: float = 0.0
    """c_hg, °/h per °C²."""
    hdot_dtab_deg_h: float = 0.0
    """c_rg, °/h per (°C/min · °C)."""
    dtab2_deg_h: float = 0.0
    """g_ab2, °/h per °C²."""
    periodic_deg_h: float = 0.0
    """p: amplitude of the periodic (polarisation/mode) term, °/h — in no candidate model."""
    periodic_period_c: float = 2.0
    """P: its period in H, °C."""

    def bias_deg_h_at(self, h_c: npt.NDArray[np.float64], hdot_c_s: npt.NDArray[np.float64],
                      dtab_c: npt.NDArray[np.float64],
                      dtcs_c: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Evaluate the law, °/h (Ḣ given in °C/s)."""
        x = h_c - self.reference_c
        r = hdot_c_s * 60.0
        out = np.full(np.shape(x), self.bias_deg_h, dtype=np.float64)
        for j, c in enumerate(self.h_deg_h, start=1):
            if c:
                out = out + c * x**j
        for j, c in enumerate(self.hdot_deg_h, start=1):
            if c:
                out = out + c * r**j
        for c, term in ((self.dtab_deg_h_per_c, dtab_c), (self.dtcs_deg_h_per_c, dtcs_c),
                        (self.h_hdot_deg_h, x * r), (self.h_dtab_deg_h, x * dtab_c),
                        (self.hdot_dtab_deg_h, r * dtab_c), (self.dtab2_deg_h, dtab_c**2)):
            if c:
                out = out + c * term
        if self.periodic_deg_h:
            out = out + self.periodic_deg_h * np.sin(2.0 * math.pi * x / self.periodic_period_c)
        return out


@dataclass(frozen=True, slots=True)
class ThermalGyroConfig:
    """Prism laser gyro, its thermal network, sensors and site; defaults: the paper (§D.4).

    Every error source is switched off by setting it to zero (``quantise=False`` emits the
    fractional pulse phase instead of whole pulses).
    """

    gyro_id: str = 'A-1'
    """Identity (serial) of the gyro, carried into the scenario metadata."""
    law: ThermalBiasLaw = field(default_factory=ThermalBiasLaw)
    """Hidden bias law."""
    scale_factor_arcsec_per_pulse: float = 2.3
    """K, ″/pulse (paper: 2.3)."""
    latitude_deg: float = 34.26
    """Site latitude, ° (Xi'an)."""
    sense_axis_elevation_deg: float = 90.0
    """Sense axis elevation above the horizon, ° (90 = vertical)."""
    sense_axis_azimuth_deg: float = 0.0
    """Azimuth of the sense axis' horizontal part, from North towards East, °."""
    earth_rate_deg_h: float = 15.041
    """Earth rotation rate, °/h (0 switches it off)."""
    angle_random_walk_deg_sqrt_h: float = 0.003
    """Angle random walk N, °/√h (paper: 0.003)."""
    bias_instability_deg_h: float = 0.01
    """Standard deviation of the Gauss–Markov bias-instability process, °/h (paper's 0.01)."""
    bias_instability_correlation_s: float = 300.0
    """Its correlation time, s."""
    shell_time_constant_s: float = 600.0
    """τ_s: shell lag behind the chamber air, s."""
    cavity_a_time_constant_s: float = 240.0
    """τ_a: arm a lag behind the shell, s."""
    cavity_b_time_constant_s: float = 420.0
    """τ_b: arm b lag behind the shell, s."""
    shell_self_heating_c: float = 1.0
    """Steady-state rise of the shell above the air, °C."""
    cavity_a_self_heating_c: float = 1.5
    """Steady-state rise of arm a above the shell, °C."""
    cavity_b_self_heating_c: float = 1.0
    """Steady-state rise of arm b above the shell, °C."""
    warm_start: bool = False
    """Start thermally settled (self-heating done) instead of cold at switch-on."""
    sensor_time_constant_s: float = 2.0
    """Lag of each temperature sensor behind the part it sits on, s (0 = none)."""
    temperature_noise_c: float = 0.01
    """White noise of each temperature reading, °C (standard deviation)."""
    temperature_resolution_c: float = 0.01
    """Resolution the readings are rounded to, °C (0 = unrounded)."""
    shell_sensor: bool = True
    """Publish the shell sensor as well as cavity_a and cavity_b."""
    pulse_rate_hz: float = 10.0
    """Rate of /gyro/pulses samples, Hz (1e9/rate must be whole ns)."""
    temperature_rate_hz: float = 1.0
    """Rate of each sensor's /gyro/temperature samples, Hz (1e9/rate whole ns); all sensors
    are read together on one clock unless ``sensor_read_intervals_s`` is given."""
    sensor_read_intervals_s: tuple[float, ...] = ()
    """Each sensor's own reading interval, s, in the order cavity_a, cavity_b, shell (a
    chamber logger reading each sensor on its own clock; () = all at temperature_rate_hz)."""
    sensor_clock_offsets_s: tuple[float, ...] = ()
    """When each sensor's clock takes its first reading, s after the start (same order;
    () = all at 0)."""
    thermal_step_s: float = 1.0
    """Grid step of the thermal network and bias instability, s."""
    quantise: bool = True
    """Emit whole pulses, carrying the fraction."""
    seed: int = 1
    """Seed of the random streams."""

    def __post_init__(self) -> None:
        """Reject parameters the physics cannot take."""
        for name in ('shell_time_constant_s', 'cavity_a_time_constant_s',
                     'cavity_b_time_constant_s', 'thermal_step_s', 'pulse_rate_hz',
                     'temperature_rate_hz', 'scale_factor_arcsec_per_pulse',
                     'bias_instability_correlation_s'):
            if not getattr(self, name) > 0:
                raise ValueError(f'{name} = {getattr(self, name)!r} must be positive')
        for name in ('angle_random_walk_deg_sqrt_h', 'bias_instability_deg_h',
                     'sensor_time_constant_s', 'temperature_noise_c',
                     'temperature_resolution_c'):
            if not getattr(self, name) >= 0:
                raise ValueError(f'{name} = {getattr(self, name)!r} must be >= 0')
        for name in ('pulse_rate_hz', 'temperature_rate_hz'):
            period = NS_PER_S / getattr(self, name)
            if abs(period - round(period)) > 1e-6:
                raise ValueError(f'{name}: 1e9 / rate must be a whole number of ns')
        n_sen = len(self.sensors)
        for name, low in (('sensor_read_intervals_s', 1e-9), ('sensor_clock_offsets_s', 0.0)):
            values = getattr(self, name)
            if values and (len(values) < n_sen or not all(
                    math.isfinite(v) and v >= low for v in values)):
                raise ValueError(f'{name} = {values!r}: give one value per sensor '
                                 f'({", ".join(self.sensors)}), each >= {low:g} s')

    @property
    def sensors(self) -> tuple[str, ...]:
        """Names of the published temperature sensors."""
        return SENSORS if self.shell_sensor else SENSORS[:2]

    @property
    def scale_factor_rad_per_pulse(self) -> float:
        """K, rad/pulse."""
        return self.scale_factor_arcsec_per_pulse * RAD_PER_ARCSEC

    def earth_rate_along_axis_rad_s(self) -> float:
        """Earth-rate component along the sense axis, rad/s."""
        return earth_rate_along_axis_deg_h(
            self.latitude_deg, self.sense_axis_elevation_deg, self.sense_axis_azimuth_deg,
            self.earth_rate_deg_h) * RAD_S_PER_DEG_H


@dataclass(frozen=True, slots=True)
class ThermalTruth:
    """Simulation truth at given stamps (sim only).

    Attributes:
        t_ns: stamps, int64 ns.
        chamber_c, shell_c, cavity_a_c, cavity_b_c: true temperatures, °C.
        h_c: H = (T_a + T_b)/2, °C. hdot_c_s: dH/dt, °C/s.
        dtab_c: T_a − T_b, °C. dtcs_c: H − T_shell, °C.
        law_bias_rad_s: the hidden law's bias (incl. its periodic term), rad/s.
        instability_rad_s: the Gauss–Markov bias-instability value, rad/s.
    """

    t_ns: npt.NDArray[np.int64]
    chamber_c: npt.NDArray[np.float64]
    shell_c: npt.NDArray[np.float64]
    cavity_a_c: npt.NDArray[np.float64]
    cavity_b_c: npt.NDArray[np.float64]
    h_c: npt.NDArray[np.float64]
    hdot_c_s: npt.NDArray[np.float64]
    dtab_c: npt.NDArray[np.float64]
    dtcs_c: npt.NDArray[np.float64]
    law_bias_rad_s: npt.NDArray[np.float64]
    instability_rad_s: npt.NDArray[np.float64]

    @staticmethod
    def concatenate(parts: list[ThermalTruth]) -> ThermalTruth:
        """Join chunks of truth in time order."""
        names = ThermalTruth.__dataclass_fields__
        return ThermalTruth(**{n: np.concatenate([getattr(p, n) for p in parts])
                               for n in names})


@dataclass(frozen=True, slots=True)
class ThermalChunk:
    """One chunk of published samples and truth.

    Attributes:
        pulse_t_ns: /gyro/pulses stamps, int64 ns.
        pulse_counts: cumulative pulse count (whole numbers in float64).
        temperature_t_ns: /gyro/temperature stamps, int64 ns (one message per sensor).
        temperature_c: readings, °C.
        temperature_variance_c2: the variance each message carries, °C².
        temperature_frame_id: sensor name of each message.
        truth: truth at the temperature stamps (one row per instant, not per message).
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    temperature_t_ns: npt.NDArray[np.int64]
    temperature_c: npt.NDArray[np.float64]
    temperature_variance_c2: npt.NDArray[np.float64]
    temperature_frame_id: npt.NDArray[np.str_]
    truth: ThermalTruth


_U, _ONE, _S, _A, _B, _SA, _SB, _SS = range(8)


class ThermalGyroSimulator:
    """Streams a gyro's pulses and temperatures through a chamber programme in chunks."""

    def __init__(self, config: ThermalGyroConfig, chamber: ChamberProfile, *,
                 start_time_ns: int = 0, duration_s: float | None = None) -> None:
        """Set up the run; nothing is computed until :meth:`advance` is called.

        Args:
            config: the gyro.
            chamber: the chamber programme (t = 0 at ``start_time_ns``).
            start_time_ns: stamp of the first sample, ns.
            duration_s: length of the run, s (default: the programme's length).
        """
        self.config = config
        self.chamber = chamber
        self.start_time_ns = int(start_time_ns)
        dur = chamber.duration_s if duration_s is None else float(duration_s)
        self.end_time_ns = self.start_time_ns + int(round(dur * NS_PER_S))
        cfg = config
        seeds = np.random.SeedSequence(cfg.seed).spawn(3)
        self._rng_arw = np.random.default_rng(seeds[0])
        self._rng_gm = np.random.default_rng(seeds[1])
        self._rng_sensor = np.random.default_rng(seeds[2])
        self._pulse_period_ns = int(round(NS_PER_S / cfg.pulse_rate_hz))
        self._temp_period_ns = int(round(NS_PER_S / cfg.temperature_rate_hz))
        self._k_rad = cfg.scale_factor_rad_per_pulse
        self._earth_rad_s = cfg.earth_rate_along_axis_rad_s()
        self._n_state = 8 if cfg.sensor_time_constant_s > 0 else 5
        self._phi_cache: dict[tuple[float, float], npt.NDArray[np.float64]] = {}
        self._breaks = chamber.breakpoints_s()
        temps = chamber.breakpoint_temperatures_c()
        self._slopes = [float((temps[i + 1] - temps[i]) / (self._breaks[i + 1] - self._breaks[i]))
                        for i in range(len(self._breaks) - 1)]
        self._seg = 0
        # thermal grid: state at t = k·h; kept from _grid_k0 on
        self._h = cfg.thermal_step_s
        z0 = np.zeros(self._n_state)
        z0[_U] = chamber.start_c
        z0[_ONE] = 1.0
        base = chamber.start_c
        if cfg.warm_start:
            z0[_S] = base + cfg.shell_self_heating_c
            z0[_A] = z0[_S] + cfg.cavity_a_self_heating_c
            z0[_B] = z0[_S] + cfg.cavity_b_self_heating_c
        else:
            z0[_S] = z0[_A] = z0[_B] = base
        if self._n_state == 8:
            z0[_SA], z0[_SB], z0[_SS] = z0[_A], z0[_B], z0[_S]
        sigma = cfg.bias_instability_deg_h * RAD_S_PER_DEG_H
        gm0 = sigma * float(self._rng_gm.standard_normal()) if sigma else 0.0
        self._grid_k0 = 0
        self._grid_z = [z0]
        self._grid_gm = [gm0]
        self._phase = float(self._rng_arw.uniform())
        self._next_pulse = 0
        self._next_temp = 0
        self._last_pulse_ns: int | None = None
        # sensors on their own clocks (None: all read together every _temp_period_ns)
        n_sen = len(cfg.sensors)
        self._own_clocks = bool(cfg.sensor_read_intervals_s or cfg.sensor_clock_offsets_s)
        intervals = cfg.sensor_read_intervals_s or (1.0 / cfg.temperature_rate_hz,) * n_sen
        offsets = cfg.sensor_clock_offsets_s or (0.0,) * n_sen
        self._read_period_ns = [int(round(v * NS_PER_S)) for v in intervals[:n_sen]]
        self._read_offset_ns = [int(round(v * NS_PER_S)) for v in offsets[:n_sen]]
        self._next_read = [0] * n_sen

    # -- thermal network ---------------------------------------------------------------------
    def _system(self, slope_c_s: float) -> npt.NDArray[np.float64]:
        cfg = self.config
        a = np.zeros((self._n_state, self._n_state))
        a[_U, _ONE] = slope_c_s
        ts, ta, tb = (cfg.shell_time_constant_s, cfg.cavity_a_time_constant_s,
                      cfg.cavity_b_time_constant_s)
        a[_S, _U], a[_S, _ONE], a[_S, _S] = 1 / ts, cfg.shell_self_heating_c / ts, -1 / ts
        a[_A, _S], a[_A, _ONE], a[_A, _A] = 1 / ta, cfg.cavity_a_self_heating_c / ta, -1 / ta
        a[_B, _S], a[_B, _ONE], a[_B, _B] = 1 / tb, cfg.cavity_b_self_heating_c / tb, -1 / tb
        if self._n_state == 8:
            tsen = cfg.sensor_time_constant_s
            for sen, part in ((_SA, _A), (_SB, _B), (_SS, _S)):
                a[sen, part], a[sen, sen] = 1 / tsen, -1 / tsen
        return a

    def _phi(self, slope_c_s: float, dt_s: float) -> npt.NDArray[np.float64]:
        key = (slope_c_s, dt_s)
        phi = self._phi_cache.get(key)
        if phi is None:
            phi = expm(self._system(slope_c_s) * dt_s)
            self._phi_cache[key] = phi
        return phi

    def _slope_at(self, t_s: float) -> tuple[float, float]:
        """Chamber slope (°C/s) at ``t_s`` and the next breakpoint (cached segment walk)."""
        breaks = self._breaks
        while self._seg + 1 < len(breaks) and t_s >= breaks[self._seg + 1]:
            self._seg += 1
        if self._seg + 1 >= len(breaks):
            return 0.0, math.inf
        return self._slopes[self._seg], float(breaks[self._seg + 1])

    def _extend_grid(self, t_s: float) -> None:
        """Step the thermal grid until it covers ``t_s`` (s from the start) plus one step."""
        cfg = self.config
        h = self._h
        sigma = cfg.bias_instability_deg_h * RAD_S_PER_DEG_H
        rho = math.exp(-h / cfg.bias_instability_correlation_s)
        drive = sigma * math.sqrt(1.0 - rho * rho)
        k_last = self._grid_k0 + len(self._grid_z) - 1
        z = self._grid_z[-1]
        gm = self._grid_gm[-1]
        normal = self._rng_gm.standard_normal
        while k_last * h <= t_s + h:
            t0, t1 = k_last * h, (k_last + 1) * h
            t = t0
            while t < t1:
                slope, next_break = self._slope_at(t)
                stop = min(t1, next_break)
                z = self._phi(slope, stop - t) @ z
                t = stop
            self._grid_z.append(z)
            gm = rho * gm + drive * float(normal()) if sigma else 0.0
            self._grid_gm.append(gm)
            k_last += 1

    def _drop_grid_before(self, t_s: float) -> None:
        keep_from = max(int(math.floor(t_s / self._h)) - 1, self._grid_k0)
        cut = keep_from - self._grid_k0
        if cut > 0:
            del self._grid_z[:cut]
            del self._grid_gm[:cut]
            self._grid_k0 = keep_from

    def _state_at(self, t_s: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64], ...]:
        """Interpolated grid state, its derivatives and the instability at times ``t_s``."""
        z = np.array(self._grid_z)
        k = self._grid_k0 + np.arange(len(z))
        grid_t = k * self._h
        cfg = self.config
        # exact derivatives at grid points (the temperatures' derivative is continuous);
        # elementwise, so a value never depends on how many grid points are held
        da_grid = ((z[:, _S] + cfg.cavity_a_self_heating_c - z[:, _A])
                   / cfg.cavity_a_time_constant_s)
        db_grid = ((z[:, _S] + cfg.cavity_b_self_heating_c - z[:, _B])
                   / cfg.cavity_b_time_constant_s)
        cols = {name: np.interp(t_s, grid_t, z[:, i]) for name, i in
                (('u', _U), ('s', _S), ('a', _A), ('b', _B))}
        da = np.interp(t_s, grid_t, da_grid)
        db = np.interp(t_s, grid_t, db_grid)
        if self._n_state == 8:
            sens = [np.interp(t_s, grid_t, z[:, i]) for i in (_SA, _SB, _SS)]
        else:
            sens = [cols['a'], cols['b'], cols['s']]
        gm = np.interp(t_s, grid_t, np.array(self._grid_gm))
        return cols['u'], cols['s'], cols['a'], cols['b'], da, db, sens[0], sens[1], sens[2], gm

    def _truth_at(self, t_ns: npt.NDArray[np.int64]) -> tuple[ThermalTruth, list]:
        t_s = (t_ns - self.start_time_ns) / NS_PER_S
        u, s, a, b, da, db, sa, sb, ss, gm = self._state_at(t_s)
        h = 0.5 * (a + b)
        hdot = 0.5 * (da + db)
        dtab = a - b
        dtcs = h - s
        law = self.config.law.bias_deg_h_at(h, hdot, dtab, dtcs) * RAD_S_PER_DEG_H
        truth = ThermalTruth(np.asarray(t_ns, np.int64), u, s, a, b, h, hdot, dtab, dtcs,
                             law, gm)
        return truth, [sa, sb, ss]

    # -- output ------------------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        """True once every sample of the run has been emitted."""
        t0, end = self.start_time_ns, self.end_time_ns
        if self._own_clocks:
            temps_done = all(t0 + off + n * per > end for off, n, per in zip(
                self._read_offset_ns, self._next_read, self._read_period_ns))
        else:
            temps_done = t0 + self._next_temp * self._temp_period_ns > end
        return t0 + self._next_pulse * self._pulse_period_ns > end and temps_done

    def advance(self, until_ns: int) -> ThermalChunk:
        """Emit every pulse and temperature sample stamped ≤ ``until_ns`` (and ≤ the end)."""
        cfg = self.config
        until_ns = min(int(until_ns), self.end_time_ns)
        t0 = self.start_time_ns
        n_p = max(0, (until_ns - t0) // self._pulse_period_ns + 1 - self._next_pulse)
        n_t = max(0, (until_ns - t0) // self._temp_period_ns + 1 - self._next_temp)
        p_idx = self._next_pulse + np.arange(n_p, dtype=np.int64)
        t_idx = self._next_temp + np.arange(n_t, dtype=np.int64)
        p_t = t0 + p_idx * self._pulse_period_ns
        tt = t0 + t_idx * self._temp_period_ns
        self._extend_grid(max((until_ns - t0) / NS_PER_S, 0.0))
        counts = self._pulses(p_t)
        if self._own_clocks:
            self._next_pulse += n_p
            return self._own_clock_chunk(p_t, counts, until_ns)
        truth, sensor_true = self._truth_at(tt)
        names = cfg.sensors
        n_sen = len(names)
        noise = self._rng_sensor.standard_normal((n_t, n_sen)) * cfg.temperature_noise_c
        readings = np.column_stack(sensor_true[:n_sen]) + noise if n_t else np.zeros((0, n_sen))
        q = cfg.temperature_resolution_c
        if q:
            readings = np.round(readings / q) * q
        variance = cfg.temperature_noise_c**2 + q * q / 12.0
        self._next_pulse += n_p
        self._next_temp += n_t
        oldest_needed_ns = until_ns if self._last_pulse_ns is None else min(
            until_ns, self._last_pulse_ns)
        self._drop_grid_before((oldest_needed_ns - t0) / NS_PER_S)
        return ThermalChunk(
            pulse_t_ns=p_t, pulse_counts=counts,
            temperature_t_ns=np.repeat(tt, n_sen), temperature_c=readings.reshape(-1),
            temperature_variance_c2=np.full(n_t * n_sen, variance),
            temperature_frame_id=np.tile(np.array(names), n_t), truth=truth)

    def _read(self, true_c: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64], float]:
        """Sensor readings of true sensor temperatures.

        Sensor readings of true sensor temperatures: white noise (drawn in message
        order), rounded to the resolution (LSB); and the variance each message carries.
        """
        cfg = self.config
        readings = true_c + self._rng_sensor.standard_normal(len(true_c)) \
            * cfg.temperature_noise_c
        q = cfg.temperature_resolution_c
        if q:
            readings = np.round(readings / q) * q
        return readings, cfg.temperature_noise_c**2 + q * q / 12.0

    def _own_clock_chunk(self, p_t: npt.NDArray[np.int64], counts: npt.NDArray[np.float64],
                         until_ns: int) -> ThermalChunk:
        """Temperatures of sensors each read on its own clock.

        Temperatures of sensors each read on its own clock (period and first reading of
        its own); messages in stamp order, at equal stamps in sensor order; truth at every
        instant any sensor is read.
        """
        t0 = self.start_time_ns
        names = self.config.sensors
        stamps, which = [], []
        for j in range(len(names)):
            per, off = self._read_period_ns[j], self._read_offset_ns[j]
            first = t0 + off
            n = 0 if until_ns < first else (until_ns - first) // per + 1 - self._next_read[j]
            n = max(0, int(n))
            stamps.append(first + (self._next_read[j] + np.arange(n, dtype=np.int64)) * per)
            which.append(np.full(n, j, np.int64))
            self._next_read[j] += n
        t_msg = np.concatenate(stamps) if stamps else np.zeros(0, np.int64)
        j_msg = np.concatenate(which) if which else np.zeros(0, np.int64)
        order = np.lexsort((j_msg, t_msg))
        t_msg, j_msg = t_msg[order], j_msg[order]
        instants, row = np.unique(t_msg, return_inverse=True)
        truth, sensor_true = self._truth_at(instants)
        true_c = np.array([sensor_true[j][r] for j, r in zip(j_msg.tolist(), row.tolist())],
                          np.float64)
        readings, variance = self._read(true_c)
        oldest_needed_ns = until_ns if self._last_pulse_ns is None else min(
            until_ns, self._last_pulse_ns)
        self._drop_grid_before((oldest_needed_ns - t0) / NS_PER_S)
        return ThermalChunk(
            pulse_t_ns=p_t, pulse_counts=counts, temperature_t_ns=t_msg,
            temperature_c=readings, temperature_variance_c2=np.full(len(t_msg), variance),
            temperature_frame_id=np.array(names)[j_msg] if len(j_msg) else
            np.zeros(0, dtype='<U8'), truth=truth)

    def _pulses(self, p_t: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        cfg = self.config
        if len(p_t) == 0:
            return np.zeros(0)
        prev = np.concatenate(([p_t[0] if self._last_pulse_ns is None else self._last_pulse_ns],
                               p_t[:-1]))
        dt_s = (p_t - prev) / NS_PER_S
        mid_ns = prev + (p_t - prev) // 2
        truth, _ = self._truth_at(mid_ns)
        rate = self._earth_rad_s + truth.law_bias_rad_s + truth.instability_rad_s
        angle = rate * dt_s
        if cfg.angle_random_walk_deg_sqrt_h:
            n = cfg.angle_random_walk_deg_sqrt_h * RAD_PER_SQRT_S_PER_DEG_SQRT_H
            angle = angle + n * np.sqrt(dt_s) * self._rng_arw.standard_normal(len(p_t))
        if self._last_pulse_ns is None:
            angle[0] = 0.0  # the first sample closes no step
        phase = np.cumsum(np.concatenate(([self._phase], angle / self._k_rad)))[1:]
        self._phase = float(phase[-1])
        self._last_pulse_ns = int(p_t[-1])
        return np.floor(phase) if cfg.quantise else phase

    def chunks(self, chunk_s: float = 600.0) -> Iterator[ThermalChunk]:
        """Yield :class:`ThermalChunk` of ``chunk_s`` seconds until the run ends."""
        step_ns = int(round(chunk_s * NS_PER_S))
        t = self.start_time_ns - 1
        while not self.finished:
            t += step_ns
            yield self.advance(t)
