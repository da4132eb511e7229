"""Thermal scenarios: named gyros (hidden bias laws), chamber runs, faults, whole recordings.

A recording is what a bench would publish — ``/gyro/pulses`` (stamp, cumulative count)
and ``/gyro/temperature`` (stamp, °C, variance, header.frame_id naming the sensor) — as
arrays, with the truth and a plain-dict scenario description (gyro id, seeds, configs)
for a bag's metadata. Rates are settable; the defaults (10 Hz pulses, 1 Hz temperatures)
keep an 8-hour chamber run small.

Gyros (:data:`GYRO_LAWS`): the terms that matter differ gyro to gyro (METHODS §D.3).
``A-1`` and ``A-2`` follow the paper's two type-009 gyros (§D.4): A-1's law is the
least-squares quartic through its seven published points (strongly non-monotonic), A-2's
the cubic through its points (near-linear), each with a small dynamic part and a small
periodic term no candidate model holds. ``B-1`` is rate-sensitive (Ḣ, Ḣ², H·Ḣ), ``B-2``
gradient-sensitive (arm-to-arm and cavity-to-shell), ``C-1`` follows the second-order
cross-term model (2). :func:`random_gyro` draws further hidden laws for benchmarks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.units import NS_PER_S
from sim_nodes.thermal.chamber import (
    ChamberProfile,
    paper_soak_programme,
    ramp_only_programme,
    ramp_programme,
    soak_programme,
)
from sim_nodes.thermal.gyro import (
    ThermalBiasLaw,
    ThermalChunk,
    ThermalGyroConfig,
    ThermalGyroSimulator,
    ThermalTruth,
)

if TYPE_CHECKING:
    import numpy.typing as npt

GYRO_LAWS: dict[str, ThermalBiasLaw] = {
    'A-1': ThermalBiasLaw(
        bias_deg_h=0.452033,
        h_deg_h=(0.0156786, 0.000184531, -1.21708e-05, -3.70965e-07),
        hdot_deg_h=(0.04,), periodic_deg_h=0.002),
    'A-2': ThermalBiasLaw(
        bias_deg_h=0.405602, h_deg_h=(-0.002272, -6.27264e-05, -2.08e-06),
        dtab_deg_h_per_c=0.03, periodic_deg_h=0.002),
    'B-1': ThermalBiasLaw(
        bias_deg_h=-0.2, h_deg_h=(0.004, 8e-05), hdot_deg_h=(0.12, 0.05),
        h_hdot_deg_h=0.002, periodic_deg_h=0.002),
    'B-2': ThermalBiasLaw(
        bias_deg_h=0.1, h_deg_h=(-0.006,), dtab_deg_h_per_c=0.15, dtcs_deg_h_per_c=-0.08,
        periodic_deg_h=0.002),
    'C-1': ThermalBiasLaw(
        bias_deg_h=0.3, h_deg_h=(0.005, 6e-05), hdot_deg_h=(0.06, 0.03),
        dtab_deg_h_per_c=0.05, h_hdot_deg_h=0.0015, h_dtab_deg_h=0.001,
        hdot_dtab_deg_h=0.02, dtab2_deg_h=0.01, periodic_deg_h=0.002),
}
"""Hidden bias laws of the named gyros (°/h; see :class:`ThermalBiasLaw`)."""


def gyro_config(gyro_id: str = 'A-1', **overrides: Any) -> ThermalGyroConfig:
    """The named gyro (law from :data:`GYRO_LAWS`, paper defaults otherwise) with overrides."""
    if gyro_id not in GYRO_LAWS:
        raise KeyError(f'unknown gyro {gyro_id!r}; known: {", ".join(GYRO_LAWS)}')
    return ThermalGyroConfig(gyro_id=gyro_id, law=GYRO_LAWS[gyro_id], **overrides)


def random_law(rng: np.random.Generator) -> ThermalBiasLaw:
    """A random hidden law: a polynomial in H of random order and random dynamic terms.

    Sizes are typical of the paper's gyros: a few tenths of °/h across −35…35 °C.
    """
    order = int(rng.integers(1, 4))
    h = tuple(float(rng.normal(0, 0.2) / 35.0**j) for j in range(1, order + 1))
    hdot = (float(rng.normal(0, 0.08)),) if rng.uniform() < 0.6 else ()
    if hdot and rng.uniform() < 0.4:
        hdot = hdot + (float(rng.normal(0, 0.04)),)
    return ThermalBiasLaw(
        bias_deg_h=float(rng.normal(0.3, 0.2)), h_deg_h=h, hdot_deg_h=hdot,
        dtab_deg_h_per_c=float(rng.normal(0, 0.08)) if rng.uniform() < 0.4 else 0.0,
        dtcs_deg_h_per_c=float(rng.normal(0, 0.05)) if rng.uniform() < 0.3 else 0.0,
        h_hdot_deg_h=float(rng.normal(0, 0.002)) if rng.uniform() < 0.3 else 0.0,
        periodic_deg_h=float(abs(rng.normal(0, 0.002))))


def random_gyro(seed: int, **overrides: Any) -> ThermalGyroConfig:
    """A gyro with a random hidden law and random thermal time constants (seeded)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    params: dict[str, Any] = dict(
        gyro_id=f'R-{seed}', law=random_law(rng),
        shell_time_constant_s=float(rng.uniform(400, 900)),
        cavity_a_time_constant_s=float(rng.uniform(150, 400)),
        cavity_b_time_constant_s=float(rng.uniform(250, 600)),
        cavity_a_self_heating_c=float(rng.uniform(0.5, 2.0)),
        cavity_b_self_heating_c=float(rng.uniform(0.5, 2.0)), seed=seed)
    params.update(overrides)
    return ThermalGyroConfig(**params)


@dataclass(frozen=True, slots=True)
class ThermalFaults:
    """Data faults applied to the published temperatures, never to the truth (all off).

    Attributes:
        stuck_sensor: sensor whose reading freezes at its value at ``stuck_from_s``.
        stuck_from_s: s from the start.
        nan_sensor: sensor that publishes NaN during ``nan_s`` (start, end), s.
        nan_s: the span.
        dropout_sensor: sensor that publishes nothing during ``dropout_s`` (start, end), s.
        dropout_s: the span.
        drop_temperature_topic: publish no /gyro/temperature at all.
        drop_sensor: a sensor that never publishes.
    """

    stuck_sensor: str | None = None
    stuck_from_s: float = 0.0
    nan_sensor: str | None = None
    nan_s: tuple[float, float] = (0.0, 0.0)
    dropout_sensor: str | None = None
    dropout_s: tuple[float, float] = (0.0, 0.0)
    drop_temperature_topic: bool = False
    drop_sensor: str | None = None


@dataclass(frozen=True, slots=True)
class ThermalRecording:
    """A whole run as arrays (the two contract topics), its truth and its description.

    Attributes:
        pulse_t_ns, pulse_counts: /gyro/pulses (int64 ns; cumulative count).
        temperature_t_ns, temperature_c, temperature_variance_c2, temperature_frame_id:
            /gyro/temperature, one entry per message.
        truth: truth at each temperature instant.
        scenario: plain-dict description (name, gyro id, seeds, configs) for bag metadata.
    """

    pulse_t_ns: npt.NDArray[np.int64]
    pulse_counts: npt.NDArray[np.float64]
    temperature_t_ns: npt.NDArray[np.int64]
    temperature_c: npt.NDArray[np.float64]
    temperature_variance_c2: npt.NDArray[np.float64]
    temperature_frame_id: npt.NDArray[np.str_]
    truth: ThermalTruth
    scenario: dict[str, Any] = field(default_factory=dict)

    @property
    def gyro_id(self) -> str:
        """The simulated gyro's identity."""
        return str(self.scenario.get('gyro_id', ''))

    @property
    def duration_s(self) -> float:
        """Span of the pulse stamps, s."""
        return float(self.pulse_t_ns[-1] - self.pulse_t_ns[0]) / NS_PER_S


def _describe(name: str, gyro: ThermalGyroConfig, chamber: ChamberProfile,
              start_time_ns: int, duration_s: float, faults: ThermalFaults) -> dict[str, Any]:
    cfg = dataclasses.asdict(gyro)
    return {
        'name': name, 'kind': 'thermal', 'gyro_id': gyro.gyro_id, 'seed': gyro.seed,
        'start_time_ns': int(start_time_ns), 'duration_s': float(duration_s),
        'gyro': cfg,
        'chamber': {'start_c': chamber.start_c, 'segments': [list(s) for s in chamber.segments]},
        'faults': dataclasses.asdict(faults),
        # what the operator knows (calibration inputs, not the answer): the site, the
        # mounting, the gyro's serial and its K from the RBRLG calibration
        'bench': {
            'gyro_id': gyro.gyro_id,
            'scale_factor_rad_per_pulse': gyro.scale_factor_rad_per_pulse,
            'latitude_deg': gyro.latitude_deg,
            'sense_axis_elevation_deg': gyro.sense_axis_elevation_deg,
            'sense_axis_azimuth_deg': gyro.sense_axis_azimuth_deg,
        },
        'truth': {
            'scale_factor_rad_per_pulse': gyro.scale_factor_rad_per_pulse,
            'earth_rate_along_axis_rad_s': gyro.earth_rate_along_axis_rad_s(),
            'latitude_deg': gyro.latitude_deg,
            'sense_axis_elevation_deg': gyro.sense_axis_elevation_deg,
            'sense_axis_azimuth_deg': gyro.sense_axis_azimuth_deg,
        },
    }


class FaultApplier:
    """Applies :class:`ThermalFaults` to temperature messages chunk by chunk.

    The only state is the stuck sensor's frozen reading (its last reading before
    ``stuck_from_s``, carried from chunk to chunk), so any chunking gives the same output
    as one call over the whole recording.
    """

    def __init__(self, faults: ThermalFaults, start_time_ns: int) -> None:
        """Faults of a run starting at ``start_time_ns``."""
        self.faults = faults
        self.start_time_ns = int(start_time_ns)
        self._last_good: float | None = None
        self._frozen: float | None = None

    def apply(self, t_ns: npt.NDArray[np.int64], values: npt.NDArray[np.float64],
              frame_id: npt.NDArray[np.str_]) -> tuple[npt.NDArray[np.float64],
                                                       npt.NDArray[np.bool_]]:
        """The faulty readings of one chunk (a copy) and the mask of messages published."""
        faults = self.faults
        values = values.copy()
        keep = np.ones(len(t_ns), bool)
        rel_s = (t_ns - self.start_time_ns) / NS_PER_S
        if faults.drop_temperature_topic:
            keep[:] = False
        if faults.drop_sensor is not None:
            keep &= frame_id != faults.drop_sensor
        if faults.stuck_sensor is not None:
            mine = np.nonzero(frame_id == faults.stuck_sensor)[0]
            stuck = mine[rel_s[mine] >= faults.stuck_from_s]
            before = mine[rel_s[mine] < faults.stuck_from_s]
            if len(before):
                self._last_good = float(values[before[-1]])
            if len(stuck):
                if self._frozen is None:
                    self._frozen = (self._last_good if self._last_good is not None
                                    else float(values[stuck[0]]))
                values[stuck] = self._frozen
        if faults.nan_sensor is not None:
            sel = (frame_id == faults.nan_sensor) & (rel_s >= faults.nan_s[0]) & (
                rel_s < faults.nan_s[1])
            values[sel] = np.nan
        if faults.dropout_sensor is not None:
            keep &= ~((frame_id == faults.dropout_sensor) & (rel_s >= faults.dropout_s[0])
                      & (rel_s < faults.dropout_s[1]))
        return values, keep


def apply_faults(chunk_t: npt.NDArray[np.int64], values: npt.NDArray[np.float64],
                 frame_id: npt.NDArray[np.str_], faults: ThermalFaults,
                 start_time_ns: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                              npt.NDArray[np.bool_]]:
    """Apply ``faults`` to a whole recording's temperature messages.

    Apply ``faults`` to a whole recording's temperature messages; return stamps, values
    and a keep mask (:class:`FaultApplier` in one call).
    """
    values, keep = FaultApplier(faults, start_time_ns).apply(chunk_t, values, frame_id)
    return chunk_t, values, keep


class ThermalRun:
    """One chamber run of one gyro, faults applied, in chunks.

    One chamber run of one gyro, faults applied, streamed in chunks (simulator nodes,
    bag writers); :func:`simulate_thermal_run` concatenates the same chunks.

    Attributes:
        simulator: the gyro-in-chamber simulator.
        scenario: plain-dict description (name, gyro id, seeds, configs, bench, truth).
    """

    def __init__(self, gyro: ThermalGyroConfig, chamber: ChamberProfile, *,
                 name: str = 'thermal_run', start_time_ns: int = 1_700_000_000 * NS_PER_S,
                 duration_s: float | None = None,
                 faults: ThermalFaults | None = None) -> None:
        """Set up the simulator and the faults; nothing is simulated yet."""
        self.faults = faults or ThermalFaults()
        self.simulator = ThermalGyroSimulator(gyro, chamber, start_time_ns=start_time_ns,
                                              duration_s=duration_s)
        self._faults = FaultApplier(self.faults, start_time_ns)
        dur = (self.simulator.end_time_ns - self.simulator.start_time_ns) / NS_PER_S
        self.scenario = _describe(name, gyro, chamber, start_time_ns, dur, self.faults)

    @property
    def finished(self) -> bool:
        """True once every sample has been emitted."""
        return self.simulator.finished

    def advance(self, until_ns: int) -> ThermalChunk:
        """Every sample stamped ≤ ``until_ns``, faults applied.

        Every sample stamped ≤ ``until_ns``, with the faults applied to the temperatures
        (truth untouched).
        """
        c = self.simulator.advance(until_ns)
        values, keep = self._faults.apply(c.temperature_t_ns, c.temperature_c,
                                          c.temperature_frame_id)
        return ThermalChunk(c.pulse_t_ns, c.pulse_counts, c.temperature_t_ns[keep],
                            values[keep], c.temperature_variance_c2[keep],
                            c.temperature_frame_id[keep], c.truth)

    def chunks(self, chunk_s: float = 600.0) -> Iterator[ThermalChunk]:
        """Yield chunks of ``chunk_s`` seconds until the run ends."""
        step_ns = int(round(chunk_s * NS_PER_S))
        t = self.simulator.start_time_ns - 1
        while not self.finished:
            t += step_ns
            yield self.advance(t)


def simulate_thermal_run(gyro: ThermalGyroConfig, chamber: ChamberProfile, *,
                         name: str = 'thermal_run', start_time_ns: int = 1_700_000_000 * NS_PER_S,
                         duration_s: float | None = None,
                         faults: ThermalFaults | None = None,
                         chunk_s: float = 3600.0) -> ThermalRecording:
    """Run the gyro through the chamber programme offline; return the whole recording.

    Faults act on the published temperatures (a stuck sensor freezes at its last good
    value); the output does not depend on ``chunk_s``.
    """
    run = ThermalRun(gyro, chamber, name=name, start_time_ns=start_time_ns,
                     duration_s=duration_s, faults=faults)
    parts: list[ThermalChunk] = list(run.chunks(chunk_s))
    cat = np.concatenate
    return ThermalRecording(
        pulse_t_ns=cat([p.pulse_t_ns for p in parts]),
        pulse_counts=cat([p.pulse_counts for p in parts]),
        temperature_t_ns=cat([p.temperature_t_ns for p in parts]),
        temperature_c=cat([p.temperature_c for p in parts]),
        temperature_variance_c2=cat([p.temperature_variance_c2 for p in parts]),
        temperature_frame_id=cat([p.temperature_frame_id for p in parts]),
        truth=ThermalTruth.concatenate([p.truth for p in parts]),
        scenario=run.scenario)


def paper_soak_scenario(gyro_id: str = 'A-1', seed: int = 1, *, soak_s: float = 3600.0,
                        gyro: ThermalGyroConfig | None = None,
                        faults: ThermalFaults | None = None, **overrides: Any
                        ) -> ThermalRecording:
    """The paper's calibration run: −35…35 °C, 7 points, 1 h soaks, 1 °C/min ramps (§D.4)."""
    cfg = gyro or gyro_config(gyro_id, seed=seed, **overrides)
    return simulate_thermal_run(cfg, paper_soak_programme(soak_s=soak_s),
                                name=f'thermal_paper_soak_{cfg.gyro_id}_{cfg.seed}',
                                faults=faults)


def continuous_ramp_scenario(gyro_id: str = 'A-1', seed: int = 1, *, low_c: float = -35.0,
                             high_c: float = 35.0, rate_c_per_min: float = 0.5,
                             cycles: int = 1, dwell_s: float = 1800.0,
                             gyro: ThermalGyroConfig | None = None,
                             faults: ThermalFaults | None = None,
                             **overrides: Any) -> ThermalRecording:
    """Continuous slow ramps low → high → low with dwells (the second calibration style)."""
    cfg = gyro or gyro_config(gyro_id, seed=seed, **overrides)
    chamber = ramp_programme(low_c, high_c, rate_c_per_min=rate_c_per_min, cycles=cycles,
                             dwell_s=dwell_s)
    return simulate_thermal_run(cfg, chamber, name=f'thermal_ramp_{cfg.gyro_id}_{cfg.seed}',
                                faults=faults)


VALIDATION_SET_POINTS_C = (-30.0, -20.0, -5.0, 10.0, 20.0, 30.0)
"""Set points of the validation run: between the calibration points, rising like them."""


def validation_scenario(gyro_id: str = 'A-1', seed: int = 101, *, soak_s: float = 2400.0,
                        ramp_rate_c_per_min: float = 1.0,
                        gyro: ThermalGyroConfig | None = None,
                        faults: ThermalFaults | None = None,
                        **overrides: Any) -> ThermalRecording:
    """A run the model never saw: other set points, shorter soaks, another seed."""
    cfg = gyro or gyro_config(gyro_id, seed=seed, **overrides)
    chamber = soak_programme(VALIDATION_SET_POINTS_C, soak_s=soak_s,
                             ramp_rate_c_per_min=ramp_rate_c_per_min)
    return simulate_thermal_run(cfg, chamber,
                                name=f'thermal_validation_{cfg.gyro_id}_{cfg.seed}',
                                faults=faults)


PROGRAMMES = ('paper_soak', 'continuous_ramp', 'validation', 'ramp_only')
"""Chamber programmes a :class:`ChamberRunConfig` names."""

SENSOR_NAMES = ('', 'cavity_a', 'cavity_b', 'shell')
"""Values of the fault fields naming a sensor ('' = no such fault)."""


@dataclass(frozen=True, slots=True)
class ChamberRunConfig:
    """One chamber run of a named gyro, as plain fields.

    One chamber run of a named gyro, as plain fields: the ``thermal_chamber_sim`` node's
    parameters and the committed bags' recipes (:meth:`run` streams it, :meth:`recording`
    simulates it whole; both give the same samples).
    """

    programme: str = 'paper_soak'
    """'paper_soak' (−35…35 °C, 7 set points), 'continuous_ramp' (low → high → low),
    'validation' (set points between the paper's: −30, −20, −5, 10, 20, 30 °C) or
    'ramp_only' (low ↔ high at the rates ramp_rates_c_per_min in turn, no soak or dwell)."""
    gyro_id: str = 'A-1'
    """Named gyro whose hidden bias law is simulated: A-1, A-2, B-1, B-2 or C-1."""
    seed: int = 1
    """Seed of the gyro's random streams (ARW, bias instability, sensor noise)."""
    soak_s: float = 0.0
    """Soak at each set point, s (0 = the programme's own: paper 3600, validation 2400)."""
    ramp_rate_c_per_min: float = 1.0
    """Soak programmes: rate of the ramps between set points, °C/min."""
    low_c: float = -35.0
    """continuous_ramp: lower end, °C."""
    high_c: float = 35.0
    """continuous_ramp: upper end, °C."""
    rate_c_per_min: float = 0.5
    """continuous_ramp: ramp rate, °C/min."""
    cycles: int = 1
    """continuous_ramp: number of up-and-down cycles."""
    dwell_s: float = 1800.0
    """continuous_ramp: dwell at each end, s."""
    ramp_rates_c_per_min: tuple[float, ...] = (0.5,)
    """ramp_only: the rate of each leg in turn (cycled), °C/min."""
    start_hot: bool = False
    """continuous_ramp and ramp_only: the chamber (and the gyro) start at high_c."""
    duration_s: float = 0.0
    """Length of the run, s (0 = the whole programme)."""
    pulse_rate_hz: float = 2.0
    """Rate of /gyro/pulses samples, Hz (hours of data need only a few Hz)."""
    temperature_rate_hz: float = 1.0
    """Rate of each sensor's /gyro/temperature samples, Hz."""
    sensor_read_intervals_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Each sensor's own reading interval (cavity_a, cavity_b, shell), s; 0 = every
    1/temperature_rate_hz. Any non-zero here or in sensor_clock_offsets_s puts every sensor
    on its own clock."""
    sensor_clock_offsets_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """When each sensor's clock takes its first reading, s after the start."""
    temperature_resolution_c: float = 0.01
    """Resolution (LSB) the temperature readings are rounded to, °C (e.g. 1/64)."""
    latitude_deg: float = 34.26
    """Site latitude, ° (the Earth rate along the vertical sense axis)."""
    start_time_ns: int = 1_700_000_000 * NS_PER_S
    """Stamp of the first sample, ns."""
    stuck_sensor: str = ''
    """Fault: sensor whose reading freezes from stuck_from_s on ('' = none)."""
    stuck_from_s: float = 0.0
    """Fault: when it freezes, s from the start."""
    dropout_sensor: str = ''
    """Fault: sensor that publishes nothing from dropout_start_s to dropout_end_s."""
    dropout_start_s: float = 0.0
    """Fault: start of the drop-out, s from the start."""
    dropout_end_s: float = 0.0
    """Fault: end of the drop-out, s from the start."""

    def __post_init__(self) -> None:
        """Reject a programme, gyro or sensor name the simulator does not know."""
        if self.programme not in PROGRAMMES:
            raise ValueError(f'programme = {self.programme!r}: use one of {", ".join(PROGRAMMES)}')
        if self.gyro_id not in GYRO_LAWS:
            raise ValueError(f'gyro_id = {self.gyro_id!r}: use one of {", ".join(GYRO_LAWS)}')
        for name in ('stuck_sensor', 'dropout_sensor'):
            if getattr(self, name) not in SENSOR_NAMES:
                raise ValueError(f'{name} = {getattr(self, name)!r}: use one of '
                                 f'{", ".join(repr(x) for x in SENSOR_NAMES)}')

    def gyro(self) -> ThermalGyroConfig:
        """The simulated gyro."""
        own = any(self.sensor_read_intervals_s) or any(self.sensor_clock_offsets_s)
        default_s = 1.0 / self.temperature_rate_hz
        return gyro_config(self.gyro_id, seed=self.seed, pulse_rate_hz=self.pulse_rate_hz,
                           temperature_rate_hz=self.temperature_rate_hz,
                           latitude_deg=self.latitude_deg,
                           temperature_resolution_c=self.temperature_resolution_c,
                           sensor_read_intervals_s=tuple(
                               float(v) or default_s for v in self.sensor_read_intervals_s)
                           if own else (),
                           sensor_clock_offsets_s=tuple(
                               float(v) for v in self.sensor_clock_offsets_s) if own else ())

    def chamber(self) -> ChamberProfile:
        """The chamber programme."""
        if self.programme == 'paper_soak':
            return paper_soak_programme(soak_s=self.soak_s or 3600.0,
                                        ramp_rate_c_per_min=self.ramp_rate_c_per_min)
        if self.programme == 'validation':
            return soak_programme(VALIDATION_SET_POINTS_C, soak_s=self.soak_s or 2400.0,
                                  ramp_rate_c_per_min=self.ramp_rate_c_per_min)
        if self.programme == 'ramp_only':
            return ramp_only_programme(self.low_c, self.high_c,
                                       rates_c_per_min=self.ramp_rates_c_per_min,
                                       duration_s=self.duration_s or 6 * 3600.0,
                                       start_hot=self.start_hot)
        return ramp_programme(self.low_c, self.high_c, rate_c_per_min=self.rate_c_per_min,
                              cycles=self.cycles, dwell_s=self.dwell_s,
                              start_c=self.high_c if self.start_hot else None)

    def faults(self) -> ThermalFaults:
        """The data faults."""
        return ThermalFaults(
            stuck_sensor=self.stuck_sensor or None, stuck_from_s=self.stuck_from_s,
            dropout_sensor=self.dropout_sensor or None,
            dropout_s=(self.dropout_start_s, self.dropout_end_s))

    @property
    def name(self) -> str:
        """Run name, as the scenario functions name theirs."""
        kind = {'paper_soak': 'paper_soak', 'continuous_ramp': 'ramp',
                'validation': 'validation', 'ramp_only': 'ramp_only'}[self.programme]
        return f'thermal_{kind}_{self.gyro_id}_{self.seed}'

    def run(self) -> ThermalRun:
        """The run, to be streamed in chunks."""
        return ThermalRun(self.gyro(), self.chamber(), name=self.name,
                          start_time_ns=self.start_time_ns,
                          duration_s=self.duration_s or None, faults=self.faults())

    def recording(self) -> ThermalRecording:
        """The whole run offline (the same samples as :meth:`run`)."""
        return simulate_thermal_run(self.gyro(), self.chamber(), name=self.name,
                                    start_time_ns=self.start_time_ns,
                                    duration_s=self.duration_s or None, faults=self.faults())
