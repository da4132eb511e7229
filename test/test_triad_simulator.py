"""The triad simulator (sim_nodes/triad) against the kinematics of docs/methods.md §F.

- Signs: the body-frame direction about which the simulator turns the IMU is the estimator's
  u (§F eqs. (1)–(2)), for the position table at any station, tilt, offset and fixture, for the
  rate table, and for each remount.
- Counts: over whole revolutions about u at constant rate, gyro i counts
  [(s_i·u)·(A + Ω_u·T) + b_i·T]/K_i (§F eq. (4)), checked against the simulator's phase.
- Reproducibility: the same seed gives the same samples however the run is chunked; the
  committed bags' truth files hold the configured triad.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gyro_calib.bagio import bag_info, iter_raw_messages, typestore
from gyro_calib.triad.kinematics import (
    earth_rate_along,
    inner_axis_direction,
    inner_axis_enu,
    outer_axis_direction,
    remount_direction,
)
from gyro_calib.units import RAD_PER_ARCSEC
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.triad.bench import TriadBench
from sim_nodes.triad.gyros import MOUNT_AXES, TriadConfig, TriadGyroSimulator, TriadMountConfig
from sim_nodes.triad.scenarios import GROUPS, IMU_PULSES, SCENARIOS

BAGS = Path(__file__).resolve().parents[1] / 'bags'


def _turn_axis(mount: TriadMountConfig, chi: float, psi: float, d_chi: float,
               d_psi: float) -> np.ndarray:
    """Unit body-frame axis of the simulator's rotation between (χ, ψ) and (χ+dχ, ψ+dψ)."""
    rot = mount.orientation(np.array([chi, chi + d_chi]), np.array([psi, psi + d_psi]))
    v = (rot[0].inv() * rot[1]).as_rotvec()
    return np.asarray(v / np.linalg.norm(v))


@settings(max_examples=40, deadline=None)
@given(tilt_deg=st.floats(5.0, 85.0), psi=st.floats(-7.0, 7.0), chi=st.floats(-7.0, 7.0),
       offset_deg=st.floats(-180.0, 180.0),
       fixture=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_position_table_turns_the_body_about_the_estimators_u(
        tilt_deg: float, psi: float, chi: float, offset_deg: float, fixture: list[float]) -> None:
    f = Rotation.from_rotvec(fixture).as_matrix()
    mount = TriadMountConfig(tilt_deg=tilt_deg, station_offset_deg=offset_deg,
                             fixture_rotation=tuple(tuple(r) for r in f.tolist()))  # type: ignore[arg-type]
    u, _ = outer_axis_direction(psi, math.radians(tilt_deg),
                                station_offset_rad=math.radians(offset_deg), fixture=f)
    np.testing.assert_allclose(_turn_axis(mount, chi, psi, 1e-3, 0.0), u, atol=1e-9)
    np.testing.assert_allclose(_turn_axis(mount, chi, psi, 0.0, 1e-3),
                               inner_axis_direction(f), atol=1e-9)


def test_forward_position_table_turn_at_station_zero_leans_away_from_body_x() -> None:
    """β = 0, α = 45°, F = I: ON = (−sin α, 0, cos α) in the body (§F.1, the sign spelled out)."""
    u = _turn_axis(TriadMountConfig(), 0.0, 0.0, 1e-3, 0.0)
    np.testing.assert_allclose(u, [-math.sqrt(0.5), 0.0, math.sqrt(0.5)], atol=1e-12)


@pytest.mark.parametrize('axis', MOUNT_AXES)
def test_remounted_table_turns_the_body_about_the_mounted_axis(axis: str) -> None:
    mount = TriadMountConfig(mount_axis=axis)
    np.testing.assert_allclose(_turn_axis(mount, 0.0, 0.3, 0.0, 1e-3), remount_direction(axis),
                               atol=1e-12)


def _whole_turns(gyros: TriadConfig, mount: TriadMountConfig, *, outer: bool, m: int,
                 seconds: float) -> np.ndarray:
    """Counts of the three gyros over m whole turns of one table at constant rate (1 kHz)."""
    n = int(seconds * 1000)
    t_ns = np.arange(n + 1, dtype=np.int64) * 1_000_000
    angle = 2 * math.pi * m * np.arange(n + 1) / n
    still = np.full(n + 1, 0.4)
    sim = TriadGyroSimulator(gyros, mount)
    counts = sim.step(t_ns, angle, still) if outer else sim.step(t_ns, still, angle)
    return np.asarray(counts[-1] - counts[0])


@pytest.mark.parametrize('outer', [False, True])
@pytest.mark.parametrize('direction', [1, -1])
def test_counts_over_whole_turns_are_eq_4(outer: bool, direction: int) -> None:
    """K_i·N = (s_i·u)·(A + Ω_u·T) + b_i·T over whole turns (§F eq. (4)), unquantised."""
    gyros = TriadConfig(quantise=False, angle_random_walk_deg_sqrt_h=(0.0, 0.0, 0.0),
                        bias_deg_h=(0.3, -0.7, 1.1), latitude_deg=41.0, heading_deg=25.0)
    mount = TriadMountConfig(tilt_deg=40.0, tilt_error_arcsec=30.0, station_offset_deg=10.0)
    m, seconds = 3 * direction, 12.0
    counts = _whole_turns(gyros, mount, outer=outer, m=m, seconds=seconds)
    alpha = mount.true_tilt_rad()
    if outer:
        u, _ = outer_axis_direction(0.4, alpha, station_offset_rad=math.radians(10.0))
        omega_u = earth_rate_along([0.0, 0.0, 1.0], 41.0)
    else:
        u = inner_axis_direction()
        omega_u = earth_rate_along(inner_axis_enu(tilt_rad=alpha, heading_deg=25.0,
                                                  position_table_angle_rad=0.4), 41.0)
    s = gyros.unit_sense_axes()
    k = gyros.scale_factor_rad_per_pulse()
    bias = np.asarray(gyros.bias_deg_h) * RAD_PER_ARCSEC
    # m < 0 turns the body the other way about u: A = 2π·m carries the sign
    expected = ((s @ u) * (2 * math.pi * m + omega_u * seconds) + bias * seconds) / k
    np.testing.assert_allclose(counts, expected, rtol=0.0, atol=2e-6)


def test_quantised_counts_are_whole_pulses_within_one_of_the_phase() -> None:
    base = TriadConfig(angle_random_walk_deg_sqrt_h=(0.0, 0.0, 0.0))
    phase = _whole_turns(dataclasses.replace(base, quantise=False), TriadMountConfig(),
                         outer=False, m=2, seconds=5.0)
    counts = _whole_turns(base, TriadMountConfig(), outer=False, m=2, seconds=5.0)
    assert np.all(counts == np.round(counts))
    assert np.all(np.abs(counts - phase) < 1.0)


def test_arw_scatters_counts_as_stated() -> None:
    """Counts minus the noiseless phase: std N·√T/K over 200 seeds (within 25 %)."""
    arw = 0.05  # °/√h, large so the quantisation does not hide it
    quiet = TriadConfig(quantise=False, angle_random_walk_deg_sqrt_h=(0.0, 0.0, 0.0))
    ref = _whole_turns(quiet, TriadMountConfig(), outer=False, m=1, seconds=0.2)
    noisy = np.array([_whole_turns(dataclasses.replace(quiet, seed=s,
                                                       angle_random_walk_deg_sqrt_h=(arw,) * 3),
                                   TriadMountConfig(), outer=False, m=1, seconds=0.2)
                      for s in range(200)])
    expected = arw * 60.0 * math.sqrt(0.2) / np.asarray(quiet.scale_factor_arcsec_per_pulse)
    np.testing.assert_allclose((noisy - ref).std(axis=0), expected, rtol=0.25)


def _short_bench(kind: str, seed: int = 3) -> TriadBench:
    from sim_nodes.two_axis_procedure import ThetaProcedureConfig

    mount = TriadMountConfig(mount_axis='-y' if kind == 'remount' else '')
    return TriadBench(kind, RateTableConfig(sample_rate_hz=250.0, revolutions_per_segment=1.0,
                                            seed=seed),
                      TriadConfig(seed=seed), mount,
                      ThetaProcedureConfig(stations_deg=(0.0, 120.0),
                                           position_table_rate_deg_s=120.0, settle_s=0.2),
                      inner_pairs=1)


@pytest.mark.parametrize('kind', ['two_axis', 'remount'])
def test_same_seed_same_samples_whatever_the_chunking(kind: str) -> None:
    a, b = _short_bench(kind).record(200), _short_bench(kind).record(37)
    for x, y in zip(dataclasses.astuple(a), dataclasses.astuple(b)):
        if isinstance(x, tuple):
            for xx, yy in zip(x, y):
                np.testing.assert_array_equal(xx, yy)
        elif x is not None:
            np.testing.assert_array_equal(x, y)
    other = _short_bench(kind, seed=4).record()
    assert not np.array_equal(a.pulse_counts, other.pulse_counts)
    assert (a.position_table is None) == (kind == 'remount')


CONTRACT_BENCH_KEYS = {'latitude_deg', 'heading_deg', 'tilt_deg', 'tilt_std_arcsec',
                       'station_offset_deg', 'fixture_rotation', 'position_table_revolutions',
                       'revolutions_per_window'}


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_committed_triad_bag_holds_the_contract_topics_bench_settings_and_truth(
        name: str) -> None:
    scenario = SCENARIOS[name]
    info = bag_info(BAGS / name)
    bench = info.scenario['bench']
    if scenario.kind == 'two_axis':
        assert set(bench) == CONTRACT_BENCH_KEYS
        assert bench['fixture_rotation'] == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        assert bench['tilt_deg'] == 45.0 and bench['revolutions_per_window'] == 5
    else:
        assert set(bench) == {'latitude_deg', 'heading_deg', 'mount_axis',
                              'revolutions_per_window'}
        assert bench['mount_axis'] == scenario.mount.mount_axis
    expected = yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))
    truth = expected['truth']
    s = np.array(truth['sense_axes'])
    k = np.array(truth['scale_factor_rad_per_pulse'])
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(k, np.array(truth['scale_factor_arcsec_per_pulse'])
                               * RAD_PER_ARCSEC, rtol=1e-15)
    m = np.array(truth['pulses_to_body_rad'])
    omega = np.array([0.3, -1.2, 2.0])  # rad/s: counts/s of the truth, back through M
    np.testing.assert_allclose(m @ ((s @ omega) / k), omega, rtol=1e-12)
    np.testing.assert_allclose(m @ (np.array(truth['bias_deg_h_along_sense_axes'])
                                    * RAD_PER_ARCSEC / k), truth['bias_rad_s'], rtol=1e-12)
    assert np.max(np.abs(np.array(truth['misalignment_rad']))) < 5e-3
    assert truth == info.scenario['truth']
    tables = {'/rate_table/joint_states', '/rate_table/zero_index'}
    if scenario.kind == 'two_axis':
        tables |= {'/position_table/joint_states', '/position_table/zero_index'}
    assert set(info.topics) == {IMU_PULSES} | tables
    store = typestore()
    pulses = []
    for topic, msgtype, _, raw in iter_raw_messages(BAGS / name):
        if topic == IMU_PULSES:
            pulses.append(store.deserialize_cdr(raw, msgtype))
            if len(pulses) == 3:
                break
    assert [p.name for p in pulses] == [['x', 'y', 'z']] * 3
    assert all(len(p.position) == 3 and np.all(p.position == np.floor(p.position))
               for p in pulses)


def test_remount_group_names_the_six_committed_mounts() -> None:
    assert GROUPS['triad_remount_bench'] == tuple(
        f'triad_remount_bench_{s}' for s in ('px', 'mx', 'py', 'my', 'pz', 'mz'))
    assert {SCENARIOS[n].mount.mount_axis for n in GROUPS['triad_remount_bench']} == set(
        MOUNT_AXES)


def test_simulate_the_remount_group_writes_one_bag_per_mount(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gyro_calib.cli import main

    out = tmp_path / 'remount'
    assert main(['simulate', 'triad_remount_bench', '--out', str(out), '--sample-rate-hz', '50',
                 '--seed', '9']) == 0
    assert capsys.readouterr().out.startswith(f'wrote {out}')
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(GROUPS['triad_remount_bench'])
    stored = {n: bag_info(out / n).scenario for n in names}
    assert {s['bench']['mount_axis'] for s in stored.values()} == set(MOUNT_AXES)
    assert len({s['gyros']['seed'] for s in stored.values()}) == 6  # independent noise
    assert all(s['table']['sample_rate_hz'] == 50.0 for s in stored.values())
    # the directory exists now: refused in one line, nothing written
    assert main(['simulate', 'triad_remount_bench', '--out', str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and captured.err.count('\n') == 1
