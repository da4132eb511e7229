"""The dither calibrator recovers a, its components and θ_d; refuses bad input.

Its results do not depend on how the streams are chunked.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gyro_calib.dither.calibrator import (
    KEY_A,
    KEY_AMPLITUDE,
    KEY_AMPLITUDE_PULSES,
    KEY_CONING,
    KEY_CONING_TOTAL,
    KEY_FREQUENCY,
    KEY_Y,
    KEY_Z,
    DitherCalibrator,
    calibrate_dither,
)
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.errors import ConfigError
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import DitherRecording, simulate_dither_pair, simulate_dither_run
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60
K = ARCMIN / 60
NOISE_FREE = DitheredGyroConfig(quantise=False, angle_random_walk_deg_sqrt_h=0.0,
                                rocking_arcsec_per_arcmin=0.0)
NOISE_FREE_TABLE = VibrationTableConfig(encoder_counts_per_rev=0)
SHORT = DitherBenchConfig(duration_s=10.0)
# the noise-free grid reaches far below the quantisation floor: judge it on a wide limit
WIDE = DitherSettings(scale_factor_rad_per_pulse=K, rocking_treatment='none',
                      max_misalignment_arcmin=600.0)


@pytest.mark.parametrize('a_arcmin', [1.0, 5.0, 20.0, 60.0])
@pytest.mark.parametrize('psi_deg', [0.0, 35.0, 90.0, 200.0])
def test_noise_free_run_recovers_a_components_and_dither_to_1_percent(
        a_arcmin: float, psi_deg: float) -> None:
    gyro = dataclasses.replace(NOISE_FREE, misalignment_arcmin=a_arcmin, ia_azimuth_deg=psi_deg)
    runs = simulate_dither_pair(gyro, NOISE_FREE_TABLE, SHORT)
    res = calibrate_dither(runs['z'], runs['y'], settings=WIDE).results()
    truth = runs['z'].truth
    a = truth['misalignment_rad']
    assert res[KEY_A].value == pytest.approx(a, rel=0.01)
    assert res[KEY_Z].value == pytest.approx(truth['misalignment_z_rad'], abs=0.01 * a)
    assert res[KEY_Y].value == pytest.approx(truth['misalignment_y_rad'], abs=0.01 * a)
    assert res[KEY_AMPLITUDE].value == pytest.approx(truth['dither_amplitude_rad'], rel=0.01)
    assert res[KEY_FREQUENCY].value == pytest.approx(truth['dither_frequency_hz'], rel=1e-6)


def _feed_in_chunks(cal: DitherCalibrator, rec: DitherRecording, rng: np.random.Generator,
                    lag: int) -> None:
    """Pulses and table in random chunk sizes, the table lagging by ``lag`` chunks."""
    def cuts(n: int) -> list[int]:
        c = np.sort(rng.choice(np.arange(1, n), size=25, replace=False))
        return [0, *c.tolist(), n]

    p, t = cuts(len(rec.pulse_t_ns)), cuts(len(rec.table_t_ns))
    for i in range(len(p) - 1 + lag):
        if i < len(p) - 1:
            s = slice(p[i], p[i + 1])
            cal.extend_pulses(rec.pulse_t_ns[s], rec.pulse_counts[s])
        if 0 <= i - lag < len(t) - 1:
            s = slice(t[i - lag], t[i - lag + 1])
            cal.extend_table_states(rec.table_t_ns[s], rec.table_angle_rad[s],
                                    rec.table_rate_rad_s[s], rec.frame_id)
        cal.process()
    cal.end_recording()


@pytest.fixture(scope='module')
def noisy_pair() -> dict[str, DitherRecording]:
    gyro = DitheredGyroConfig(misalignment_arcmin=30.0, ia_azimuth_deg=30.0, seed=5)
    return simulate_dither_pair(gyro, VibrationTableConfig(rate_amplitude_rad_s=20.0),
                                DitherBenchConfig(duration_s=16.0))


@pytest.mark.parametrize('seed', [1, 2])
def test_results_do_not_depend_on_chunking_or_stream_lag(
        noisy_pair: dict[str, DitherRecording], seed: int) -> None:
    settings = DitherSettings(scale_factor_rad_per_pulse=K, max_misalignment_arcmin=60.0)
    batch = calibrate_dither(noisy_pair['z'], noisy_pair['y'], settings=settings)
    streamed = DitherCalibrator(settings)
    rng = np.random.default_rng(seed)
    for axis in ('z', 'y'):
        _feed_in_chunks(streamed, noisy_pair[axis], rng, lag=seed)
    assert streamed.results() == batch.results()
    assert len(batch.results()) == 7


def test_sample_by_sample_input_equals_array_input(noisy_pair: dict[str, DitherRecording]) -> None:
    settings = DitherSettings(scale_factor_rad_per_pulse=K, max_misalignment_arcmin=60.0)
    rec = noisy_pair['z']
    batch = calibrate_dither(rec, settings=settings)
    live = DitherCalibrator(settings)
    j = 0
    for i, (t, c) in enumerate(zip(rec.pulse_t_ns.tolist(), rec.pulse_counts.tolist())):
        live.add_pulses(t, c)
        while j < len(rec.table_t_ns) and rec.table_t_ns[j] <= t:
            live.add_table_state(int(rec.table_t_ns[j]), float(rec.table_angle_rad[j]),
                                 float(rec.table_rate_rad_s[j]), 'z')
            j += 1
        if i % 4000 == 0:
            live.process()
    live.end_recording()
    assert live.results() == batch.results()


def test_one_orientation_gives_its_component_and_says_a_needs_the_other(
        noisy_pair: dict[str, DitherRecording]) -> None:
    cal = calibrate_dither(noisy_pair['z'], settings=DitherSettings(
        scale_factor_rad_per_pulse=K, max_misalignment_arcmin=60.0))
    res, missing = cal.results(), cal.missing()
    assert KEY_Z in res and KEY_A not in res and KEY_Y not in res
    assert 'needs both orientations' in missing[KEY_A] and 'Y' in missing[KEY_A]
    assert 'needs a' in missing[KEY_CONING]
    truth = noisy_pair['z'].truth['effective_z_rad']
    assert abs(res[KEY_Z].value - truth) < 3 * res[KEY_Z].std_uncertainty


def test_without_scale_factor_the_dither_amplitude_is_in_pulses_and_says_so(
        noisy_pair: dict[str, DitherRecording]) -> None:
    cal = calibrate_dither(noisy_pair['z'], noisy_pair['y'],
                           settings=DitherSettings(max_misalignment_arcmin=60.0))
    res, missing = cal.results(), cal.missing()
    assert KEY_AMPLITUDE not in res and KEY_CONING_TOTAL not in res
    assert res[KEY_AMPLITUDE_PULSES].value == pytest.approx(
        noisy_pair['z'].truth['dither_amplitude_pulses'], rel=1e-3)
    assert 'scale factor K' in missing[KEY_AMPLITUDE]
    assert 'needs θ_d in rad' in missing[KEY_CONING_TOTAL]
    assert KEY_A in res and KEY_CONING in res


def _rejections(cal: DitherCalibrator) -> str:
    return ' | '.join(r.reason for r in cal.rejections)


def test_stripped_output_without_dither_line_is_refused_with_its_reason() -> None:
    gyro = dataclasses.replace(NOISE_FREE, quantise=True, dither_amplitude_arcmin=0.0)
    rec = simulate_dither_run(gyro, VibrationTableConfig(), SHORT)
    cal = calibrate_dither(rec, settings=DitherSettings(scale_factor_rad_per_pulse=K))
    assert KEY_Z not in cal.results() and KEY_FREQUENCY not in cal.results()
    assert 'no dither line' in _rejections(cal) and 'dither-stripped' in _rejections(cal)
    assert 'dither-stripped' in cal.missing()[KEY_Z]


@pytest.mark.parametrize(('table_hz', 'what'), [
    (407.3172 / 3, 'table harmonic 2·f_z'),   # sub-harmonic: f_d − f_z = 2·f_z
    (406.0, 'zero frequency'),                # next to the dither frequency
])
def test_vibration_frequency_on_the_dither_or_a_harmonic_is_refused(table_hz: float,
                                                                    what: str) -> None:
    rec = simulate_dither_run(dataclasses.replace(NOISE_FREE, quantise=True),
                              VibrationTableConfig(frequency_hz=table_hz), SHORT)
    cal = calibrate_dither(rec, settings=DitherSettings(scale_factor_rad_per_pulse=K,
                                                        table_band_max_hz=420.0))
    assert KEY_Z not in cal.results()
    text = _rejections(cal)
    assert 'too close to the dither frequency' in text and what in text


def test_sample_rate_too_low_for_the_dither_is_refused() -> None:
    rec = simulate_dither_run(NOISE_FREE, VibrationTableConfig(),
                              DitherBenchConfig(duration_s=10.0, sample_rate_hz=500.0,
                                                table_decimation=1))
    cal = calibrate_dither(rec, settings=DitherSettings(scale_factor_rad_per_pulse=K))
    assert KEY_Z not in cal.results() and KEY_FREQUENCY not in cal.results()
    assert 'cannot resolve a dither' in _rejections(cal) and 'sample faster' in _rejections(cal)


def test_table_amplitude_too_small_reports_the_component_with_what_would_resolve_it() -> None:
    gyro = DitheredGyroConfig(misalignment_arcmin=3.0)
    rec = simulate_dither_run(gyro, VibrationTableConfig(rate_amplitude_rad_s=0.2), SHORT)
    cal = calibrate_dither(rec, settings=dataclasses.replace(WIDE, rocking_treatment='bound'))
    assert KEY_Z in cal.results()  # reported, however wide (issue 16)
    note = cal.summary().unresolved['z']
    assert 'cannot be told from zero' in note and 'A ≥' in note
    assert 'min at this amplitude' in note
    parts = cal.result_parts()[KEY_Z]
    assert parts['interval'][0] == 0.0 and parts['std_statistical'] > 0


def test_table_that_does_not_move_is_refused() -> None:
    rec = simulate_dither_run(NOISE_FREE, VibrationTableConfig(rate_amplitude_rad_s=0.0), SHORT)
    cal = calibrate_dither(rec, settings=DitherSettings(scale_factor_rad_per_pulse=K))
    assert KEY_Z not in cal.results()
    assert 'not vibrating' in _rejections(cal)


def test_pulses_without_table_states_are_refused_at_the_end(
        noisy_pair: dict[str, DitherRecording]) -> None:
    cal = DitherCalibrator(DitherSettings(scale_factor_rad_per_pulse=K))
    rec = noisy_pair['z']
    cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    assert cal.process() == []  # waits for the table stream
    lines = cal.end_recording()
    assert any('joint_states' in line and 'missing' in line for line in lines)
    assert KEY_Z not in cal.results()


def test_unknown_frame_id_is_ignored_with_its_reason(
        noisy_pair: dict[str, DitherRecording]) -> None:
    cal = DitherCalibrator(DitherSettings(scale_factor_rad_per_pulse=K))
    rec = noisy_pair['z']
    cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    cal.extend_table_states(rec.table_t_ns, rec.table_angle_rad, rec.table_rate_rad_s, 'x')
    lines = cal.end_recording()
    assert any("frame_id 'x' ignored" in line and '"z" or "y"' in line for line in lines)


def test_nothing_measured_says_why_for_every_key() -> None:
    missing = DitherCalibrator().missing()
    assert set(missing) >= {KEY_A, KEY_Z, KEY_Y, KEY_FREQUENCY, KEY_AMPLITUDE, KEY_CONING}
    assert all(text.endswith('.') for text in missing.values())


@pytest.mark.parametrize(('field', 'value'), [('block_s', 0.0), ('rocking_treatment', 'guess'),
                                              ('spectrum_samples', 1000), ('min_blocks', 1)])
def test_settings_refuse_invalid_values_naming_the_field(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        DitherSettings(**{field: value})


def test_rocking_model_needs_the_scale_factor() -> None:
    with pytest.raises(ConfigError, match='scale_factor_rad_per_pulse'):
        DitherSettings(rocking_treatment='model')


@pytest.fixture(scope='module')
def rocking_pair() -> dict[str, DitherRecording]:
    gyro = dataclasses.replace(NOISE_FREE, misalignment_arcmin=30.0, ia_azimuth_deg=50.0,
                               rocking_arcsec_per_arcmin=1 / 35, rocking_phase_rad=1.0)
    return simulate_dither_pair(gyro, NOISE_FREE_TABLE, SHORT)


def test_in_phase_rocking_shifts_the_components_unless_modelled(
        rocking_pair: dict[str, DitherRecording]) -> None:
    truth = rocking_pair['z'].truth
    ignored = calibrate_dither(rocking_pair['z'], rocking_pair['y'], settings=WIDE)
    comps, _ = ignored.components()
    # without a model the output carries the effective components (a shifted by the rocking)
    assert comps['z'].signed_rad == pytest.approx(truth['effective_z_rad'], rel=1e-3)
    assert -comps['y'].signed_rad == pytest.approx(-truth['effective_y_rad'], rel=1e-3)
    assert comps['y'].quadrature_rad == pytest.approx(truth['quadrature_y_rad'], rel=1e-3)
    assert abs(ignored.results()[KEY_A].value / truth['misalignment_rad'] - 1) > 0.1
    u, w = truth['rocking_xz_rad'], truth['rocking_xy_rad']
    model = dataclasses.replace(
        WIDE, rocking_treatment='model', rocking_in_phase_xz_arcsec=u * 206264.806,
        rocking_in_phase_xy_arcsec=w * math.cos(truth['rocking_phase_rad']) * 206264.806)
    modelled = calibrate_dither(rocking_pair['z'], rocking_pair['y'], settings=model)
    assert modelled.results()[KEY_A].value == pytest.approx(truth['misalignment_rad'], rel=1e-3)


def test_rocking_bound_covers_the_shift_it_bounds(
        rocking_pair: dict[str, DitherRecording]) -> None:
    truth = rocking_pair['z'].truth
    cal = calibrate_dither(rocking_pair['z'], rocking_pair['y'],
                           settings=dataclasses.replace(WIDE, rocking_treatment='bound'))
    comps, _ = cal.components()
    shift_z = abs(truth['effective_z_rad'] - truth['misalignment_z_rad'])
    assert 0 < shift_z <= comps['z'].rocking_bound_rad
    a = cal.results()[KEY_A]
    assert abs(a.value - truth['misalignment_rad']) <= 2 * a.std_uncertainty
    assert 'rocking allowance ±' in '\n'.join(cal.summary().lines())


def test_plots_are_written_for_a_calibrator_and_for_bare_results(
        noisy_pair: dict[str, DitherRecording], tmp_path) -> None:  # noqa: ANN001
    from gyro_calib.dither.plots import plot_dither

    cal = calibrate_dither(noisy_pair['z'], noisy_pair['y'], settings=DitherSettings(
        scale_factor_rad_per_pulse=K, max_misalignment_arcmin=60.0))
    paths = plot_dither(cal, tmp_path / 'full')
    names = sorted(p.name for p in paths)
    assert names == ['dither_coning.png', 'dither_residuals_y.png', 'dither_residuals_z.png',
                     'dither_spectrum_y.png', 'dither_spectrum_z.png']
    assert all(p.stat().st_size > 10_000 for p in paths)
    only = plot_dither(cal.results(), tmp_path / 'results')
    assert [p.name for p in only] == ['dither_coning.png']


def test_issue_16_bench_reports_a_with_a_weak_y_component_and_rejects() -> None:
    """Issue 16's bench with a weak Y component.

    The issue's bench, shortened: a = 53′ with the Y component small (ψ₀ = 100°), table
    6.2 rad/s at 8.7 Hz, the paper's rocking. Y cannot be told from zero; it is still
    reported with its interval, a and the coning drift are formed, the verdict rejects.
    """
    gyro = DitheredGyroConfig(misalignment_arcmin=53.0, ia_azimuth_deg=100.0, seed=16)
    table = VibrationTableConfig(rate_amplitude_rad_s=6.2, frequency_hz=8.7)
    pair = simulate_dither_pair(gyro, table, DitherBenchConfig(duration_s=60.0))
    cal = calibrate_dither(pair['z'], pair['y'],
                           settings=DitherSettings(scale_factor_rad_per_pulse=K))
    res, parts, summary = cal.results(), cal.result_parts(), cal.summary()
    assert {KEY_Z, KEY_Y, KEY_A, KEY_CONING} <= set(res)  # nothing measured is withheld
    y = summary.components['y']
    assert not y.significant and 'cannot be told from zero' in summary.unresolved['y']
    low, high = parts[KEY_Y]['interval']
    assert low <= 53.0 * ARCMIN * abs(math.cos(math.radians(100.0))) <= high
    assert summary.verdict is not None and summary.verdict.state == 'reject'
    low_a, high_a = parts[KEY_A]['interval']
    assert 5 * ARCMIN < low_a <= 53.0 * ARCMIN <= high_a
    assert cal.missing() == {}
