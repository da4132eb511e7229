"""The dither session.

The dither session: two bags, a live stream and whole arrays give the same numbers bit for
bit; K is taken from the flag, the settings or a hand-off file, or its absence is said; bad
settings are refused naming the field; reports never carry NaN.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from gyro_calib import topics
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import JOINT_STATE, SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.dither.calibrator import KEY_A, KEY_FREQUENCY, KEY_Z, calibrate_dither
from gyro_calib.dither.session import DitherSession
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.errors import ConfigError
from gyro_calib.session import CalibrationOptions
from sim_nodes.dither.bag_scenarios import SCENARIOS, simulate_scenario
from sim_nodes.dither.scenarios import DitherRecording

BAGS = Path(__file__).resolve().parents[1] / 'bags'
K = SCENARIOS['dither_z'].gyro.scale_factor_rad_per_pulse


def _live_batches(recs: list[DitherRecording], piece_s: float, table_lag: int
                  ) -> list[SampleBatch]:
    """The recordings one after the other, as a live node hands them.

    The recordings one after the other, as a live node hands them over: pieces of
    ``piece_s`` of stamps, the table ``table_lag`` pieces behind the pulses, the frame_id
    codes numbered in order of first appearance over the whole stream.
    """
    p_t = np.concatenate([r.pulse_t_ns for r in recs])
    p_n = np.concatenate([r.pulse_counts for r in recs])
    t_t = np.concatenate([r.table_t_ns for r in recs])
    angle = np.concatenate([r.table_angle_rad for r in recs])
    rate = np.concatenate([r.table_rate_rad_s for r in recs])
    names = tuple(dict.fromkeys(r.frame_id for r in recs))
    codes = np.concatenate([np.full(len(r.table_t_ns), names.index(r.frame_id), np.int32)
                            for r in recs])
    edges = np.arange(p_t[0], p_t[-1] + int(piece_s * 1e9) + 1, int(piece_s * 1e9))
    pieces_p = [slice(*np.searchsorted(p_t, [a, b])) for a, b in zip(edges[:-1], edges[1:])]
    pieces_t = [slice(*np.searchsorted(t_t, [a, b])) for a, b in zip(edges[:-1], edges[1:])]
    out = []
    for i in range(len(pieces_p) + table_lag):
        cols = {}
        if i < len(pieces_p):
            s = pieces_p[i]
            cols[topics.GYRO_PULSES] = TopicColumns(
                topics.GYRO_PULSES, JOINT_STATE, p_t[s], p_t[s],
                FrameIds(np.zeros(s.stop - s.start, np.int32), ('gyro',)),
                {'position': p_n[s], 'velocity': np.full(s.stop - s.start, np.nan)})
        if 0 <= i - table_lag < len(pieces_t):
            s = pieces_t[i - table_lag]
            seen = names[:int(codes[:s.stop].max()) + 1] if s.stop else names[:1]
            cols[topics.VIBRATION_TABLE_JOINT_STATES] = TopicColumns(
                topics.VIBRATION_TABLE_JOINT_STATES, JOINT_STATE, t_t[s], t_t[s],
                FrameIds(codes[s], seen), {'position': angle[s], 'velocity': rate[s]})
        n = sum(len(c) for c in cols.values())
        last = max((int(c.stamp_ns[-1]) for c in cols.values() if len(c)), default=0)
        out.append(SampleBatch(cols, n, last))
    return out


@pytest.fixture(scope='module')
def recordings() -> list[DitherRecording]:
    return [simulate_scenario(SCENARIOS['dither_z']), simulate_scenario(SCENARIOS['dither_y'])]


def test_two_bags_a_live_stream_and_the_arrays_give_the_same_numbers_bit_for_bit(
        recordings: list[DitherRecording]) -> None:
    options = CalibrationOptions(scale_factor_rad_per_pulse=K)
    offline = calibrate_bags([BAGS / 'dither_z', BAGS / 'dither_y'], options=options)
    bags = offline.sessions['dither'].results()
    live = DitherSession(options)  # no start_bag: the frame_id change ends the Z recording
    log = []
    for batch in _live_batches(recordings, 0.37, table_lag=2):
        live.feed(batch)
        log += live.process()
    arrays = calibrate_dither(*recordings, settings=live.calibrator.settings).results()
    assert KEY_A in bags
    assert bags == live.results() == {k: v for k, v in arrays.items()}
    assert any('re-mounted' in line for line in log)
    assert live.data_span_ns() == offline.sessions['dither'].data_span_ns()


def test_the_live_log_says_why_a_running_component_is_unbounded(
        recordings: list[DitherRecording]) -> None:
    """Without K the rocking allowance is unbounded: the line says so, never '± inf′'."""
    live = DitherSession(CalibrationOptions())
    log = []
    for batch in _live_batches(recordings[:1], 0.37, table_lag=2):
        live.feed(batch)
        log += live.process()
    running = [line for line in log if 'running component' in line]
    assert running and not any('inf' in line for line in log)
    assert '± unbounded, the rocking allowance needs the scale factor K' in running[-1]


def test_scale_factor_comes_from_the_flag_the_settings_or_a_handoff_file(tmp_path: Path) -> None:
    handoff = tmp_path / 'gyro.yaml'
    handoff.write_text(yaml.safe_dump({
        'format_version': 2, 'gyro_calib_version': '0.2.0', 'gyro_id': '', 'complete': True,
        'missing': {}, 'gyro': {'k_tilde_rad_per_pulse': 4.1e-06,
                                'k_tilde_rad_per_pulse_std': 1.0e-13},
        'methods': {'rbrlg': {'source': 'x', 'created_utc': '2026-01-01T00:00:00+00:00',
                              'data_start_stamp_ns': 0, 'data_end_stamp_ns': 1}}}))
    from_file = DitherSession(CalibrationOptions(calibration_file=handoff))
    assert from_file.calibrator.settings.scale_factor_rad_per_pulse == 4.1e-06
    assert 'K̃ (taken for K' in from_file.scale_factor_note
    flag = DitherSession(CalibrationOptions(calibration_file=handoff,
                                            scale_factor_rad_per_pulse=4.2e-06))
    assert flag.calibrator.settings.scale_factor_rad_per_pulse == 4.2e-06
    config = tmp_path / 'dither.yaml'
    config.write_text('dither_calibration_node:\n  ros__parameters:\n'
                      '    scale_factor_rad_per_pulse: 4.3e-06\n    block_s: 4\n')
    settings = DitherSession(CalibrationOptions(config_file=config)).calibrator.settings
    assert settings.scale_factor_rad_per_pulse == 4.3e-06 and settings.block_s == 4.0
    none = DitherSession(CalibrationOptions())
    assert not none.calibrator.settings.has_scale_factor
    assert 'θ_d is reported in pulses' in none.scale_factor_note


# A K out of range given as a flag or parameter is refused by CalibrationOptions itself
# (test_settings.py: one range check for every front door).
@pytest.mark.parametrize('options, field', [
    (CalibrationOptions(settings={'block_secs': 2.0}), 'block_secs'),
    (CalibrationOptions(settings={'min_blocks': 1}), 'min_blocks'),
    (CalibrationOptions(settings={'target_std_arcmin': -1.0}), 'target_std_arcmin'),
])
def test_bad_settings_are_refused_naming_the_field(options: CalibrationOptions,
                                                   field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        DitherSession(options)


def test_handoff_file_without_a_scale_factor_is_refused_naming_the_keys(tmp_path: Path) -> None:
    handoff = tmp_path / 'gyro.yaml'
    handoff.write_text(yaml.safe_dump({
        'format_version': 2, 'gyro_calib_version': '0.2.0', 'gyro_id': '', 'complete': True,
        'missing': {}, 'gyro': {'dither_frequency_hz': 400.0, 'dither_frequency_hz_std': 0.1},
        'methods': {'dither': {'source': 'x', 'created_utc': '2026-01-01T00:00:00+00:00',
                               'data_start_stamp_ns': 0, 'data_end_stamp_ns': 1}}}))
    with pytest.raises(ConfigError, match='neither scale_factor_rad_per_pulse nor '
                                          'k_tilde_rad_per_pulse'):
        DitherSession(CalibrationOptions(calibration_file=handoff))


def test_what_limits_the_result_is_said_at_every_stage(recordings: list[DitherRecording]) -> None:
    session = DitherSession(CalibrationOptions(scale_factor_rad_per_pulse=K))
    assert session.limiting().startswith('no accepted block: no block of pulses')
    assert session.data_span_ns() is None and session.handoff('live') is None
    z = recordings[0]
    short = slice(0, 5001)  # 2.5 s: one block, no scatter for the dither's uncertainty
    session.feed(_live_batches([DitherRecording(
        z.pulse_t_ns[short], z.pulse_counts[short], z.table_t_ns[:501],
        z.table_angle_rad[:501], z.table_rate_rad_s[:501], 'z', z.truth)], 10.0, 0)[0])
    session.process(flush=True)
    assert KEY_FREQUENCY not in session.results()
    assert 'its uncertainty needs the scatter of at least two' in session.missing()[
        KEY_FREQUENCY]
    assert 'min_blocks' in session.limiting()
    json.dumps(session.json_section(), allow_nan=False)
    for batch in _live_batches(recordings[:1], 5.0, 0):
        session.feed(batch)
    session.process(flush=True)
    # one orientation: the component is measured, but the rocking allowance κ·a needs a
    assert KEY_Z in session.json_section()['results'] and KEY_Z not in session.results()
    assert 'its uncertainty is unbounded' in session.missing()[KEY_Z]
    assert 'one orientation bounds a only from below' in '\n'.join(session.summary_lines())
    assert session.limiting().startswith('a needs the table along Y too')
    rows = dict((r[0], r[1]) for r in session.summary_rows())
    assert rows['a (′)'] == '—' and float(rows['a·|sin ψ₀|, table along Z (′)']) > 0


@pytest.mark.parametrize('name', ['dither_stripped', 'dither_small_table'])
def test_json_section_never_holds_nan(name: str) -> None:
    session = calibrate_bags([BAGS / name]).sessions['dither']
    json.dumps(session.json_section(), allow_nan=False)


def test_info_target_follows_the_setting() -> None:
    assert math.isclose(DitherSettings().target_std_rad, math.radians(1.25 / 60))
    assert math.isclose(DitherSettings(target_std_arcmin=0.5).target_std_rad,
                        math.radians(0.5 / 60))
