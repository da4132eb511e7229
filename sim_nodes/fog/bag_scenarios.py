"""The FOG scenario bags: named bench runs, their MCAP bags and what a calibration must find.

A :class:`FogScenario` is one run of the simulated FOG bench (METHODS §B): the gyro
(:class:`~sim_nodes.fog.config.FogConfig`), the turntable and sampling
(:class:`~sim_nodes.fog.scenarios.TableSettings`) and the procedure — ``turntable`` (IEEE
Std 952 multi-rate) or ``mapping_self_cal`` (the equivalence mapping on the turntable, then
the injected ladder on a static base). The ``fog_sim`` node runs the same scenarios live
(:func:`scenario_from_parameters`), so a recorded live run and a committed bag hold the same
samples.

Faults here are physics or procedure, never edits of the truth: a plateau shorter than the
loop needs to settle, injection messages that never reach the loop (no output response),
a staircase driven far beyond the front end's range (the loop saturates and slips fringes).
Data faults (NaN, duplicate or out-of-order stamps) are applied by tests to a recording
and written with :func:`write_recording_bag`.

Expectations (``<name>.expected.yaml``): the truth, noise-free, as each fit sees it
(:func:`turntable_fit_truth`, :func:`self_cal_truth`); ``tolerance_sigma``: a result must
lie within that many of its *stated* standard uncertainties of the truth; ``max_std``: the
stated uncertainty may not exceed 1.5 × the floor predicted from the angle random walk and
the output quantisation for the spans the procedure gives (:func:`predicted_line_std`),
so a calibration cannot pass by overstating its uncertainty; counts and rejection reasons.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib import topics
from gyro_calib.bagio import BagMessage, ContractMessages, topic_sort_key, write_bag
from sim_nodes import scenario_files
from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.front_end import FrontEnd
from sim_nodes.fog.scenarios import (
    IEEE_RATES_DEG_S,
    MAPPING_RATES_DEG_S,
    FogBench,
    FogRecording,
    SelfCalLadder,
    TableSettings,
    mapping_self_cal_bench,
    turntable_bench,
)
from sim_nodes.fog.sensing import SenseAxis
from sim_nodes.scenario_files import named

KINDS = ('turntable', 'mapping_self_cal')
"""The procedures a FOG scenario runs."""

GUARD_S = 0.5
"""Segment guard of the calibration's default settings (FogSettings.segment_guard_s), s."""
FIT_HALF_WIDTH_S = 0.1
"""Local count-fit half-width of the default settings, s."""
MIN_FIT_TRANSITIONS = 8.0
"""Count transitions a local fit needs before it is widened (default settings)."""
MAX_FIT_HALF_WIDTH_S = 1.0
"""Widest local count fit (default settings), s."""


@dataclass(frozen=True, slots=True)
class FogScenario:
    """One run of the FOG bench and what a calibration of it must find.

    Attributes:
        name: file-system friendly name (the bag is ``<name>/``).
        description: one sentence for humans.
        kind: ``turntable`` or ``mapping_self_cal``.
        gyro: the FOG.
        table: turntable and sampling.
        rates_deg_s, hold_s: the turntable procedure (kind ``turntable``), °/s and s.
        mapping_rates_deg_s, mapping_hold_s: the mapping phase (kind ``mapping_self_cal``;
            empty: no mapping phase), °/s and s.
        ladder: the injected ladder (kind ``mapping_self_cal``).
        model: FOG loop model (``equivalent`` or ``loop``).
        expected: regression expectations beyond the truth: counts and rejection reasons.
    """

    name: str
    description: str
    kind: str
    gyro: FogConfig = field(default_factory=FogConfig)
    table: TableSettings = field(default_factory=TableSettings)
    rates_deg_s: tuple[float, ...] = IEEE_RATES_DEG_S
    hold_s: float = 60.0
    mapping_rates_deg_s: tuple[float, ...] = MAPPING_RATES_DEG_S
    mapping_hold_s: float = 60.0
    ladder: SelfCalLadder = field(default_factory=SelfCalLadder)
    model: str = 'equivalent'
    expected: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Reject an unknown procedure."""
        if self.kind not in KINDS:
            raise ValueError(f'scenario kind {self.kind!r} is not one of {KINDS}')

    def bench(self) -> FogBench:
        """The streamed bench of this run (table, FOG, injections, truth)."""
        if self.kind == 'turntable':
            return turntable_bench(self.gyro, rates_deg_s=self.rates_deg_s, hold_s=self.hold_s,
                                   table=self.table, model=self.model)
        return mapping_self_cal_bench(self.gyro,
                                      mapping_rates_deg_s=self.mapping_rates_deg_s or None,
                                      mapping_hold_s=self.mapping_hold_s, ladder=self.ladder,
                                      table=self.table, model=self.model)

    def procedure(self) -> dict[str, Any]:
        """The procedure's parameters (for the bag's metadata)."""
        if self.kind == 'turntable':
            return {'rates_deg_s': list(self.rates_deg_s), 'hold_s': self.hold_s}
        ladder = {k: list(v) if isinstance(v, tuple) else v
                  for k, v in dataclasses.asdict(self.ladder).items()}
        return {'mapping_rates_deg_s': list(self.mapping_rates_deg_s),
                'mapping_hold_s': self.mapping_hold_s, 'ladder': ladder}

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows about the bench (calibration inputs, not the answer)."""
        return {'latitude_deg': self.gyro.latitude_deg}

    def truth(self) -> dict[str, float]:
        """The simulator's truth, noise-free, as the calibration's fits see it."""
        bench = self.bench()
        truth = dict(bench.truth)
        if self.kind == 'turntable':
            for key in ('mapping_counts_per_rad', 'injection_gain_error',
                        'self_cal_small_signal_k_counts_per_rad'):
                truth.pop(key, None)  # no mapping, no injection in this procedure
            truth.update(turntable_fit_truth(self.gyro, self.rates_deg_s))
        truth['angle_random_walk_rad_sqrt_s'] = self.gyro.angle_random_walk_rad_sqrt_s
        levels = self.expected.get('linear_range_levels')
        if levels:
            step = self.ladder.step_counts_s(self.gyro)
            truth['self_cal_k_counts_per_rad'] = self_cal_truth(
                self.gyro, [i * step for i in levels], truth['mapping_counts_per_rad'])
            truth['self_cal_linear_range_rad_s'] = (max(levels) * step
                                                    / truth['mapping_counts_per_rad'])
            truth['self_cal_minus_turntable_counts_per_rad'] = (
                truth['self_cal_k_counts_per_rad'] - truth['turntable_k_counts_per_rad'])
        return {k: float(v) for k, v in truth.items()}

    def max_std(self) -> dict[str, float]:
        """Largest stated uncertainties a correct calibration gives.

        Largest stated uncertainties a correct calibration gives: 1.5 × the floor
        predicted from ARW and quantisation for the procedure's shortest possible spans.
        """
        hz = self.table.output_rate_hz
        if self.kind == 'turntable':
            k_std, bias_std = predicted_line_std(self.gyro, self.rates_deg_s, self.hold_s, hz,
                                                 weighted=False)
            return {'fog_scale_factor_counts_per_rad': 1.5 * k_std,
                    'fog_bias_rad_s': 1.5 * bias_std}
        if not self.mapping_rates_deg_s:
            return {}
        k_std, _ = predicted_line_std(self.gyro, self.mapping_rates_deg_s, self.mapping_hold_s,
                                      hz, weighted=True)
        return {'fog_mapping_scale_factor_counts_per_rad': 1.5 * k_std}

    def expected_results(self) -> dict[str, Any]:
        """The expectations written beside the committed bag."""
        return {'scenario': self.name, 'kind': self.kind, 'truth': self.truth(),
                'tolerance_sigma': 5.0, 'max_std': self.max_std(), **self.expected}

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: parameters, seeds, procedure, truth."""
        return scenario_description(self.kind, self.gyro, self.table, self.procedure(),
                                    self.truth(), name=self.name, description=self.description,
                                    model=self.model)


def scenario_description(kind: str, gyro: FogConfig, table: TableSettings,
                         procedure: dict[str, Any], truth: dict[str, float], *,
                         name: str = '', description: str = '',
                         model: str = 'equivalent') -> dict[str, Any]:
    """The FOG bench's /sim/scenario part and bag metadata (the same for node and bags)."""
    out: dict[str, Any] = {'kind': f'fog_{kind}', 'fog': dataclasses.asdict(gyro),
                           'fog_table': dataclasses.asdict(table), 'fog_procedure': procedure,
                           'fog_model': model, 'bench': {'latitude_deg': gyro.latitude_deg},
                           'truth': {k: float(v) for k, v in truth.items()}}
    if name:
        out['name'] = name
    if description:
        out['description'] = description
    return out


def _axis_outputs(config: FogConfig, rates_deg_s: Sequence[float]) -> np.ndarray:
    """Noise-free output rate at table rates ω (counts/s, bias and Earth rate left out)."""
    sense = SenseAxis(config)
    w = sense.cos_tilt * np.radians(np.asarray(rates_deg_s, dtype=np.float64))
    return config.scale_factor_counts_per_rad * (w + sense.scale_factor_terms(w))


def turntable_fit_truth(config: FogConfig, rates_deg_s: Sequence[float]) -> dict[str, float]:
    """What the turntable fits (each rate one point) give on noise-free outputs at these rates.

    Keys: ``line_k_counts_per_rad`` (LS line slope), ``nonlinearity_ppm`` (max |residual| /
    full scale), and with five or more rates ``quadratic_seen_s_per_rad`` /
    ``cubic_seen_s2_per_rad2`` (K₂/K₁, K₃/K₁ of the cubic; an asymmetry shows in them too).
    """
    w = np.radians(np.asarray(rates_deg_s, dtype=np.float64))
    y = _axis_outputs(config, rates_deg_s)
    line = np.polyfit(w, y, 1)
    resid = y - np.polyval(line, w)
    out = {'line_k_counts_per_rad': float(line[0]),
           'nonlinearity_ppm': float(np.max(np.abs(resid)) / np.max(np.abs(y)) * 1e6)}
    if len(set(rates_deg_s)) >= 5:
        k3, k2, k1, _ = np.polyfit(w, y, 3)
        out['quadratic_seen_s_per_rad'] = float(k2 / k1)
        out['cubic_seen_s2_per_rad2'] = float(k3 / k1)
    return out


def self_cal_truth(config: FogConfig, levels_counts_s: Sequence[float],
                   mapping_counts_per_rad: float) -> float:
    """Noise-free self-calibrated K over plateaus, counts/rad.

    Noise-free self-calibrated K over plateaus at these injection levels (counts/rad):
    the LS slope of the balanced static outputs against J, times the true mapping.
    """
    fe = FrontEnd(config)
    j = np.asarray(levels_counts_s, dtype=np.float64)
    a, _ = fe.balance(0.0, fe.injection_word(j))
    y = fe.output_rate_counts_s(0.0, a)
    return float(np.polyfit(j, y, 1)[0] * mapping_counts_per_rad)


def shortest_span_s(rate_deg_s: float, hold_s: float) -> float:
    """The shortest span a segment at this rate is measured over, s.

    The shortest span a segment at this rate can be measured over (s): whole revolutions
    between zero-index events (one fewer than fit when the mark may fall late), else the hold
    less the guards.
    """
    usable = hold_s - 2.0 * GUARD_S
    rev_s = 360.0 / abs(rate_deg_s) if rate_deg_s else math.inf
    whole = math.floor(usable / rev_s) if math.isfinite(rev_s) else 0
    if whole >= 2:
        return (whole - 1) * rev_s
    if whole == 1:
        return min(rev_s, usable)
    return usable


def predicted_line_std(config: FogConfig, rates_deg_s: Sequence[float], hold_s: float,
                       output_hz: float, *, weighted: bool) -> tuple[float, float]:
    """Standard uncertainties of K and of the bias of the line fit.

    Standard uncertainties of K (counts/rad) and of the bias (rad/s) of the line fit over
    segments at these rates, from the angle random walk and the output quantisation alone:
    var(R_i) = N²/T_i + 2·q²/T_i², q² = 1/(12·looks) (one look per count transition in a
    local fit window, at most one per sample), T_i the shortest span (:func:`shortest_span_s`).
    ``weighted``: segments weighted by T_i (the mapping fit), else one point each. With rates
    of both signs the bias is the intercept of the two-slope (asymmetry) fit, as the
    calibration takes it.
    """
    k = config.scale_factor_counts_per_rad
    n_c2 = (config.angle_random_walk_rad_sqrt_s * k) ** 2
    w = np.radians(np.asarray(rates_deg_s, dtype=np.float64))
    spans = np.array([shortest_span_s(r, hold_s) for r in rates_deg_s])
    var = []
    for rate_rad_s, t in zip(w, spans):
        out = abs(rate_rad_s * k)
        h = FIT_HALF_WIDTH_S
        if out * 2 * h < MIN_FIT_TRANSITIONS:
            h = min(MAX_FIT_HALF_WIDTH_S, h * MIN_FIT_TRANSITIONS / max(out * 2 * h, 1.0))
        looks = min(2 * h * output_hz, 1.0 + out * 2 * h)
        var.append(n_c2 / t + 2.0 / (12.0 * looks) / t**2)
    weights = spans if weighted else np.ones_like(spans)

    def cov(x: np.ndarray) -> np.ndarray:
        op = np.linalg.solve(x.T @ (weights[:, None] * x), x.T * weights)
        out: np.ndarray = (op * np.asarray(var)) @ op.T
        return out

    line = cov(np.column_stack((w, np.ones_like(w))))
    bias_var = line[1, 1]
    if np.any(w > 0) and np.any(w < 0) and len(set(w.tolist())) >= 3:
        # the calibration takes the bias from the two-slope (asymmetry) fit then
        two = cov(np.column_stack((np.maximum(w, 0.0), np.minimum(w, 0.0), np.ones_like(w))))
        bias_var = two[2, 2]
    return float(math.sqrt(line[0, 0])), float(math.sqrt(bias_var) / k)


# -- the committed scenarios ---------------------------------------------------------------------
_TABLE = TableSettings(output_rate_hz=200.0)
# 200 Hz output: a 1 kHz run of this length would not fit in 5 MB; the count quantisation
# still averages in the ±0.1 s local fits (≥ 40 samples) and the ARW floor is unchanged.
_SHORT_MAPPING: dict[str, Any] = {'mapping_hold_s': 15.0}

def _null_time_constant_s(config: FogConfig) -> float:
    """The loop's first-order time constant about the null balance, s (front-end physics)."""
    fe = FrontEnd(config)
    return float(fe.loop_time_constant_s(fe.error_word_slope(0.0)))


# A slow loop read slowly (odd but legal): integrator gain 7e-4 (τ ≈ 0.074 s at null, 180 ×
# the default loop's), 50 Hz output. Each injection step leaves a transient of a few τ at the
# start of its plateau, which the calibration must find and skip.
_SLOW_LOOP = dataclasses.replace(FogConfig(), integrator_gain=7e-4, seed=101)

SCENARIOS: dict[str, FogScenario] = {s.name: s for s in (
    FogScenario(
        'fog_turntable', 'IEEE Std 952 multi-rate turntable calibration: ±1, ±5, ±20, ±50, '
        '±100 °/s held 30 s each, a 30 ppm scale-factor asymmetry, 200 Hz output.',
        'turntable', dataclasses.replace(FogConfig(), scale_factor_asymmetry_ppm=30.0, seed=51),
        dataclasses.replace(_TABLE, seed=52), hold_s=30.0,
        expected={'segments': 10, 'plateaus': 0, 'rejections': 0,
                  'results': ['fog_scale_factor_counts_per_rad', 'fog_bias_rad_s',
                              'fog_nonlinearity_ppm', 'fog_asymmetry_ppm',
                              'fog_scale_factor_quadratic_s_per_rad',
                              'fog_scale_factor_cubic_s2_per_rad2',
                              'fog_angle_random_walk_rad_per_sqrt_s'],
                  'missing_reasons': {'fog_self_cal_scale_factor_counts_per_rad':
                                      'no /fog/injection messages'}}),
    FogScenario(
        'fog_mapping_self_cal', "The paper's procedure: the equivalence mapping at 20, 20.01, "
        '20.1 and 21 °/s (30 s each), then 55 injected plateaus of 4 s and a last zero '
        'plateau on the stopped table; the front end fitted to Table 1, 200 Hz output.',
        'mapping_self_cal', dataclasses.replace(FogConfig(), seed=61),
        dataclasses.replace(_TABLE, seed=62), mapping_hold_s=30.0,
        ladder=SelfCalLadder(plateau_s=4.0),
        expected={'segments': 4, 'plateaus': 56, 'rejections': 1,
                  'rejection_reasons': ['overlaps a self-calibration injection'],
                  'linear_range_levels': [0, 0, 1, 2, 3],
                  'results': ['fog_scale_factor_counts_per_rad',
                              'fog_mapping_scale_factor_counts_per_rad',
                              'fog_self_cal_scale_factor_counts_per_rad',
                              'fog_self_cal_linear_range_rad_s',
                              'fog_self_cal_nonlinearity_ppm',
                              'fog_self_cal_small_signal_scale_factor_counts_per_rad',
                              'fog_self_cal_minus_turntable_scale_factor_counts_per_rad']}),
    FogScenario(
        'fog_fault_short_plateau', 'Mapping (15 s per rate), then 9 plateaus of 6 s of which '
        'the fourth lasts 0.2 s: shorter than the loop needs to settle and be measured.',
        'mapping_self_cal', dataclasses.replace(FogConfig(), seed=71),
        dataclasses.replace(_TABLE, seed=72), **_SHORT_MAPPING,
        ladder=SelfCalLadder(plateau_count=9,
                             plateau_durations_s=(6.0, 6.0, 6.0, 0.2, 6.0, 6.0, 6.0, 6.0, 6.0)),
        expected={'segments': 4, 'plateaus': 9, 'rejections': 2,
                  'rejection_reasons': ['shorter than the loop needs to settle'],
                  'linear_range_levels': [0, 0, 1, 2],
                  'results': ['fog_self_cal_scale_factor_counts_per_rad']}),
    FogScenario(
        'fog_fault_silent_injection', 'Mapping (15 s per rate), then 9 plateaus of 6 s; the '
        'fifth injection message is published but never reaches the loop (no output response).',
        'mapping_self_cal', dataclasses.replace(FogConfig(), seed=81),
        dataclasses.replace(_TABLE, seed=82), **_SHORT_MAPPING,
        ladder=SelfCalLadder(plateau_count=9, plateau_s=6.0, silent_plateaus=(4,)),
        expected={'segments': 4, 'plateaus': 9, 'rejections': 2,
                  'rejection_reasons': ['the output does not follow the injection'],
                  'linear_range_levels': [0, 0, 1, 2],
                  'results': ['fog_self_cal_scale_factor_counts_per_rad']}),
    FogScenario(
        'fog_fault_saturating_staircase', 'Mapping (15 s per rate), then a staircase of 63 '
        'plateaus of 1.5 s, driven beyond the front end: the loop saturates, slips fringes '
        'and relocks; those plateaus are rejected, the linear range is kept.',
        'mapping_self_cal', dataclasses.replace(FogConfig(), seed=91),
        dataclasses.replace(_TABLE, seed=92), **_SHORT_MAPPING,
        ladder=SelfCalLadder(plateau_count=63, plateau_s=1.5),
        expected={'segments': 4, 'plateaus': 60, 'rejections': 5,
                  'rejection_reasons': ['the output does not follow the injection',
                                        'did not return to the same state'],
                  'linear_range_levels': [0, 1, 2],
                  'results': ['fog_self_cal_scale_factor_counts_per_rad']}),
    FogScenario(
        'fog_slow_loop_low_rate', 'A slow closed loop (integrator gain 7e-4: τ ≈ 0.074 s at '
        'null) read at 50 Hz: mapping (30 s per rate), then 16 plateaus of 4 s, the loop still '
        'settling for the first few tenths of a second of each.',
        'mapping_self_cal', _SLOW_LOOP,
        dataclasses.replace(_TABLE, output_rate_hz=50.0, joint_state_decimation=1, seed=102),
        mapping_hold_s=30.0, ladder=SelfCalLadder(plateau_count=16, plateau_s=4.0),
        expected={'segments': 4, 'plateaus': 17, 'rejections': 1,
                  'rejection_reasons': ['overlaps a self-calibration injection'],
                  'linear_range_levels': [0, 0, 1],
                  'loop_time_constant_at_null_s': _null_time_constant_s(_SLOW_LOOP),
                  'results': ['fog_scale_factor_counts_per_rad',
                              'fog_mapping_scale_factor_counts_per_rad',
                              'fog_self_cal_scale_factor_counts_per_rad',
                              'fog_self_cal_small_signal_scale_factor_counts_per_rad']}),
)}
"""The committed FOG scenarios (``bags/<name>``)."""


# -- bags ----------------------------------------------------------------------------------------
_JOINTS = {topics.FOG_OUTPUT: topics.FOG_JOINT, topics.FOG_INJECTION: topics.FOG_INJECTION_JOINT,
           topics.RATE_TABLE_JOINT_STATES: topics.RATE_TABLE_JOINT,
           topics.RATE_TABLE_ZERO_INDEX: topics.RATE_TABLE_JOINT}


def recording_messages(rec: FogRecording) -> Iterator[BagMessage]:
    """A recording's streams as bag messages.

    A recording's streams as bag messages: log time = header stamp, in stamp order (ties in
    contract topic order). Samples out of stamp order in the arrays (a data fault) keep the
    log time of their slot: they arrived then.
    """
    streams: list[tuple[str, np.ndarray, np.ndarray | None, np.ndarray | None]] = [
        (topics.FOG_OUTPUT, rec.output_t_ns, rec.output_counts, None),
        (topics.FOG_INJECTION, rec.injection_t_ns, rec.injection_counts_s, None),
        (topics.RATE_TABLE_JOINT_STATES, rec.table_t_ns, rec.table_angle_rad,
         rec.table_rate_rad_s),
        (topics.RATE_TABLE_ZERO_INDEX, rec.zero_index_ns, None, None)]
    slots, prio, kind, row = [], [], [], []
    for k, (topic, t, _, _) in enumerate(streams):
        t = np.asarray(t, dtype=np.int64)
        slots.append(np.maximum.accumulate(t) if len(t) else t)
        prio.append(np.full(len(t), topic_sort_key(topic)))
        kind.append(np.full(len(t), k))
        row.append(np.arange(len(t)))
    slot, pri = np.concatenate(slots), np.concatenate(prio)
    kinds, rows = np.concatenate(kind), np.concatenate(row)
    cdr = ContractMessages()
    for i in np.lexsort((rows, pri, slot)).tolist():
        topic, t, pos, vel = streams[kinds[i]]
        r = int(rows[i])
        joint = _JOINTS[topic]
        if pos is None:
            data = cdr.header(int(t[r]), joint)
        else:
            data = cdr.joint_state(int(t[r]), joint, float(pos[r]),
                                   None if vel is None else float(vel[r]))
        yield BagMessage(topic, int(slot[i]), data)


def write_recording_bag(rec: FogRecording, path: str | Path, *,
                        scenario: dict[str, Any] | None = None,
                        omit: Sequence[str] = ()) -> Path:
    """Write a recording to a new bag at ``path`` (topics in ``omit`` left out)."""
    messages = (m for m in recording_messages(rec) if m.topic not in omit)
    write_bag(path, messages, scenario=scenario)
    return Path(path)


def write_scenario_bag(scenario: FogScenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    scenario = named(scenario, SCENARIOS)
    rec = scenario.bench().record()
    return write_recording_bag(rec, path, scenario=scenario.description_dict())


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/fog/bag_scenarios.py')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""


# -- the live node's scenario ------------------------------------------------------------------
def scenario_from_parameters(kind: str, gyro: FogConfig, table: TableSettings, *,
                             rates_deg_s: Sequence[float] = IEEE_RATES_DEG_S,
                             hold_s: float = 60.0,
                             mapping_rates_deg_s: Sequence[float] = MAPPING_RATES_DEG_S,
                             mapping_hold_s: float = 60.0,
                             ladder: SelfCalLadder | None = None,
                             model: str = 'equivalent') -> FogScenario:
    """The scenario a ``fog_sim`` node runs from its parameters (same bench as the bags)."""
    return FogScenario('live', '', kind, gyro, table, tuple(float(r) for r in rates_deg_s),
                       float(hold_s), tuple(float(r) for r in mapping_rates_deg_s),
                       float(mapping_hold_s), ladder or SelfCalLadder(), model)
