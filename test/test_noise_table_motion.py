"""Noise characterisation splits the record at the rate table's changes of rate.

IEEE Std 952 noise terms need a constant input rate: a table at rest or turning at one
constant rate adds a constant, which every Allan-family deviation removes; a table that
changes rate (start, reversal, stop) puts its profile into the Allan variance. When the
record also holds the rate table's joint states (``/rate_table/joint_states``), each span at
a constant rate is a steady segment, analysed as its own segment (as a gap splits a record),
and the samples while the rate changed are left out; the summary, ``--json``
(``table_motion``) and the rejections say what changed and how much was left out. A table
at rest throughout changes nothing. The position table (two-axis bench) sweeps the tilted
sense axis round a cone, so it is steady only at rest.

The gyro and the table are generated here from the physics: the table's angle is the
integral of a trapezoidal rate profile, read through a quantised encoder; the RLG's pulse
count is ⌊(table angle + Earth-rate angle + angle random walk)/K⌋. ``GYRO_CALIB_STRESS=1``
raises the property test's example count.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ros_in_process import init_undiscovered

import gyro_calib
from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import BagMessage, ContractMessages, write_bag
from gyro_calib.cli import main
from gyro_calib.handoff import load_calibration
from gyro_calib.noise.calibrator import NoiseCalibrator
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.session import CalibrationOptions

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
BAGS = Path(__file__).resolve().parents[1] / 'bags'
K = 4.0e-6                      # rad/pulse
GYRO_HZ, TABLE_HZ = 200, 50     # gyro samples and table states per second
N_TRUE = 2.0e-4                 # angle random walk, rad/√s
EARTH_Z = 7.292115e-5 * math.sin(math.radians(45.0))  # rad/s on a vertical sense axis
ENCODER_RAD = 2 * math.pi / 2**23                       # one count of the table encoder
START_NS = 1_000_000_000_000


def table_angle(t_s: np.ndarray, start_s: float, cruise_s: float, rate: float,
                accel: float) -> tuple[np.ndarray, np.ndarray]:
    """Angle (rad) and rate (rad/s) of a trapezoidal move.

    The table rests, accelerates at |``accel``| to ``rate`` at ``start_s``, cruises
    ``cruise_s``, decelerates to rest and stays there.
    """
    accel = math.copysign(accel, rate)
    ramp = rate / accel
    s = np.clip(t_s - start_s, 0.0, None)
    up = np.minimum(s, ramp)
    cruise = np.clip(s - ramp, 0.0, cruise_s)
    down = np.clip(s - ramp - cruise_s, 0.0, ramp)
    angle = 0.5 * accel * up**2 + rate * cruise + rate * down - 0.5 * accel * down**2
    omega = np.where(s < ramp, accel * up, np.where(s < ramp + cruise_s, rate,
                                                    rate - accel * down))
    omega = np.where(s >= 2 * ramp + cruise_s, 0.0, np.where(s <= 0, 0.0, omega))
    return angle, omega


def bench(duration_s: float, motion: tuple[float, float, float, float] | None, seed: int,
          jitter_counts: int = 1) -> dict[str, np.ndarray]:
    """Stamps and readings of a gyro on a table.

    ``motion`` = (start s, cruise s, rate rad/s, acceleration rad/s²) or None (at rest);
    the encoder flickers by up to ``jitter_counts`` counts at rest, and its rate is the
    encoder difference over the state interval.
    """
    rng = np.random.default_rng(seed)
    n = int(duration_s * GYRO_HZ) + 1
    tg = np.arange(n, dtype=np.int64) * (1_000_000_000 // GYRO_HZ)
    ts = tg / 1e9
    table = (table_angle(ts, *motion)[0] if motion is not None else np.zeros(n))
    walk = np.concatenate(([0.0], np.cumsum(rng.normal(0.0, N_TRUE / math.sqrt(GYRO_HZ),
                                                       n - 1))))
    counts = np.floor((table + EARTH_Z * ts + walk) / K + rng.uniform())
    m = int(duration_s * TABLE_HZ) + 1
    tt = np.arange(m, dtype=np.int64) * (1_000_000_000 // TABLE_HZ)
    true = (table_angle(tt / 1e9, *motion) if motion is not None
            else (np.zeros(m), np.zeros(m)))[0]
    encoder = (np.round(true / ENCODER_RAD) + rng.integers(-jitter_counts, jitter_counts + 1, m)
               ) * ENCODER_RAD
    rate = np.concatenate(([0.0], np.diff(encoder) * TABLE_HZ))
    return {'t_gyro': START_NS + tg, 'counts': counts, 't_table': START_NS + tt,
            'angle': encoder, 'rate': rate}


def write(path: Path, b: dict[str, np.ndarray], *, table: bool) -> Path:
    cdr = ContractMessages()
    msgs = [BagMessage('/gyro/pulses', int(t), cdr.joint_state(int(t), 'gyro', float(c)))
            for t, c in zip(b['t_gyro'], b['counts'])]
    if table:
        msgs += [BagMessage('/rate_table/joint_states', int(t),
                            cdr.joint_state(int(t), 'rate_table', float(a), float(r)))
                 for t, a, r in zip(b['t_table'], b['angle'], b['rate'])]
    write_bag(path, sorted(msgs, key=lambda m: m.log_time_ns))
    return path


def run_cli(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    status = main(['noise', *map(str, argv), '--no-progress'])
    out = capsys.readouterr()
    return status, out.out, out.err


def interleaved(b: dict[str, np.ndarray],
                chunk: int) -> Iterator[tuple[slice, np.ndarray]]:
    """Chunks of gyro samples, each with the mask of the table states due before it.

    Chunks of gyro samples, each with the mask of the table states due before it (a
    node's batch: the table's states of a chunk first, the last chunk takes the rest).
    """
    t_gyro, t_table = b['t_gyro'], b['t_table']
    edges = np.arange(0, len(t_gyro) + chunk, chunk)
    for a, z in zip(edges[:-1], edges[1:]):
        if a >= len(t_gyro):
            continue
        hi = t_gyro[min(z, len(t_gyro)) - 1] if z < len(t_gyro) else t_table[-1]
        lo = t_gyro[a - 1] if a else t_table[0] - 1
        yield slice(a, z), (t_table > lo) & (t_table <= hi)


def left_out(cal: NoiseCalibrator, t_gyro: np.ndarray) -> np.ndarray:
    """The gyro stamps the calibrator's table gate leaves out (the record complete)."""
    n, seg = cal.gate.decide(t_gyro, final=True)
    assert n == len(t_gyro)
    out: np.ndarray = np.any(seg == -1, axis=1)
    return out


def changes_of_rate(t_gyro: np.ndarray, ramps: list[tuple[float, float, float]],
                    steady: list[tuple[float, float]], settings: NoiseSettings,
                    state_s: float = 1.0 / TABLE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """(must be left out, must be analysed) from the true motion.

    ``ramps``: (start s, end s, |acceleration| rad/s²) of each change of rate. Left out: every
    gyro sample inside a ramp at which the table has left the steady line by more than the
    gate can miss — by twice the angle tolerance or twice the rate tolerance, judged one state
    interval later (the next state decides). Analysed: every sample of a true constant-rate
    span long enough to be steady (table_min_steady_s and four state intervals), more than two
    state intervals from a ramp (a state's rate, differenced over the interval before it,
    mixes the ramp in; the record's own ends are no ramp).
    """
    ts = (t_gyro - START_NS) / 1e9
    must_out = np.zeros(len(ts), dtype=bool)
    theta_tol = settings.table_rest_angle_rad + 3.5 * settings.table_stamp_jitter_s  # ≤ 200 °/s
    for lo, hi, accel in ramps:
        d = np.minimum(ts - lo, hi - ts) - state_s  # into the ramp, one state later
        seen = ((0.5 * accel * d**2 > 2 * theta_tol)
                | (accel * d > 2 * settings.table_rest_rate_rad_s))
        must_out |= (ts > lo) & (ts < hi) & (d > 0) & seen
    must_in = np.zeros(len(ts), dtype=bool)
    end = ts[-1]
    for lo, hi in steady:
        if hi - lo < settings.table_min_steady_s + 4 * state_s:
            continue
        a = lo + 2 * state_s if lo > 0 else -math.inf
        z = hi - 2 * state_s if hi < end else math.inf
        must_in |= (ts > a) & (ts < z)
    return must_out, must_in


def trapezoid_spans(motion: tuple[float, float, float, float],
                    duration_s: float) -> tuple[list[tuple[float, float, float]],
                                                list[tuple[float, float]]]:
    """(ramps, constant-rate spans) of :func:`table_angle`'s move, s from the start."""
    start, cruise, rate, accel = motion
    ramp, a = abs(rate / accel), abs(accel)
    ramps = [(start, start + ramp, a), (start + ramp + cruise, start + 2 * ramp + cruise, a)]
    steady = [(0.0, start), (start + ramp, start + ramp + cruise),
              (start + 2 * ramp + cruise, duration_s)]
    return ramps, steady


def calibrated(b: dict[str, np.ndarray], *, table: bool, chunk: int = 997) -> NoiseCalibrator:
    """The calibrator fed in interleaved chunks, the table's states of each chunk first."""
    cal = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
    for part, k in interleaved(b, chunk):
        if table:
            cal.extend_table(b['t_table'][k], b['angle'][k], b['rate'][k])
        cal.extend_pulses(b['t_gyro'][part], b['counts'][part])
        cal.process()
    cal.process(flush=True)
    return cal


# -- a table that turns for part of the record -------------------------------------------------
MOTION = (40.0, 12.0, math.radians(90.0), math.radians(180.0))  # 40 s at rest, then 90 °/s


@pytest.fixture(scope='module')
def turning(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, np.ndarray], Path]:
    b = bench(100.0, MOTION, seed=5)
    return b, write(tmp_path_factory.mktemp('turning') / 'bag', b, table=True)


def test_a_turn_at_constant_rate_is_analysed_and_only_its_start_and_stop_are_left_out(
        turning: tuple[dict[str, np.ndarray], Path], capsys: pytest.CaptureFixture[str]) -> None:
    b, bag = turning
    status, out, err = run_cli(capsys, bag, '--scale-factor-rad-per-pulse', K, '--json')
    assert status == 0, err
    lines = [ln for ln in err.splitlines() if ln.startswith('/rate_table/joint_states: ')]
    assert len(lines) == 1
    # 40 s → 40.5 s accelerating, 12 s at 90 °/s, 0.5 s decelerating: two changes of rate,
    # each seen between the last state of one steady segment and the first of the next
    assert 'the rate table changed rate during 1.04 s of its 100 s record (2 span(s): 1 × ' \
        'start, 1 × stop; largest rate' in lines[0]
    assert 'held 3 steady segment(s) (at rest, at 90 °/s;' in lines[0]
    assert 'reference: the gyro alone (table_reference = gyro).' in lines[0]
    document = json.loads(out)
    jsonschema.validate(document, json.loads((Path(gyro_calib.__file__).parent / 'schema'
                                              / 'result.schema.json').read_text()))
    doc = document['methods']['noise']
    motion = doc['table_motion']
    assert motion['moved'] is True and motion['spans'] == 2
    assert motion['changes'] == ['start', 'stop'] and motion['steady_segments'] == 3
    assert motion['steady_rates_rad_s'] == pytest.approx([0.0, math.radians(90.0), 0.0],
                                                         abs=1e-6)
    assert motion['turning_s'] == pytest.approx(12.0, abs=0.041)
    assert motion['reference'] == 'gyro'
    assert motion['max_rate_rad_s'] <= math.radians(90.0)
    rejections = [r for r in doc['rejections'] if 'are left out: the rate table' in r]
    assert len(rejections) == 2
    assert 'the rate table started from rest to 90 °/s' in rejections[0]
    assert 'the rate table stopped from 90 °/s to rest' in rejections[1]
    # left out: the ramps, within two state intervals; the 12 s at 90 °/s is analysed
    cal = calibrated(b, table=True)
    out_mask = left_out(cal, b['t_gyro'])
    ramps, steady = trapezoid_spans(MOTION, 100.0)
    must_out, must_in = changes_of_rate(b['t_gyro'], ramps, steady, cal.settings)
    assert np.all(out_mask[must_out]) and not np.any(out_mask[must_in])
    assert motion['samples_left_out'] == {'/gyro/pulses': int(np.count_nonzero(out_mask))}
    # what remains is the same record with the changes cut out (gaps), to the last bit: the
    # constant 90 °/s adds a constant rate the Allan variance removes; N within 3σ of the truth
    cut = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
    cut.extend_pulses(b['t_gyro'][~out_mask], b['counts'][~out_mask])
    cut.process(flush=True)
    assert doc['axes']['gyro']['adev'] == cut.json_section()['axes']['gyro']['adev']
    n = doc['results']['angle_random_walk_rad_per_sqrt_s']
    want = cut.results()['gyro']['angle_random_walk_rad_per_sqrt_s']
    assert (n['value'], n['std'], n['n']) == (want.value, want.std_uncertainty, want.n_used)
    assert abs(n['value'] - N_TRUE) < 3 * n['std']


def test_without_the_table_the_same_record_reports_the_motion_as_noise(
        turning: tuple[dict[str, np.ndarray], Path]) -> None:
    """Why the gate exists: the turning record read blind gives a curve of the profile."""
    b, _ = turning
    blind = calibrated(b, table=False)
    gated = calibrated(b, table=True)
    assert blind.table_line() == ''
    blind_adev = np.array(blind.json_section()['axes']['gyro']['adev'])
    gated_adev = np.array(gated.json_section()['axes']['gyro']['adev'])
    assert np.nanmax(blind_adev) > 100 * np.nanmax(gated_adev)


def test_the_turning_record_is_analysed_the_same_live_as_offline(
        turning: tuple[dict[str, np.ndarray], Path]) -> None:
    """Chunked like a node's batches (the table's states first) = the whole bag at once."""
    b, bag = turning
    offline = calibrate_bags([bag], methods=['noise'], options=CalibrationOptions(
        scale_factor_rad_per_pulse=K)).sessions['noise']
    live = calibrated(b, table=True, chunk=211)
    assert live.json_section()['axes'] == offline.json_section()['axes']
    assert live.table_line() == offline.calibrator.table_line()


# -- a table at rest throughout ----------------------------------------------------------------
def test_a_table_at_rest_throughout_gives_exactly_the_numbers_without_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    b = bench(60.0, None, seed=9, jitter_counts=3)  # encoder flickering ±3 counts at rest
    with_table = write(tmp_path / 'with', b, table=True)
    without = write(tmp_path / 'without', b, table=False)
    docs = {}
    for name, bag in (('with', with_table), ('without', without)):
        status, out, err = run_cli(capsys, bag, '--scale-factor-rad-per-pulse', K, '--json')
        assert status == 0, err
        docs[name] = json.loads(out)['methods']['noise']
        if name == 'with':
            assert ('/rate_table/joint_states: the rate table stayed at rest throughout its '
                    '60 s record (3001 states;') in err
    motion = docs['with'].pop('table_motion')
    assert motion['moved'] is False and motion['samples_left_out'] == {'/gyro/pulses': 0}
    assert docs['with'] == docs['without']


# -- the committed RBRLG bench --------------------------------------------------------------------
def test_the_rate_bias_bench_gives_no_term_from_its_reversals(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """k_tilde_bench: ±150 °/s with six reversals in 100 s.

    Read blind, the reversals gave a "rate random walk" K of 1.043 rad/s/√s. Gated, each
    reversal is left out and only the steady ±150 °/s spans (14.4 s each) are analysed: their
    curve is the gyro's own (no point near the reversals' 0.8·Ω ≈ 2 rad/s), and 14.4 s spans
    give too few averaging times for a term, which the run says (exit 1), writing only the
    curves it computed.
    """
    out_file = tmp_path / 'handoff.yaml'
    status, out, err = run_cli(capsys, BAGS / 'k_tilde_bench', '--scale-factor-rad-per-pulse',
                               4.086e-6, '--out', out_file)
    assert status == 1
    assert 'no noise term is resolved (see the reasons above); the curves are written' in err
    written = load_calibration(out_file)
    assert not [k for k in written.values if 'random_walk' in k or 'quantization' in k]
    assert '/rate_table/joint_states: the rate table changed rate during 1.95 s of its 100 s ' \
        'record (7 span(s): 1 × change of rate, 6 × reversal; largest rate 2.531 rad/s = 145 ' \
        '°/s) and held 7 steady segment(s) (at 150 °/s, at -150 °/s;' in out  # the summary
    status = main(['calibrate', str(BAGS / 'k_tilde_bench'), '--method', 'noise',
                   '--scale-factor-rad-per-pulse', '4.086e-6', '--json'])
    captured = capsys.readouterr()
    noise = json.loads(captured.out)['methods']['noise']
    motion = noise['table_motion']
    assert motion['moved'] is True and motion['changes'] == ['change of rate'] + ['reversal'] * 6
    assert motion['steady_rates_rad_s'] == pytest.approx(
        [math.radians(150.0) * (-1) ** k for k in range(7)], rel=1e-6)
    assert motion['samples_left_out'] == {'/gyro/pulses': 1944}
    assert sum('are left out: the rate table reversed from ' in r
               for r in noise['rejections']) == 6
    assert noise['results'] == {}
    assert 'rate_random_walk_rad_per_s_sqrt_s' in noise['missing']
    gyro = noise['axes']['gyro']
    assert max(gyro['tau_s']) < 14.4 / 4 and max(gyro['adev']) < 3e-3  # no reversal in it


# -- property: whatever the move, its changes of rate are left out, and only they -------------
@settings(max_examples=200 if STRESS else 12, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(start_s=st.floats(0.0, 25.0), cruise_s=st.floats(0.0, 8.0),
       rate_deg_s=st.floats(-200.0, 200.0).filter(lambda r: abs(r) > 0.05),
       accel_deg_s2=st.floats(5.0, 2000.0), chunk=st.integers(50, 5000),
       seed=st.integers(0, 2**16))
def test_the_changes_of_rate_are_left_out_and_the_steady_spans_analysed_as_a_cut_record(
        start_s: float, cruise_s: float, rate_deg_s: float, accel_deg_s2: float, chunk: int,
        seed: int) -> None:
    motion = (start_s, cruise_s, math.radians(rate_deg_s), math.radians(accel_deg_s2))
    b = bench(30.0, motion, seed=seed)
    cal = calibrated(b, table=True, chunk=chunk)
    out_mask = left_out(cal, b['t_gyro'])
    ramps, steady = trapezoid_spans(motion, 30.0)
    must_out, must_in = changes_of_rate(b['t_gyro'], ramps, steady, cal.settings)
    assert np.all(out_mask[must_out]) and not np.any(out_mask[must_in])
    record = cal.table_record()
    assert record is not None
    assert record['samples_left_out']['/gyro/pulses'] == int(np.count_nonzero(out_mask))
    assert record['moved'] is bool(out_mask.any())
    # every steady segment is at rest or at the cruise rate (its encoder-fitted slope)
    for r in record['steady_rates_rad_s']:
        assert min(abs(r), abs(r - motion[2])) < 1e-3, record['steady_rates_rad_s']
    # and the rest is analysed as if the changes were gaps in a static record
    cut = NoiseCalibrator(cal.settings)
    cut.extend_pulses(b['t_gyro'][~out_mask], b['counts'][~out_mask])
    cut.process(flush=True)
    assert cal.json_section()['axes'] == cut.json_section()['axes']


def test_a_table_whose_states_stop_holds_its_last_state_and_no_unbounded_backlog() -> None:
    """The table's states end at 20 s of a 60 s static record.

    The samples beyond wait at most table_wait_s, then the last state (at rest) holds for
    them, and the line says so.
    """
    b = bench(60.0, None, seed=4)
    stopped = dict(b)
    keep = b['t_table'] <= START_NS + 20_000_000_000
    for key in ('t_table', 'angle', 'rate'):
        stopped[key] = b[key][keep]
    gated = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
    blind = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
    gated.extend_table(stopped['t_table'], stopped['angle'], stopped['rate'])
    wait = gated.settings.table_wait_s
    for a in range(0, len(b['t_gyro']), 500):
        for cal in (gated, blind):
            cal.extend_pulses(b['t_gyro'][a:a + 500], b['counts'][a:a + 500])
            cal.process()
        backlog = gated.sample_storage_bytes() - blind.sample_storage_bytes()
        assert backlog <= 16 * (wait + 1.0 + 2.5) * GYRO_HZ  # the wait, the reorder window, 500
    for cal in (gated, blind):
        cal.process(flush=True)
    assert gated.json_section()['axes'] == blind.json_section()['axes']
    # decided by the held state once the newest sample was 5 s ahead: 20.005 s … 55 s (the
    # last 5 s at the end of the record, as every record's tail)
    line = gated.table_line()
    assert 'stayed at rest throughout its 20 s record' in line
    assert f'7000 of /gyro/pulses after waiting {wait:g} s for a later state: taken as ' \
        'steady' in line


def test_noise_node_subscribes_the_rate_table_beside_its_input(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The live graph: the node reads the table through the same session topics."""
    import rclpy

    from gyro_calib.nodes.noise_node import NoiseNode
    from gyro_calib.nodes.processes import ros_args

    monkeypatch.chdir(tmp_path)  # the node keeps its state record in the working directory
    init_undiscovered(args=[*ros_args({'scale_factor_rad_per_pulse': K}), '-r', '__ns:=/bench2'])
    try:
        node = NoiseNode()
        try:
            names = {s.topic_name for s in node.subscriptions}
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
    assert {'/bench2/gyro/pulses', '/bench2/fog/output', '/bench2/rate_table/joint_states',
            '/bench2/position_table/joint_states'} <= names


@pytest.mark.parametrize('given', ['angle and rate', 'angle only', 'rate only'])
def test_the_motion_is_seen_from_whatever_the_table_publishes(given: str) -> None:
    """JointState may carry the angle, the rate or both (NaN = not given, as decoded).

    An Imu on the same table loses the same stretch on all six axes.
    """
    b = bench(30.0, (10.0, 5.0, math.radians(-30.0), math.radians(60.0)), seed=2)
    angle = b['angle'] if given != 'rate only' else np.full_like(b['angle'], np.nan)
    rate = b['rate'] if given != 'angle only' else np.full_like(b['rate'], np.nan)
    cal = NoiseCalibrator(NoiseSettings())
    cal.extend_table(b['t_table'], angle, rate)
    n = len(b['t_gyro'])
    rng = np.random.default_rng(1)
    gyro = rng.normal(0.0, 1e-3, (n, 3))
    gyro[:, 2] += np.interp(b['t_gyro'], b['t_table'], b['rate'])  # the table turns about z
    cal.extend_imu(b['t_gyro'], gyro, rng.normal(0.0, 1e-2, (n, 3)) + (0, 0, 9.81))
    cal.process(flush=True)
    record = cal.table_record()
    assert record is not None and record['moved'] and record['spans'] == 2
    assert record['changes'] == ['start', 'stop']
    # 10 s → 10.5 s accelerating, 5 s at −30 °/s (a steady segment: analysed, the constant
    # −30 °/s on gyro_z removed as any constant rate), 0.5 s decelerating
    assert record['steady_rates_rad_s'] == pytest.approx([0.0, math.radians(-30.0), 0.0],
                                                         abs=2e-4)
    assert record['moving_s'] == pytest.approx(1.0, abs=0.081)
    must_out, must_in = changes_of_rate(
        b['t_gyro'], [(10.0, 10.5, math.radians(60.0)), (15.5, 16.0, math.radians(60.0))],
        [(0.0, 10.0), (10.5, 15.5), (16.0, 30.0)], cal.settings)
    out_mask = left_out(cal, b['t_gyro'])
    assert np.all(out_mask[must_out]) and not np.any(out_mask[must_in])
    left = record['samples_left_out']['imu']
    assert left == np.count_nonzero(out_mask)
    assert all(cal.axis_result(a).curve is not None for a in cal.axes())
    assert [r.reason.split(':')[0] for r in cal.rejections] == ['imu', 'imu']
    # the three steady segments are three segments, each integrated from its own phase origin;
    # the count is of the rate samples analysed (not of their phase points, one more each)
    assert cal.results()['gyro_z']['angle_random_walk_rad_per_sqrt_s'].n_used == n - left


def test_the_table_is_never_offered_as_an_input_to_characterise(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The table is context beside the input: info and methods say so."""
    assert main(['info', str(BAGS / 'k_tilde_bench')]) == 0
    info = capsys.readouterr().out
    assert 'gyro-calib noise BAG --topic T, T one of /gyro/pulses\n' in info
    assert main(['methods']) == 0
    listing = capsys.readouterr().out.split('\nnoise ', 1)[1]
    assert '/rate_table/joint_states         sensor_msgs/msg/JointState   optional, beside the ' \
        'input' in listing
    assert '/position_table/joint_states     sensor_msgs/msg/JointState   optional, beside the ' \
        'input' in listing


# -- the two-axis bench: the position table gates as the rate table does -------------------------
ELEVATION = math.radians(45.0)  # the sense axis's elevation over the position table's plane


def two_axis_bench(duration_s: float, rate_motion: tuple[float, float, float, float] | None,
                   position_motion: tuple[float, float, float, float] | None,
                   seed: int) -> dict[str, np.ndarray]:
    """Stamps and readings of a gyro on a rate table carried by a position table.

    The rate table's axis is the sense axis; the sense axis is tilted ``ELEVATION`` out of
    the position table's plane, so it sees sin(ELEVATION) of the position table's rotation
    (the rate table's own angle does not change that projection: its axis is the sense
    axis). Each table's encoder (2²³ counts) flickers by ±1 count; its rate is the encoder
    difference over the state interval. Motions as :func:`bench`'s, None = at rest.
    """
    rng = np.random.default_rng(seed)
    n = int(duration_s * GYRO_HZ) + 1
    tg = np.arange(n, dtype=np.int64) * (1_000_000_000 // GYRO_HZ)
    ts = tg / 1e9

    def true_angle(t_s: np.ndarray, motion: tuple[float, float, float, float] | None
                   ) -> np.ndarray:
        return table_angle(t_s, *motion)[0] if motion is not None else np.zeros(len(t_s))

    sensed = true_angle(ts, rate_motion) + math.sin(ELEVATION) * true_angle(ts, position_motion)
    walk = np.concatenate(([0.0], np.cumsum(rng.normal(0.0, N_TRUE / math.sqrt(GYRO_HZ),
                                                       n - 1))))
    counts = np.floor((sensed + EARTH_Z * ts + walk) / K + rng.uniform())
    m = int(duration_s * TABLE_HZ) + 1
    tt = np.arange(m, dtype=np.int64) * (1_000_000_000 // TABLE_HZ)
    out = {'t_gyro': START_NS + tg, 'counts': counts, 't_table': START_NS + tt}
    for name, motion in (('rate', rate_motion), ('position', position_motion)):
        encoder = (np.round(true_angle(tt / 1e9, motion) / ENCODER_RAD)
                   + rng.integers(-1, 2, m)) * ENCODER_RAD
        out[f'{name}_angle'] = encoder
        out[f'{name}_rate'] = np.concatenate(([0.0], np.diff(encoder) * TABLE_HZ))
    return out


def write_two_axis(path: Path, b: dict[str, np.ndarray], tables: tuple[str, ...]) -> Path:
    """The bag of :func:`two_axis_bench` with the joint states of ``tables``."""
    cdr = ContractMessages()
    msgs = [BagMessage('/gyro/pulses', int(t), cdr.joint_state(int(t), 'gyro', float(c)))
            for t, c in zip(b['t_gyro'], b['counts'])]
    for name in tables:
        msgs += [BagMessage(f'/{name}_table/joint_states', int(t),
                            cdr.joint_state(int(t), f'{name}_table', float(a), float(r)))
                 for t, a, r in zip(b['t_table'], b[f'{name}_angle'], b[f'{name}_rate'])]
    write_bag(path, sorted(msgs, key=lambda m: m.log_time_ns))
    return path


def moving_states(cal: NoiseCalibrator, angle: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """The table states that moved: by the rate, or by the angle from where the table rested."""
    thr_w, thr_a = cal.settings.table_rest_rate_rad_s, cal.settings.table_rest_angle_rad
    moving, ref = np.zeros(len(angle), dtype=bool), angle[0]
    for i, (a, w) in enumerate(zip(angle, rate)):
        if abs(w) > thr_w or abs(a - ref) > thr_a:
            moving[i], ref = True, a
    return moving


def moved_at(t_table: np.ndarray, moving: np.ndarray, t_gyro: np.ndarray) -> np.ndarray:
    """Gyro samples strictly between two states at rest with a moving state between them."""
    rest_t = t_table[~moving]
    k = np.searchsorted(rest_t, t_gyro, side='left')
    on_state = (k < len(rest_t)) & (rest_t[np.minimum(k, len(rest_t) - 1)] == t_gyro)
    lo = np.where(k > 0, rest_t[np.maximum(k - 1, 0)], np.iinfo(np.int64).min)
    hi = np.where(k < len(rest_t), rest_t[np.minimum(k, len(rest_t) - 1)],
                  np.iinfo(np.int64).max)
    n_moving_before = np.concatenate(([0], np.cumsum(moving)))
    between = (n_moving_before[np.searchsorted(t_table, hi, side='left')]
               - n_moving_before[np.searchsorted(t_table, lo, side='right')])
    return (between > 0) & ~on_state


POSITION_MOTION = (25.0, 12.0, math.radians(30.0), math.radians(60.0))  # one revolution at 30 °/s


@pytest.mark.parametrize('tables', [('rate', 'position'), ('position',)])
def test_the_position_table_turning_while_the_rate_table_holds_is_left_out(
        tables: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The θ phase: the rate table held, the position table turning; the gyro is not static.

    With the rate table recorded (at rest) or not, the same samples are left out: those
    while the position table turned; the line, the rejection and ``table_motion.tables``
    name the position table.
    """
    b = two_axis_bench(70.0, None, POSITION_MOTION, seed=11)
    bag = write_two_axis(tmp_path / 'bag', b, tables)
    status, out, err = run_cli(capsys, bag, '--scale-factor-rad-per-pulse', K, '--json')
    assert status == 0, err
    document = json.loads(out)
    jsonschema.validate(document, json.loads((Path(gyro_calib.__file__).parent / 'schema'
                                              / 'result.schema.json').read_text()))
    doc = document['methods']['noise']
    motion = doc['table_motion']
    cal = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
    inside = moved_at(b['t_table'], moving_states(cal, b['position_angle'], b['position_rate']),
                      b['t_gyro'])
    assert 0.95 * 13.0 * GYRO_HZ < np.count_nonzero(inside) < 1.05 * 13.0 * GYRO_HZ
    assert motion['samples_left_out'] == {'/gyro/pulses': int(np.count_nonzero(inside))}
    position = motion['tables']['/position_table/joint_states']
    assert position['moved'] is True and position['spans'] == 1
    # 25 s → 25.5 s accelerating, 12 s at 30 °/s, 0.5 s decelerating, ± one 20 ms state
    assert position['moving_s'] == pytest.approx(13.0, abs=0.041)
    peak = np.max(np.abs(b['position_rate']))  # 30 °/s + encoder flicker
    assert position['max_rate_rad_s'] == peak
    largest = f'{peak:.4g} rad/s = {math.degrees(peak):.4g} °/s'
    assert sorted(motion['tables']) == sorted(f'/{t}_table/joint_states' for t in tables)
    if 'rate' in tables:  # the top-level keys stay the rate table's
        assert motion['topic'] == '/rate_table/joint_states' and motion['moved'] is False
        assert motion['tables']['/rate_table/joint_states']['moved'] is False
        assert ('/rate_table/joint_states: the rate table stayed at rest throughout its 70 s '
                'record (3501 states); /position_table/joint_states: the position table moved '
                f'during 13.02 s of its 70 s record (1 span(s), largest rate {largest}); steady '
                '= velocity within 0.01 rad/s of the segment\'s mean and angle within 2e-05 rad '
                '(+ |rate| × 0.0001 s) of its line, for 1 s or more; the position table steady '
                f'only at rest: {np.count_nonzero(inside)} of 14001 samples of '
                '/gyro/pulses') in err
    else:
        assert motion['topic'] == '/position_table/joint_states' and motion['moved'] is True
        assert ('/position_table/joint_states: the position table moved during 13.02 s of its '
                f'70 s record (1 span(s), largest rate {largest}; steady') in err
    assert len(doc['rejections']) == 1
    assert doc['rejections'][0].startswith('t=1025.005000 s: /gyro/pulses: the ')
    assert 'are left out: the position table was turning (/position_table/joint_states up ' \
        f'to {largest}); steady' in doc['rejections'][0]
    # what remains is the static record with the turning part cut out, to the last bit
    cal.extend_pulses(b['t_gyro'][~inside], b['counts'][~inside])
    cal.process(flush=True)
    assert doc['axes']['gyro']['adev'] == cal.json_section()['axes']['gyro']['adev']
    n = doc['results']['angle_random_walk_rad_per_sqrt_s']
    assert abs(n['value'] - N_TRUE) < 3 * n['std']


def test_both_tables_at_rest_give_exactly_the_numbers_without_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    b = two_axis_bench(60.0, None, None, seed=13)
    docs = {}
    for tables in (('rate', 'position'), ()):
        bag = write_two_axis(tmp_path / ('_'.join(tables) or 'none'), b, tables)
        status, out, err = run_cli(capsys, bag, '--scale-factor-rad-per-pulse', K, '--json')
        assert status == 0, err
        docs[tables] = json.loads(out)['methods']['noise']
    motion = docs[('rate', 'position')].pop('table_motion')
    assert motion['line'].startswith(
        '/rate_table/joint_states: the rate table stayed at rest throughout its 60 s record '
        '(3001 states); /position_table/joint_states: the position table stayed at rest '
        'throughout its 60 s record (3001 states); steady = ')
    assert motion['line'].endswith('the position table steady only at rest: every sample '
                                   'analysed; reference: the gyro alone (table_reference = '
                                   'gyro).')
    assert motion['moved'] is False and motion['samples_left_out'] == {'/gyro/pulses': 0}
    assert {t: m['moved'] for t, m in motion['tables'].items()} == {
        '/rate_table/joint_states': False, '/position_table/joint_states': False}
    assert docs[('rate', 'position')] == docs[()]


def test_the_committed_theta_bench_names_the_position_table_motion(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The θ bench's position-table motion is named and left out.

    theta_four_position: the K̃ phase turns the rate table, the θ phase the position table at
    30 °/s, one revolution each way at each of four stations; both are left out.
    """
    status = main(['calibrate', str(BAGS / 'theta_four_position'), '--method', 'rbrlg',
                   '--method', 'noise', '--scale-factor-rad-per-pulse', '4.086e-6', '--json',
                   '--no-progress'])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    document = json.loads(captured.out)
    jsonschema.validate(document, json.loads((Path(gyro_calib.__file__).parent / 'schema'
                                              / 'result.schema.json').read_text()))
    noise = document['methods']['noise']
    tables = noise['table_motion']['tables']
    position = tables['/position_table/joint_states']
    assert position['moved'] is True and position['spans'] == 4
    assert position['max_rate_rad_s'] == pytest.approx(math.radians(30.0))
    assert tables['/rate_table/joint_states']['moved'] is True
    # the rate table's K̃ phase turns steadily at ±150 °/s between reversals: analysed
    assert noise['table_motion']['steady_rates_rad_s'][:4] == pytest.approx(
        [math.radians(150.0) * (-1) ** k for k in range(4)], rel=1e-6)
    assert noise['table_motion']['changes'] == ['change of rate'] + ['reversal'] * 3 + [
        'stop'] + ['move'] * 3
    assert sum('the position table was turning' in r for r in noise['rejections']) == 4
    assert '/position_table/joint_states: the position table moved during 196.8 s of its ' \
        '270.9 s record (4 span(s), largest rate 0.5236 rad/s = 30 °/s)' in captured.err
    # left out: the position table's four turns and the rate table's changes of rate (its
    # steady ±150 °/s spans analysed; 65507 when only rest was steady)
    assert noise['table_motion']['samples_left_out'] == {'/gyro/pulses': 51099}


def motions() -> st.SearchStrategy[tuple[float, float, float, float] | None]:
    """A table at rest, or a trapezoidal move of random start, cruise, rate and acceleration."""
    return st.none() | st.tuples(
        st.floats(0.0, 25.0), st.floats(0.0, 8.0),
        st.floats(-200.0, 200.0).filter(lambda r: abs(r) > 0.05).map(math.radians),
        st.floats(5.0, 2000.0).map(math.radians))


@settings(max_examples=200 if STRESS else 10, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(rate_motion=motions(), position_motion=motions(), chunk=st.integers(50, 5000),
       seed=st.integers(0, 2**16))
def test_a_sample_is_analysed_only_when_every_recorded_table_is_steady(
        rate_motion: tuple[float, float, float, float] | None,
        position_motion: tuple[float, float, float, float] | None, chunk: int,
        seed: int) -> None:
    """Left out: the union of what each table's own states leave out.

    Each table is classified from its own states as when it is the only one recorded; the
    rate table is steady at any constant rate, the position table only at rest (its turning
    sweeps the tilted sense axis round a cone).
    """
    b = two_axis_bench(30.0, rate_motion, position_motion, seed=seed)

    def fed(names: tuple[str, ...]) -> NoiseCalibrator:
        cal = NoiseCalibrator(NoiseSettings(scale_factor_rad_per_pulse=K))
        for part, k in interleaved(b, chunk):
            for name in names:  # each chunk's table states first, as a node's batch
                cal.extend_table(b['t_table'][k], b[f'{name}_angle'][k], b[f'{name}_rate'][k],
                                 topic=f'/{name}_table/joint_states')
            cal.extend_pulses(b['t_gyro'][part], b['counts'][part])
            cal.process()
        cal.process(flush=True)
        return cal

    both, alone = fed(('rate', 'position')), {n: fed((n,)) for n in ('rate', 'position')}
    either = left_out(alone['rate'], b['t_gyro']) | left_out(alone['position'], b['t_gyro'])
    assert np.array_equal(left_out(both, b['t_gyro']), either)
    record = both.table_record()
    assert record is not None
    assert record['samples_left_out']['/gyro/pulses'] == int(np.count_nonzero(either))
    for name, cal in alone.items():
        own = cal.table_record()
        assert own is not None
        topic = f'/{name}_table/joint_states'
        assert record['tables'][topic] == own['tables'][topic]
    # the position table turning at a constant rate is never steady; the rate table is
    if position_motion is not None and position_motion[1] > 2.0:
        start, cruise, rate, accel = position_motion
        ts = (b['t_gyro'] - START_NS) / 1e9
        mid = abs(rate / accel) + start + cruise / 2
        assert np.all(either[np.abs(ts - mid) < 0.5])
    cut = NoiseCalibrator(both.settings)
    cut.extend_pulses(b['t_gyro'][~either], b['counts'][~either])
    cut.process(flush=True)
    assert both.json_section()['axes'] == cut.json_section()['axes']


@settings(max_examples=200 if STRESS else 10, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(rates=st.lists(st.floats(-3.0, 3.0), min_size=2, max_size=5), turning=st.booleans(),
       nan_angles=st.floats(0.0, 0.1), nan_rates=st.floats(0.0, 0.2),
       chunk=st.integers(1, 400), seed=st.integers(0, 2**16))
def test_the_steady_segments_do_not_depend_on_how_the_states_arrive(
        rates: list[float], turning: bool, nan_angles: float, nan_rates: float, chunk: int,
        seed: int) -> None:
    """One state at a time, in chunks or all at once: the same segments, bit for bit.

    A rate profile through the given rates (linear between random knots), stamps with
    ±1 ms jitter, angle noise of 3 µrad, some states without an angle or a rate.
    """
    from gyro_calib.noise.table import TableMotion

    rng = np.random.default_rng(seed)
    n = 1500
    t = np.cumsum(rng.integers(4_000_000, 6_000_000, n)).astype(np.int64)
    ts = (t - t[0]) / 1e9
    knots = np.sort(rng.uniform(0.0, ts[-1], len(rates)))
    rate = np.interp(ts, knots, rates)
    angle = np.concatenate(([0.0], np.cumsum(np.diff(ts) * rate[1:]))) + rng.normal(0, 3e-6, n)
    angle[rng.random(n) < nan_angles] = np.nan
    given_rate = np.where(rng.random(n) < nan_rates, np.nan, rate + rng.normal(0, 1e-3, n))

    def classified(size: int) -> tuple[object, ...]:
        tm = TableMotion(1e-2, 2e-5, 1.0, 1e-4, turning)
        for a in range(0, n, size):
            tm.extend(t[a:a + size], angle[a:a + size], given_rate[a:a + size])
        return (repr(tm.segments), tm.moving_states, repr(tm.changes()),
                tm.decide(t, final=True)[1].tolist())

    once = classified(n)
    assert classified(1) == once and classified(chunk) == once
