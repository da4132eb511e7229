"""The streaming ThermalCalibrator.

The streaming ThermalCalibrator: paper-like runs, chunking invariance, bounded memory,
results and hand-off.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gyro_calib.estimate import Estimate
from gyro_calib.thermal.calibrator import ThermalCalibrator, ThermalSettings, calibrate_thermal
from gyro_calib.thermal.model import ThermalBiasModel
from sim_nodes.thermal.scenarios import (
    ThermalRecording,
    continuous_ramp_scenario,
    gyro_config,
    paper_soak_scenario,
)

DEG_H = np.pi / 180 / 3600


def _settings(rec: ThermalRecording, **kw) -> ThermalSettings:  # noqa: ANN003
    truth = rec.scenario['truth']
    return ThermalSettings(scale_factor_rad_per_pulse=truth['scale_factor_rad_per_pulse'],
                           latitude_deg=truth['latitude_deg'], gyro_id=rec.gyro_id, **kw)


def _calibrate(rec: ThermalRecording, **kw) -> ThermalCalibrator:  # noqa: ANN003
    return calibrate_thermal(rec.pulse_t_ns, rec.pulse_counts, rec.temperature_t_ns,
                             rec.temperature_c, rec.temperature_frame_id, _settings(rec, **kw))


@pytest.fixture(scope='module')
def paper_run() -> ThermalRecording:
    return paper_soak_scenario('A-1', seed=1, pulse_rate_hz=2.0)


@pytest.fixture(scope='module')
def paper_cal(paper_run: ThermalRecording) -> ThermalCalibrator:
    return _calibrate(paper_run, max_h_power=4)


@pytest.fixture(scope='module')
def short_ramp() -> ThermalRecording:
    gyro = gyro_config('B-2', seed=4)
    return continuous_ramp_scenario(gyro=gyro, low_c=-10.0, high_c=20.0, rate_c_per_min=0.5,
                                    dwell_s=900.0)


def test_paper_run_recovers_the_quartic_of_gyro_a1(paper_cal: ThermalCalibrator) -> None:
    """The paper run recovers the quartic of gyro A-1.

    A-1's hidden law is the quartic through the paper's points plus a small Ḣ term and
    a periodic term no model holds: stepwise keeps every power of H up to 4.
    """
    rep = paper_cal.report
    assert {'H', 'H^2', 'H^3', 'H^4'} <= set(rep.model.terms)
    assert rep.model.h_range_c[0] == pytest.approx(-35.0, abs=0.5)
    assert rep.model.h_range_c[1] == pytest.approx(37.2, abs=0.5)
    hold_raw = rep.holdout_stability_raw.value
    hold_comp = rep.holdout_stability_compensated.value
    assert hold_comp < 0.23 * hold_raw  # ≥ 77 % better on data held out of the fit
    assert len(rep.snr) == 7 and all(p.snr_denoised_db > p.snr_raw_db + 15 for p in rep.snr)


def test_paper_run_model_predicts_the_true_static_law(paper_cal: ThermalCalibrator,
                                                      paper_run: ThermalRecording) -> None:
    """At settled temperatures the model bias is the law.

    At settled temperatures the model bias is the law within its stated uncertainty
    plus the periodic term (0.002 °/h) and bias instability averaged over the run.
    """
    model = paper_cal.model()
    law = gyro_config('A-1').law
    h = np.linspace(-30.0, 35.0, 14)
    z = np.zeros_like(h)
    truth = law.bias_deg_h_at(h, z, z, z) * DEG_H
    value, std = model.bias_rad_s(h, 0.0, model.scaling.centre['dTab'],
                                  model.scaling.centre['dTcs'])
    assert np.all(np.abs(value - truth) < 4 * std + 0.006 * DEG_H)


def test_soak_style_fits_one_point_per_settled_set_point(paper_run: ThermalRecording) -> None:
    cal = _calibrate(paper_run, calibration_style='soak', candidate_terms='static',
                     max_h_power=4)
    rep = cal.report
    assert rep.fit.n == 7 and rep.fit.covariance_kind == 'wls'
    assert rep.model.terms == ('H', 'H^2', 'H^3', 'H^4')
    assert np.allclose(rep.rows.variables['H'],
                       np.array([-35, -25, -15, 0, 15, 25, 35]) + 2.2, atol=0.6)
    assert rep.fit.birge_ratio < 2.5
    assert 'thermal_holdout_bias_stability_raw_rad_s' in cal.missing()


def test_chunked_lagging_streams_give_identical_results(short_ramp: ThermalRecording) -> None:
    rec = short_ramp
    one = _calibrate(rec)
    cal = ThermalCalibrator(_settings(rec))
    rng = np.random.default_rng(3)
    p_cuts = np.sort(rng.choice(len(rec.pulse_t_ns), 40, replace=False))
    t_cuts = np.sort(rng.choice(len(rec.temperature_t_ns), 25, replace=False))
    p_parts = np.split(np.arange(len(rec.pulse_t_ns)), p_cuts)
    t_parts = np.split(np.arange(len(rec.temperature_t_ns)), t_cuts)
    while p_parts or t_parts:  # pulses run ahead of the temperatures, then the reverse
        for _ in range(int(rng.integers(0, 4))):
            if p_parts:
                i = p_parts.pop(0)
                cal.extend_pulses(rec.pulse_t_ns[i], rec.pulse_counts[i])
        if t_parts and (not p_parts or rng.uniform() < 0.5):
            i = t_parts.pop(0)
            cal.extend_temperatures(rec.temperature_t_ns[i], rec.temperature_c[i],
                                    rec.temperature_frame_id[i])
        cal.process()
    cal.process(flush=True)
    assert cal.handoff_extra() == one.handoff_extra()
    assert cal.results() == one.results()


def test_single_samples_give_the_same_model_as_arrays() -> None:
    gyro = gyro_config('A-2', seed=9, pulse_rate_hz=2.0)
    rec = continuous_ramp_scenario(gyro=gyro, low_c=0.0, high_c=15.0, rate_c_per_min=0.5,
                                   dwell_s=600.0)
    kw = dict(candidate_terms='H,H^2,Hdot', validation_fraction=0.0, fit_block_s=20.0)
    arrays = _calibrate(rec, **kw)
    cal = ThermalCalibrator(_settings(rec, **kw))
    merged = sorted([(int(t), 0, float(c), '') for t, c in zip(rec.pulse_t_ns, rec.pulse_counts)]
                    + [(int(t), 1, float(c), str(f)) for t, c, f in zip(
                        rec.temperature_t_ns, rec.temperature_c, rec.temperature_frame_id)])
    for i, (t, kind, value, frame) in enumerate(merged):
        if kind == 0:
            cal.add_pulses(t, value)
        else:
            cal.add_temperature(t, value, frame)
        if i % 5000 == 0:
            cal.process()
    cal.process(flush=True)
    assert cal.handoff_extra() == arrays.handoff_extra()


def test_memory_stays_bounded_while_streaming() -> None:
    gyro = gyro_config('A-1', seed=2, pulse_rate_hz=200.0)
    rec = continuous_ramp_scenario(gyro=gyro, low_c=0.0, high_c=10.0, rate_c_per_min=1.0,
                                   dwell_s=600.0)
    cal = ThermalCalibrator(_settings(rec))
    step = 20_000
    for a in range(0, len(rec.pulse_t_ns), step):
        cal.extend_pulses(rec.pulse_t_ns[a:a + step], rec.pulse_counts[a:a + step])
        t_hi = rec.pulse_t_ns[min(a + step, len(rec.pulse_t_ns)) - 1]
        sel = (rec.temperature_t_ns <= t_hi) & (rec.temperature_t_ns > rec.pulse_t_ns[a] - 1)
        cal.extend_temperatures(rec.temperature_t_ns[sel], rec.temperature_c[sel],
                                rec.temperature_frame_id[sel])
        cal.process()
        # what is held spans at most one interval plus the reorder window (1 s + 1 s)
        assert len(cal._pulses.buffer) <= 200 * (1.0 + 1.0) + 2
        assert all(len(r.buffer) <= 3 * (1 + 1) + 1 for r in cal._temps.values())
    rows = len(cal._pulses.arrays()[0])
    assert rows == pytest.approx(rec.duration_s, abs=3)  # one small row per second


def test_results_are_absent_until_the_end_then_keyed_for_the_handoff(
        short_ramp: ThermalRecording) -> None:
    rec = short_ramp
    cal = ThermalCalibrator(_settings(rec))
    cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    cal.extend_temperatures(rec.temperature_t_ns, rec.temperature_c, rec.temperature_frame_id)
    cal.process()
    assert cal.results() == {}
    assert 'process(flush=True)' in cal.missing()['thermal_coefficient_const_rad_s']
    lines = cal.process(flush=True)
    assert any(line.startswith('thermal model fitted') for line in lines)
    res = cal.results()
    assert all(isinstance(v, Estimate) and k.startswith('thermal_') for k, v in res.items())
    for term in cal.model().terms:
        key = 'thermal_coefficient_' + term.lower().replace('^', '').replace('*', '_') + '_rad_s'
        assert res[key].std_uncertainty > 0
    assert all(k.startswith('thermal_') for k in cal.handoff_extra())


def test_model_dict_round_trips_exactly(paper_cal: ThermalCalibrator) -> None:
    model = paper_cal.model()
    again = ThermalBiasModel.from_dict(model.to_dict())
    assert again == model
    h = np.array([-20.0, 0.0, 30.0])
    assert np.array_equal(again.bias_rad_s(h, 1e-3)[0], model.bias_rad_s(h, 1e-3)[0])


def test_model_uncertainty_grows_outside_the_data(paper_cal: ThermalCalibrator) -> None:
    """The model uncertainty grows outside the data.

    The coefficient part x·C·xᵀ grows beyond the data; the model error u_m (METHODS
    (17g)) is the same everywhere, in quadrature.
    """
    model = paper_cal.model()
    inside = np.linspace(*model.h_range_c, 9)
    _, std_in = model.bias_rad_s(inside, 0.0)
    _, std_out = model.bias_rad_s(np.array([model.h_range_c[1] + 10.0]), 0.0, check=False)
    u_m = model.model_error_rad_s
    coef_in = np.sqrt(std_in**2 - u_m**2)
    coef_out = math.sqrt(std_out[0] ** 2 - u_m**2)
    assert np.all(coef_in > 0) and coef_out > 3 * coef_in.max()
    assert np.all(std_in >= u_m) and std_out[0] > std_in.max()


def test_denoising_changes_the_fitted_model_by_less_than_its_uncertainty(
        short_ramp: ThermalRecording) -> None:
    kw = dict(candidate_terms='H,H^2,Hdot,dTab', validation_fraction=0.0, p_enter=0.998,
              p_remove=0.999)  # the same terms either way: compare their coefficients
    on = _calibrate(short_ramp, **kw).report.fit
    off = _calibrate(short_ramp, denoise=False, **kw).report.fit
    assert on.terms == off.terms
    assert np.all(np.abs(on.coefficients - off.coefficients) < 1.0 * off.std_uncertainties)


def test_unknown_sensor_names_are_counted_and_reported(short_ramp: ThermalRecording) -> None:
    rec = short_ramp
    cal = ThermalCalibrator(_settings(rec))
    cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    frame = np.where(rec.temperature_frame_id == 'shell', 'mount', rec.temperature_frame_id)
    cal.extend_temperatures(rec.temperature_t_ns, rec.temperature_c, frame)
    lines = cal.process(flush=True)
    assert any("frame_id 'mount'" in line for line in lines)
    assert 'shell' not in cal.model().sensors


def test_refit_every_gives_running_models_and_the_same_final_one(
        short_ramp: ThermalRecording) -> None:
    rec = short_ramp
    settings = dataclasses.replace(_settings(rec), refit_every_s=1800.0)
    cal = ThermalCalibrator(settings)
    n = len(rec.pulse_t_ns)
    fits = 0
    for a in range(0, n, n // 6):
        sel = slice(a, a + n // 6)
        cal.extend_pulses(rec.pulse_t_ns[sel], rec.pulse_counts[sel])
        lo, hi = rec.pulse_t_ns[sel][0], rec.pulse_t_ns[sel][-1]
        tsel = (rec.temperature_t_ns >= lo) & (rec.temperature_t_ns <= hi)
        cal.extend_temperatures(rec.temperature_t_ns[tsel], rec.temperature_c[tsel],
                                rec.temperature_frame_id[tsel])
        fits += any('fitted' in line for line in cal.process())
    cal.process(flush=True)
    assert fits >= 2
    final = calibrate_thermal(rec.pulse_t_ns, rec.pulse_counts, rec.temperature_t_ns,
                              rec.temperature_c, rec.temperature_frame_id, settings)
    assert cal.handoff_extra() == final.handoff_extra()


def test_plots_are_written_where_asked(paper_cal: ThermalCalibrator, paper_run: ThermalRecording,
                                       tmp_path) -> None:  # noqa: ANN001
    from gyro_calib.thermal.compensate import compensate
    from gyro_calib.thermal.plots import plot_thermal

    rep = compensate(paper_cal.model(), paper_run.pulse_t_ns, paper_run.pulse_counts,
                     paper_run.temperature_t_ns, paper_run.temperature_c,
                     paper_run.temperature_frame_id, gyro_id='A-1')
    paths = plot_thermal(paper_cal, tmp_path / 'plots', validation=rep)
    assert [p.name for p in paths] == ['thermal_bias_vs_h.png', 'thermal_residuals.png',
                                       'thermal_before_after.png', 'thermal_allan.png']
    assert all(p.stat().st_size > 10_000 for p in paths)
