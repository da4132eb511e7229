"""Property: the thermal model covers the hidden law.

Property: on any chamber bench a user may have, the thermal calibration gives a model whose
bias is the generator's hidden law within its stated uncertainty, or one line saying why not;
never a traceback (issue 16).

The benches come from ``thermal_bench_physics`` (written for the tests from the physics,
sharing nothing with sim_nodes): soaks, ramps only, or a mix; starting hot or cold, switched
on cold or settled; a hidden law of H, Ḣ and both gradients; pulses at 1 Hz – 10 kHz; each
temperature sensor read at 0.01 Hz up to the pulse rate on its own clock (offset, rate
error), with noise and an LSB, lagging its part; drop-outs and a stuck sensor.

Two calibrations per bench:

- as a user runs it (default settings, stepwise selection, held-out check): a model whose
  terms keep a first power beside its higher powers — then compensation of the same
  recording runs, and a drop-out longer than ``max_temperature_gap_s`` is named — or a
  refusal in one line, allowed only when it names a sensor that failed; over the examples,
  the model's stated uncertainty (covariance and model error u_m in quadrature, METHODS
  §D.3 (17g)) covers the law at points of the true trajectory about 60–80 % (±1σ) and
  ≥ 90 % (±2σ) of the time, within the binomial tolerance of the example count (the points
  of one run are correlated: one example counts once);
- with the law's own terms as the candidates (all kept): the model's bias at those points
  is within 4.5 of its standard uncertainties of the law.

:func:`test_default_model_uncertainty_covers_the_hidden_law_over_benches` and
:func:`test_stated_uncertainty_covers_the_hidden_law_over_benches` check the coverage on a
fixed set of benches (default settings; the law's own terms). Before u_m, the default
models' ±1σ / ±2σ covered the law at 52 % / 84 % of the points (36 benches).

CI runs a derandomized handful with pulses up to 200 Hz and sensors up to 10 Hz;
``GYRO_CALIB_STRESS=1`` runs many more with pulses up to 10 kHz and sensors up to 50 Hz.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from thermal_bench_physics import (
    DEG_H,
    K_RAD,
    LATITUDE_DEG,
    T0_NS,
    Bench,
    draw_bench,
    pulse_chunks,
    temperatures,
    truth,
)

from gyro_calib.errors import GyroCalibError
from gyro_calib.thermal.calibrator import ThermalCalibrator, ThermalSettings
from gyro_calib.thermal.compensate import CompensationReducer, compensate_reduced
from gyro_calib.thermal.terms import main_effects, parse_term

STRESS = os.environ.get('GYRO_CALIB_STRESS') == '1'
MAX_PULSE_HZ = 10_000.0 if STRESS else 200.0
MAX_SENSOR_HZ = 50.0 if STRESS else 10.0


@st.composite
def benches(draw: st.DrawFn) -> Bench:
    pulse_hz = 10 ** draw(st.floats(0.0, math.log10(MAX_PULSE_HZ)))
    sensor_hz = 10 ** draw(st.floats(-2.0, math.log10(min(pulse_hz, MAX_SENSOR_HZ))))
    return draw_bench(draw(st.integers(0, 2**31 - 1)),
                      kind=draw(st.sampled_from(['soaks', 'ramps', 'mix'])),
                      hot=draw(st.booleans()), pulse_rate_hz=pulse_hz,
                      sensor_rate_hz=sensor_hz, shell=draw(st.booleans()),
                      dropout=draw(st.booleans()), stuck=draw(st.integers(0, 3)) == 0)


def _record(bench: Bench) -> tuple:  # type: ignore[type-arg]
    tr, variables = truth(bench)
    return tr, variables, temperatures(bench, tr)


def _calibrate(bench: Bench, record: tuple, s: ThermalSettings) -> ThermalCalibrator:  # type: ignore[type-arg]
    """Feed the calibrator as a bag reader does: pulses chunk by chunk, then temperatures."""
    tr, _, (tt, tv, ti) = record
    cal = ThermalCalibrator(s)
    for t_ns, counts in pulse_chunks(bench, tr):
        cal.extend_pulses(t_ns, counts)
        cal.process()
    cal.extend_temperatures(tt, tv, ti)
    cal.process(flush=True)
    if cal._error is not None:
        raise cal._error
    return cal


def _settings(**kw: object) -> ThermalSettings:
    return ThermalSettings(scale_factor_rad_per_pulse=K_RAD, latitude_deg=LATITUDE_DEG,
                           **kw)  # type: ignore[arg-type]


def _z_on_the_trajectory(bench: Bench, tr, variables, cal) -> np.ndarray:  # type: ignore[no-untyped-def]  # noqa: ANN001
    """(model − law)/σ_model along the true trajectory.

    (model − law)/σ_model every 300 s along the true trajectory, where the fit used the
    data and H lies in the calibrated range (model and law at the same true H, Ḣ, ΔT).
    """
    model, rep = cal.model(), cal.report
    t_mid = (rep.t_mid_ns - T0_NS) / 1e9
    used = np.isfinite(rep.bias_model_rad_s).astype(float)
    at = np.arange(600.0, bench.duration_s - 60.0, 300.0)
    idx = at[np.interp(at, t_mid, used) > 0.99].astype(int)
    h = variables['H'][idx]
    idx = idx[(h >= model.h_range_c[0]) & (h <= model.h_range_c[1])]
    value, std = model.bias_rad_s(variables['H'][idx], variables['Hdot'][idx],
                                  variables['dTab'][idx], variables['dTcs'][idx], check=False)
    return (value - tr.law_rad_s[idx]) / std


def _with_true_terms(bench: Bench, record: tuple) -> np.ndarray:  # type: ignore[type-arg]
    s = _settings(candidate_terms=bench.law.terms('shell' in bench.sensors), p_enter=0.998,
                  p_remove=0.999, validation_fraction=0.0)
    return _z_on_the_trajectory(bench, record[0], record[1], _calibrate(bench, record, s))


def _assert_coverage(zs: list[np.ndarray]) -> None:
    """The pooled z cover ±1σ and ±2σ as they should.

    ±1σ in 60–80 %, ±2σ ≥ 90 % of the pooled points, each bound widened by twice the
    binomial standard deviation for as many independent trials as benches (the points of
    one run share its model: a bench counts once).
    """
    n = len(zs)
    z = np.abs(np.concatenate(zs))
    c1, c2 = float(np.mean(z < 1)), float(np.mean(z < 2))
    t1 = 2 * math.sqrt(0.683 * 0.317 / n)
    t2 = 2 * math.sqrt(0.954 * 0.046 / n)
    assert 0.60 - t1 <= c1 <= 0.80 + t1, (c1, n)
    assert c2 >= 0.90 - t2, (c2, n)


def _hierarchical(terms: tuple[str, ...]) -> bool:
    """Every variable of a term of order > 1 has its first power in the model."""
    return all(n in terms for t in terms for n in main_effects(parse_term(t)))


def test_any_bench_gives_the_hidden_law_within_its_uncertainty_or_one_line_why_not() -> None:
    zs: list[np.ndarray] = []

    @settings(max_examples=60 if STRESS else 10, deadline=None, derandomize=True,
              database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(benches())
    def run(bench: Bench) -> None:
        z = _check_bench(bench)
        if z is not None:
            zs.append(z)

    run()
    assert len(zs) >= 5, f'only {len(zs)} example(s) gave a model'
    _assert_coverage(zs)


def _check_bench(bench: Bench) -> np.ndarray | None:
    """One example: (model − law)/σ, or None when refused.

    One example; returns (model − law)/σ of the default model along the trajectory, or
    None when the calibration was refused (for a named sensor fault).
    """
    record = _record(bench)
    tr, variables, (tt, tv, ti) = record
    try:
        cal = _calibrate(bench, record, _settings())
        model = cal.model()
    except GyroCalibError as exc:
        assert '\n' not in str(exc) and str(exc).endswith('.'), str(exc)
        faulty = [n for n, s in bench.sensors.items()
                  if s.dropout_s is not None or s.stuck_from_s is not None]
        assert any(n in str(exc) for n in faulty), f'refused, not for a sensor fault: {exc}'
        return None
    assert _hierarchical(model.terms), model.terms
    z_default = _z_on_the_trajectory(bench, tr, variables, cal)
    reasons = [r.reason for r in cal.rejections]
    reducer = CompensationReducer(model)
    for t_ns, counts in pulse_chunks(bench, tr):
        reducer.extend_pulses(t_ns, counts)
        reducer.process()
    reducer.extend_temperatures(tt, tv, ti)
    reducer.process(flush=True)
    rep = compensate_reduced(reducer, out_of_range='skip')
    assert math.isfinite(rep.bias_stability_compensated.value)
    # a gap longer than max_temperature_gap_s in a sensor's readings is named
    if not any(s.stuck_from_s is not None for s in bench.sensors.values()):
        for name in bench.sensors:
            t = tt[ti == name]
            if len(t) > 1 and np.max(np.diff(t)) > 120e9:
                assert any(f'temperature sensor {name} gave no finite reading' in r
                           for r in reasons), (name, reasons)
    z = _with_true_terms(bench, record)
    assert len(z) >= 5
    assert np.max(np.abs(z)) < 4.5, np.round(z, 1)
    return z_default


def _fixed_bench(i: int) -> Bench:
    kinds = ('soaks', 'ramps', 'mix')
    rng = np.random.default_rng([7, i])
    return draw_bench(100 + i, kind=kinds[i % 3], hot=bool(i % 2),
                      pulse_rate_hz=float(rng.choice([1.0, 2.0, 12.5, 50.0])),
                      sensor_rate_hz=float(10 ** rng.uniform(-2, 0)),
                      shell=bool(rng.uniform() < 0.7), dropout=bool(rng.uniform() < 0.3),
                      stuck=bool(rng.uniform() < 0.2))


def test_default_model_uncertainty_covers_the_hidden_law_over_benches() -> None:
    """The default model's uncertainty covers the hidden law.

    Default settings (stepwise selection, held-out check) over 24 benches (72 with
    GYRO_CALIB_STRESS=1): the covariance and the model error u_m together cover the law
    (:func:`_assert_coverage`; measured 66 % / 90 % on these 24, 70 % / 91 % on 72;
    the covariance alone: 52 % / 84 %).
    """
    zs = []
    for i in range(72 if STRESS else 24):
        bench = _fixed_bench(i)
        record = _record(bench)
        zs.append(_z_on_the_trajectory(bench, record[0], record[1],
                                       _calibrate(bench, record, _settings())))
    _assert_coverage(zs)


def test_held_out_check_keeps_h_beside_its_higher_powers_on_ramp_only_benches() -> None:
    """The held-out check keeps H beside its higher powers.

    Two ramp-only benches where the held-out check used to drop H and keep H², H³
    (and Ḣ, Ḣ², dTab): a curve pinned flat at the centre of the range. H stays now, and
    the model covers the law along the run.
    """
    for i, sensor_hz in ((8, 0.03996850924495578), (34, 0.027252954819273107)):
        bench = draw_bench(1000 + i, kind='ramps', hot=False, pulse_rate_hz=1.0,
                           sensor_rate_hz=sensor_hz, shell=True, dropout=False, stuck=False)
        record = _record(bench)
        cal = _calibrate(bench, record, _settings())
        terms = cal.model().terms
        assert 'H' in terms and 'H^3' in terms and _hierarchical(terms), terms
        assert 'H' not in cal.report.pruned
        z = _z_on_the_trajectory(bench, record[0], record[1], cal)
        assert np.max(np.abs(z)) < 2.5, np.round(z, 1)


def test_stated_uncertainty_covers_the_hidden_law_over_benches() -> None:
    """The stated uncertainty covers the hidden law over benches.

    Coverage over 12 benches (soaks, ramps, mixes; hot and cold; sparse sensors with LSB,
    drop-outs, stuck sensors): the law inside ±1σ about 68 %, ±2σ about 95 % of the time
    (the points of one run are correlated: bounds allow for ~12 independent runs).
    """
    zs = []
    for i in range(36 if STRESS else 12):
        bench = _fixed_bench(i)
        zs.append(_with_true_terms(bench, _record(bench)))
    z = np.abs(np.concatenate(zs))
    assert 0.55 <= np.mean(z < 1) <= 0.85, np.mean(z < 1)
    assert np.mean(z < 2) >= 0.88, np.mean(z < 2)


def test_the_generator_is_the_physics_it_claims() -> None:
    """The generator is the physics it claims.

    A settled gyro in a soak: H = air + rises, Ḣ = 0, gradients = the rises' difference;
    the law is evaluated on those.
    """
    bench = draw_bench(3, kind='soaks', hot=False, pulse_rate_hz=2.0, sensor_rate_hz=1.0,
                       shell=True, dropout=False, stuck=False)
    tr, variables = truth(bench)
    end = int(bench.knots_t_s[1])  # the chamber leaves its start after a while
    settled = bench.warm_start
    if settled:
        air = bench.knots_c[0]
        assert tr.shell[end // 2] == pytest.approx(air + bench.rise_shell_c, abs=1e-9)
        assert variables['dTab'][end // 2] == pytest.approx(
            bench.rise_a_c - bench.rise_b_c, abs=1e-9)
    assert np.all(np.abs(np.diff(variables['H'])) < 0.05)  # °C per s: a lagged chamber
    assert tr.law_rad_s[0] == pytest.approx(bench.law.bias_deg_h(
        variables['H'][:1], variables['Hdot'][:1], variables['dTab'][:1],
        variables['dTcs'][:1])[0] * DEG_H)
