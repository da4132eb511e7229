"""The FOG session behind the front door.

The FOG session behind the front door: streamed like a live node it gives the offline
numbers once the recording ends; unsteady segments are left out with a reason; the summary
says what limits the result; the bench streams the same samples in any chunk size.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import iter_sample_batches
from gyro_calib.fog import FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import KEY_BIAS, KEY_SCALE_FACTOR
from gyro_calib.fog.session import TOPICS, FogSession
from gyro_calib.session import CalibrationOptions
from sim_nodes.fog import FogConfig, SelfCalLadder, TableSettings, mapping_self_cal_bench
from sim_nodes.fog.scenarios import simulate_mapping_and_self_cal

BAGS = Path(__file__).resolve().parents[1] / 'bags'
TABLE = TableSettings(output_rate_hz=200.0, lead_s=1.0)


def _streamed(name: str, batch_messages: int) -> FogSession:
    """A session fed as a live node feeds it: small batches, processed without flush."""
    session = FogSession(CalibrationOptions(latitude_deg=45.75))
    for batch in iter_sample_batches(BAGS / name, TOPICS, batch_messages=batch_messages):
        session.feed(batch)
        session.process()
    return session


@pytest.mark.parametrize('name', ['fog_turntable', 'fog_fault_silent_injection'])
def test_session_end_of_recording_gives_the_offline_numbers(name: str) -> None:
    offline = calibrate_bags([BAGS / name]).sessions['fog']
    live = _streamed(name, 900)
    assert live.results() != offline.results()  # the last segment / plateau is still open
    live.end_of_recording()
    live.process()
    assert live.results() == offline.results()
    assert live.rejections() == offline.rejections()
    assert live.missing() == offline.missing()


def test_session_rejections_are_in_stamp_order_whatever_the_batches() -> None:
    a, b = _streamed('fog_fault_saturating_staircase', 500), \
        _streamed('fog_fault_saturating_staircase', 40_000)
    for s in (a, b):
        s.end_of_recording()
        s.process()
    assert a.rejections() == b.rejections()
    stamps = [r.stamp_ns for r in a.rejections()]
    assert stamps == sorted(stamps) and len(stamps) == 5


def test_unsteady_segment_is_left_out_of_the_fits_with_its_reason() -> None:
    """An unsteady segment is left out of the fits, with its reason.

    The ladder ran on the stopped table but its injection messages were not recorded:
    the static segment's output jumps from plateau to plateau.
    """
    rec = simulate_mapping_and_self_cal(
        mapping_rates_deg_s=(5.0, -5.0, 20.0, 20.01, 20.1, 21.0, -40.0), mapping_hold_s=12.0,
        ladder=SelfCalLadder(plateau_count=8, plateau_s=6.0), table=TABLE)
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns,
                        settings=FogSettings(latitude_deg=45.75))
    reasons = [r.reason for r in cal.all_rejections()]
    assert len(reasons) == 1 and 'the output rate was not steady' in reasons[0]
    assert 'segment at +0.0000 °/s' in reasons[0]
    assert len(cal.segments) == 8  # measured, then left out by the fits
    res = cal.results()
    k, bias = res[KEY_SCALE_FACTOR], res[KEY_BIAS]
    assert k.n_used == 7 and len(k.rejected) == 1
    assert abs(k.value - rec.truth['turntable_k_counts_per_rad']) < 5 * k.std_uncertainty
    assert abs(bias.value - rec.truth['bias_rad_s']) < 5 * bias.std_uncertainty


@pytest.mark.parametrize('name', ['fog_turntable', 'fog_mapping_self_cal'])
def test_steady_segments_are_never_called_unsteady(name: str) -> None:
    """Steady segments are never called unsteady.

    Even where the integer output beats against the sample rate (−100 °/s at 200 Hz:
    0.504 count per sample over 383) and inflates a segment's block scatter sevenfold.
    """
    session = calibrate_bags([BAGS / name]).sessions['fog']
    assert isinstance(session, FogSession)
    assert session.calibrator.fits().rejections == ()


@pytest.mark.parametrize(('name', 'start'), [
    ('fog_turntable', 'the angle random walk gives'),
    ('fog_mapping_self_cal', 'the self-calibrated K differs from the turntable K by +77'),
])
def test_limiting_says_what_to_do(name: str, start: str) -> None:
    line = calibrate_bags([BAGS / name]).sessions['fog'].limiting()
    assert line.startswith(start), line


@pytest.mark.parametrize(('mapping_hold_s', 'plateau_s', 'words'), [
    (10.0, 4.0, "of the self-calibrated K's variance: hold each plateau longer"),
    (30.0, 6.0, 'while the zero-amplitude K agrees with it'),
])
def test_limiting_for_a_gyro_whose_injection_gain_is_right(mapping_hold_s: float,
                                                            plateau_s: float,
                                                            words: str) -> None:
    """What limits the mapping error is named.

    No mapping error: the noise limits (short mapping and plateaus), or the front end's
    bend inside the linear range shows once mapping and plateaus are long enough (the
    zero-amplitude K agrees). (With 4 s plateaus the bend is 2.9 σ: the plateaus' angle
    random walk is no longer read low by the local fits' smoothing.)
    """
    rec = simulate_mapping_and_self_cal(FogConfig(injection_gain_error=0.0),
                                        mapping_hold_s=mapping_hold_s,
                                        ladder=SelfCalLadder(plateau_count=8,
                                                             plateau_s=plateau_s),
                                        table=TABLE)
    session = FogSession(CalibrationOptions())
    session.calibrator = calibrate_fog(
        rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
        table_angle_rad=rec.table_angle_rad, table_rate_rad_s=rec.table_rate_rad_s,
        zero_index_ns=rec.zero_index_ns, settings=FogSettings(latitude_deg=45.75))
    assert words in session.limiting()


def test_json_section_has_no_nan_for_short_ranges_or_a_missing_mapping() -> None:
    rec = simulate_mapping_and_self_cal(mapping_rates_deg_s=(5.0, -5.0, 40.0),
                                        mapping_hold_s=10.0,
                                        ladder=SelfCalLadder(plateau_count=5, plateau_s=4.0,
                                                             end_with_zero=False),
                                        table=TABLE)
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
                        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns)
    session = FogSession(CalibrationOptions())
    session.calibrator = cal
    doc = session.json_section()
    json.dumps(doc, allow_nan=False)
    rows = doc['self_cal_table']
    assert rows[0]['plateaus'] == 2 and rows[0]['nonlinearity_ppm'] is None
    assert all(r['scale_factor_counts_per_rad'] is None for r in rows)  # no mapping


def test_bench_streams_the_same_samples_in_any_chunk_size() -> None:
    bench = mapping_self_cal_bench(mapping_hold_s=5.0,
                                   ladder=SelfCalLadder(plateau_count=4, plateau_s=2.0,
                                                        silent_plateaus=(2,)),
                                   table=TABLE)
    rec = bench.record()
    parts = list(bench.chunks(37))
    for name in ('output_t_ns', 'output_counts', 'table_t_ns', 'table_angle_rad',
                 'table_rate_rad_s', 'zero_index_ns'):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(rec, name))
    t, v = bench.injection_messages
    np.testing.assert_array_equal(t, rec.injection_t_ns)
    assert v[2] != 0.0  # published, though it never reaches the loop
