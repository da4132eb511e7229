"""Offline FOG scenarios: whole recordings as arrays per stream, with the truth beside them.

(a) :func:`simulate_turntable` — IEEE Std 952 multi-rate calibration: constant-rate
    segments at several ± rates with accelerations between them; rate-table joint_states,
    zero-index events and the FOG output.
(b) :func:`simulate_mapping_and_self_cal` — the seed 001 procedure: the equivalence
    mapping on the turntable at 20, 20.01, 20.1 and 21 °/s, then, on the stopped table
    (static base), the injected ladder: one `/fog/injection` message per plateau.

The table is the shared :class:`sim_nodes.rate_table.RateTableSimulator` driven by a
:class:`sim_nodes.motion.MotionProfile`; the FOG samples its output at the table's sample
stamps. Both are streamed in chunks of ``chunk_samples``; the result does not depend on it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S
from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.front_end import FrontEnd
from sim_nodes.fog.gyro import FogSimulator
from sim_nodes.fog.paper import PAPER_PLATEAU_COUNT, PAPER_PLATEAU_STEP_DEG_S
from sim_nodes.fog.sensing import InjectionSchedule, SenseAxis
from sim_nodes.motion import MotionProfile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator

if TYPE_CHECKING:
    import numpy.typing as npt

    IntArray = npt.NDArray[np.int64]
    FloatArray = npt.NDArray[np.float64]

MAPPING_RATES_DEG_S = (20.0, 20.01, 20.1, 21.0)
"""Turntable rates of the paper's equivalence mapping, °/s."""
IEEE_RATES_DEG_S = (1.0, -1.0, 5.0, -5.0, 20.0, -20.0, 50.0, -50.0, 100.0, -100.0)
"""Default rates of the multi-rate turntable calibration, °/s."""


@dataclass(frozen=True, slots=True)
class TableSettings:
    """How the turntable and the sampling are run (shared by both scenarios)."""

    acceleration_deg_s2: float = 20.0
    """Table acceleration between segments, °/s²."""
    output_rate_hz: float = 1000.0
    """FOG output sample rate (= table sample rate), Hz."""
    joint_state_decimation: int = 5
    """Publish every n-th table sample on joint_states."""
    encoder_counts_per_rev: int = 2**23
    """Encoder resolution (0 = unquantised)."""
    zero_index_jitter_arcsec: float = 0.1
    """Zero-index timing jitter as an angle, ″."""
    zero_index_angle_deg: float = 37.0
    """Angle of the table's reference mark, °."""
    lead_s: float = 2.0
    """Time at rest before the first acceleration, s."""
    start_time_ns: int = 1_000_000_000_000
    """Stamp of the first sample, ns."""
    seed: int = 7
    """Seed of the table (index jitter)."""
    chunk_samples: int = 2000
    """Samples per simulation chunk (does not change the result)."""


@dataclass(frozen=True, slots=True)
class FogRecording:
    """Everything a FOG calibration receives from one run, plus the truth.

    Attributes:
        output_t_ns, output_counts: `/fog/output` stamps (int64 ns) and cumulative counts.
        injection_t_ns, injection_counts_s: `/fog/injection` stamps and values (counts/s).
        table_t_ns, table_angle_rad, table_rate_rad_s: `/rate_table/joint_states`.
        zero_index_ns: `/rate_table/zero_index` stamps.
        truth: true values (keys documented in :func:`truth_of`).
        self_cal_truth: (plateaus used, noise-free self-calibrated K counts/rad) pairs.
    """

    output_t_ns: IntArray
    output_counts: FloatArray
    injection_t_ns: IntArray
    injection_counts_s: FloatArray
    table_t_ns: IntArray
    table_angle_rad: FloatArray
    table_rate_rad_s: FloatArray
    zero_index_ns: IntArray
    truth: dict[str, float] = field(default_factory=dict)
    self_cal_truth: tuple[tuple[int, float], ...] = ()

    @property
    def duration_s(self) -> float:
        """Recorded span, s."""
        return float(self.output_t_ns[-1] - self.output_t_ns[0]) / NS_PER_S


def multi_rate_profile(rates_deg_s: tuple[float, ...], hold_s: float | tuple[float, ...],
                       acceleration_deg_s2: float, *, lead_s: float = 2.0,
                       tail_s: float = 2.0) -> tuple[MotionProfile, list[tuple[float, float]]]:
    """Rest, then for each rate an acceleration to it and a hold; decelerate and rest.

    Returns:
        the profile and each hold's (start, end) in s from the profile start.
    """
    holds = (hold_s,) * len(rates_deg_s) if isinstance(hold_s, (int, float)) else hold_s
    acc = math.radians(acceleration_deg_s2)
    durations, accels, spans = [lead_s], [0.0], []
    rate, t = 0.0, lead_s
    for target_deg, hold in zip(rates_deg_s, holds):
        target = math.radians(target_deg)
        if target != rate:
            durations.append(abs(target - rate) / acc)
            accels.append(math.copysign(acc, target - rate))
            t += durations[-1]
        durations.append(hold)
        accels.append(0.0)
        spans.append((t, t + hold))
        t += hold
        rate = target
    if rate:
        durations.append(abs(rate) / acc)
        accels.append(-math.copysign(acc, rate))
    durations.append(tail_s)
    accels.append(0.0)
    return MotionProfile(durations, accels), spans


def truth_of(config: FogConfig, *, mapping_rates_deg_s: tuple[float, ...] = MAPPING_RATES_DEG_S,
             plateau_step_counts_s: float = 0.0,
             plateau_count: int = 0) -> tuple[dict[str, float], tuple[tuple[int, float], ...]]:
    """What a calibration of this gyro should find (noise-free, from the model's statics).

    Keys: ``k_counts_per_rad`` (D/(nλ)); ``turntable_k_counts_per_rad`` (K·cos tilt);
    ``bias_rad_s``; ``earth_rate_along_axis_rad_s`` (vertical Earth rate · cos tilt);
    ``bias_plus_earth_rate_rad_s``; ``asymmetry_ppm``, ``quadratic_s_per_rad``,
    ``cubic_s2_per_rad2`` (as a turntable fit against table rate sees them);
    ``mapping_counts_per_rad`` (LS slope over the mapping rates);
    ``injection_gain_error``; ``self_cal_small_signal_k_counts_per_rad`` (the small-signal
    slope of output against injection times the mapping); with a ladder also
    ``self_cal_step_counts_s`` and the noise-free K over the first n plateaus.
    """
    sense = SenseAxis(config)
    k = config.scale_factor_counts_per_rad
    c = sense.cos_tilt
    earth = config.earth_rate_base_rad_s()[2] * c
    w = np.radians(np.asarray(mapping_rates_deg_s, dtype=np.float64))
    response = k * (c * w + sense.scale_factor_terms(c * w))
    k_map = float(np.polyfit(w, response, 1)[0])
    fe = FrontEnd(config)
    probe = 1e-3 * k
    a, _ = fe.balance(0.0, fe.injection_word(np.array([0.0, probe])))
    y = fe.output_rate_counts_s(0.0, a)
    small = float((y[1] - y[0]) / probe)
    truth = {
        'k_counts_per_rad': k,
        'turntable_k_counts_per_rad': k * c,
        'bias_rad_s': config.bias_rad_s,
        'earth_rate_along_axis_rad_s': earth,
        'bias_plus_earth_rate_rad_s': config.bias_rad_s + earth,
        'asymmetry_ppm': config.scale_factor_asymmetry_ppm,
        'quadratic_s_per_rad': config.scale_factor_quadratic_s_per_rad * c,
        'cubic_s2_per_rad2': config.scale_factor_cubic_s2_per_rad2 * c * c,
        'mapping_counts_per_rad': k_map,
        'injection_gain_error': config.injection_gain_error,
        'self_cal_small_signal_k_counts_per_rad': small * k_map,
    }
    table: tuple[tuple[int, float], ...] = ()
    if plateau_count and plateau_step_counts_s:
        from sim_nodes.fog.paper import ladder_k_ratios

        counts = tuple(range(2, plateau_count + 1))
        ratios = ladder_k_ratios(config, plateau_step_counts_s, counts)
        table = tuple((n, float(r) * k_map) for n, r in zip(counts, ratios))
        truth['self_cal_step_counts_s'] = plateau_step_counts_s
    return truth, table


@dataclass(frozen=True, slots=True)
class BenchChunk:
    """What the simulated bench publishes over one stretch of a run.

    Attributes:
        output_t_ns, output_counts: `/fog/output` stamps (int64 ns) and cumulative counts.
        table_t_ns, table_angle_rad, table_rate_rad_s: `/rate_table/joint_states` (every
            ``joint_state_decimation``-th sample of the run).
        zero_index_ns: `/rate_table/zero_index` stamps inside the stretch.
    """

    output_t_ns: IntArray
    output_counts: FloatArray
    table_t_ns: IntArray
    table_angle_rad: FloatArray
    table_rate_rad_s: FloatArray
    zero_index_ns: IntArray


class FogBench:
    """One scenario's bench: the rate table on its motion profile, the FOG and its injections.

    :meth:`chunks` streams the run (fresh simulators on every call, so it can be run again);
    the offline functions (:meth:`record`) and the ``fog_sim`` node both stream it, so they
    publish the same samples whatever the chunk size.
    """

    def __init__(self, config: FogConfig, table: TableSettings, profile: MotionProfile, *,
                 published: InjectionSchedule | None = None,
                 applied: InjectionSchedule | None = None, model: str = 'equivalent',
                 truth: dict[str, float] | None = None,
                 self_cal_truth: tuple[tuple[int, float], ...] = ()) -> None:
        """Set the bench up.

        Args:
            config: the gyro.
            table: turntable and sampling settings.
            profile: the table's motion.
            published: the `/fog/injection` messages (default: none).
            applied: what actually reaches the loop (default: what is published).
            model: FOG loop model (``'equivalent'`` or ``'loop'``).
            truth: what a calibration should find (:func:`truth_of`).
            self_cal_truth: (plateaus used, noise-free self-calibrated K) pairs.
        """
        self.config = config
        self.table = table
        self.profile = profile
        self.published = published or InjectionSchedule()
        self.applied = applied if applied is not None else self.published
        self.model = model
        self.truth = dict(truth or {})
        self.self_cal_truth = self_cal_truth
        self.table_config = RateTableConfig(
            encoder_counts_per_rev=table.encoder_counts_per_rev,
            zero_index_angle_deg=table.zero_index_angle_deg,
            zero_index_jitter_arcsec=table.zero_index_jitter_arcsec,
            sample_rate_hz=table.output_rate_hz,
            joint_state_decimation=table.joint_state_decimation,
            duration_s=profile.duration_s, start_time_ns=table.start_time_ns, seed=table.seed)

    @property
    def n_samples(self) -> int:
        """Output samples of the whole run."""
        return int(self.table_config.duration_s * self.table_config.sample_rate_hz) + 1

    @property
    def injection_messages(self) -> tuple[IntArray, FloatArray]:
        """The `/fog/injection` messages: stamps (ns) and values (counts/s)."""
        return self.published.messages

    def chunks(self, chunk_samples: int | None = None) -> Iterator[BenchChunk]:
        """Stream the run in chunks.

        Stream the run in chunks of ``chunk_samples`` output samples (default: the table
        settings'); the samples do not depend on the chunk size.
        """
        size = int(chunk_samples or self.table.chunk_samples)
        if size < 1:
            raise ValueError('chunk_samples must be at least 1')
        table_sim = RateTableSimulator(self.table_config, self.profile)
        fog = FogSimulator(self.config, model=self.model, injection=self.applied)
        dec = self.table.joint_state_decimation
        n_done = 0
        while not table_sim.finished:
            chunk = table_sim.step(size)
            counts = fog.step(chunk.t_ns, chunk.true_angle_rad, chunk.true_rate_rad_s)
            keep = (np.arange(n_done, n_done + len(chunk.t_ns)) % dec) == 0
            n_done += len(chunk.t_ns)
            yield BenchChunk(chunk.t_ns, counts, chunk.t_ns[keep], chunk.encoder_angle_rad[keep],
                             chunk.encoder_rate_rad_s[keep], chunk.zero_index_ns)

    def record(self) -> FogRecording:
        """The whole run as arrays per stream, with the truth."""
        parts = list(self.chunks())
        inj_t, inj_v = self.injection_messages

        def cat(name: str) -> np.ndarray:
            return np.concatenate([getattr(c, name) for c in parts])

        return FogRecording(
            output_t_ns=cat('output_t_ns'), output_counts=cat('output_counts'),
            injection_t_ns=inj_t, injection_counts_s=inj_v, table_t_ns=cat('table_t_ns'),
            table_angle_rad=cat('table_angle_rad'), table_rate_rad_s=cat('table_rate_rad_s'),
            zero_index_ns=cat('zero_index_ns'), truth=dict(self.truth),
            self_cal_truth=self.self_cal_truth)


def turntable_bench(config: FogConfig | None = None, *,
                    rates_deg_s: tuple[float, ...] = IEEE_RATES_DEG_S,
                    hold_s: float | tuple[float, ...] = 60.0,
                    table: TableSettings | None = None,
                    model: str = 'equivalent') -> FogBench:
    """The bench of scenario (a), IEEE Std 952 multi-rate.

    The bench of scenario (a), IEEE Std 952 multi-rate (arguments as
    :func:`simulate_turntable`).
    """
    config = config or FogConfig()
    table = table or TableSettings()
    profile, _ = multi_rate_profile(rates_deg_s, hold_s, table.acceleration_deg_s2,
                                    lead_s=table.lead_s)
    truth, _ = truth_of(config)
    return FogBench(config, table, profile, model=model, truth=truth)


def simulate_turntable(config: FogConfig | None = None, *,
                       rates_deg_s: tuple[float, ...] = IEEE_RATES_DEG_S,
                       hold_s: float | tuple[float, ...] = 60.0,
                       table: TableSettings | None = None,
                       model: str = 'equivalent') -> FogRecording:
    """Scenario (a): IEEE Std 952 multi-rate turntable calibration.

    Args:
        config: the gyro (default :class:`FogConfig`).
        rates_deg_s: constant rates in order, °/s.
        hold_s: time at each rate (one value or one per rate), s.
        table: turntable and sampling settings.
        model: FOG loop model (``'equivalent'`` or ``'loop'``).
    """
    return turntable_bench(config, rates_deg_s=rates_deg_s, hold_s=hold_s, table=table,
                           model=model).record()


@dataclass(frozen=True, slots=True)
class SelfCalLadder:
    """The injected ladder of the self-calibration phase (seed 001 §3–4)."""

    plateau_count: int = PAPER_PLATEAU_COUNT
    """Plateaus, the first at zero injection."""
    plateau_step_deg_s: float = PAPER_PLATEAU_STEP_DEG_S
    """Injection step between plateaus, as °/s of equivalent rate (converted with K)."""
    plateau_s: float = 10.0
    """Duration of each plateau, s (one value; see ``plateau_durations_s`` to vary)."""
    plateau_durations_s: tuple[float, ...] = ()
    """Per-plateau durations, s (overrides ``plateau_s`` when given)."""
    settle_s: float = 5.0
    """Time the table rests after stopping before the ladder starts, s."""
    silent_plateaus: tuple[int, ...] = ()
    """Plateaus whose message is published but never reaches the loop (a fault)."""
    end_with_zero: bool = True
    """Publish a final zero injection after the last plateau (a last zero plateau)."""

    def durations(self) -> tuple[float, ...]:
        """Duration of each plateau, s."""
        return self.plateau_durations_s or (self.plateau_s,) * self.plateau_count

    def step_counts_s(self, config: FogConfig) -> float:
        """The step in counts/s, from the gyro's K."""
        return math.radians(self.plateau_step_deg_s) * config.scale_factor_counts_per_rad


def simulate_mapping_and_self_cal(
        config: FogConfig | None = None, *,
        mapping_rates_deg_s: tuple[float, ...] | None = MAPPING_RATES_DEG_S,
        mapping_hold_s: float = 60.0, ladder: SelfCalLadder | None = None,
        table: TableSettings | None = None, model: str = 'equivalent') -> FogRecording:
    """Scenario (b): equivalence mapping on the turntable, then the ladder on a static base.

    Args:
        config: the gyro (default :class:`FogConfig`, front end fitted to Table 1).
        mapping_rates_deg_s: mapping rates, °/s (None: no mapping phase, a fault).
        mapping_hold_s: time at each mapping rate, s.
        ladder: the injected plateaus.
        table: turntable and sampling settings.
        model: FOG loop model.
    """
    return mapping_self_cal_bench(config, mapping_rates_deg_s=mapping_rates_deg_s,
                                  mapping_hold_s=mapping_hold_s, ladder=ladder, table=table,
                                  model=model).record()


def mapping_self_cal_bench(
        config: FogConfig | None = None, *,
        mapping_rates_deg_s: tuple[float, ...] | None = MAPPING_RATES_DEG_S,
        mapping_hold_s: float = 60.0, ladder: SelfCalLadder | None = None,
        table: TableSettings | None = None, model: str = 'equivalent') -> FogBench:
    """The bench of scenario (b), mapping then ladder.

    The bench of scenario (b), mapping then ladder (arguments as
    :func:`simulate_mapping_and_self_cal`).
    """
    config = config or FogConfig()
    ladder = ladder or SelfCalLadder()
    table = table or TableSettings()
    durations = ladder.durations()
    ladder_s = sum(durations)
    rates = tuple(mapping_rates_deg_s or ())
    profile, _ = multi_rate_profile(rates, mapping_hold_s, table.acceleration_deg_s2,
                                    lead_s=table.lead_s,
                                    tail_s=ladder.settle_s + ladder_s + max(durations))
    static_start_s = profile.duration_s - (ladder.settle_s + ladder_s + max(durations))
    step = ladder.step_counts_s(config)
    t_ns = table.start_time_ns + int(round((static_start_s + ladder.settle_s) * NS_PER_S))
    published = InjectionSchedule()
    applied = InjectionSchedule()
    for i, d in enumerate(durations):
        published.add(t_ns, i * step)
        applied.add(t_ns, 0.0 if i in ladder.silent_plateaus else i * step)
        t_ns += int(round(d * NS_PER_S))
    if ladder.end_with_zero:
        published.add(t_ns, 0.0)
        applied.add(t_ns, 0.0)
    truth, k_table = truth_of(config, mapping_rates_deg_s=rates or MAPPING_RATES_DEG_S,
                              plateau_step_counts_s=step, plateau_count=ladder.plateau_count)
    return FogBench(config, table, profile, published=published, applied=applied, model=model,
                    truth=truth, self_cal_truth=k_table)
