"""The committed triad bags, cut naively, give their truth through the core estimator (§F).

An end-to-end check of the simulator against the estimator's conventions, independent of the
triad session (issue 26's live/offline pipeline): windows of whole turns between zero-index
events at constant table rate, counts at each event from a straight-line fit of the pulses
within ±0.1 s (§A eq. (2a) in its simplest form), forward/reverse windows paired, directions
from gyro_calib.triad.kinematics (§F eqs. (1)–(2)), rows by ``triad_calibration``. The
results must land within the tolerances written in the bags' ``expected.yaml``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib.bagio import iter_raw_messages, iter_sample_batches, typestore
from gyro_calib.triad.estimator import BenchParameter, TriadPair, TriadResult, triad_calibration
from gyro_calib.triad.kinematics import (
    TILT,
    earth_rate_along,
    inner_axis_direction,
    inner_axis_enu,
    outer_axis_direction,
    pair_from_windows,
    remount_direction,
)
from gyro_calib.units import RAD_PER_ARCSEC

BAGS = Path(__file__).resolve().parents[1] / 'bags'
HALF_FIT_S = 0.1


@dataclass
class _Bag:
    pulses_t: npt.NDArray[np.int64]
    pulses: npt.NDArray[np.float64]
    tables: dict[str, tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                            npt.NDArray[np.float64], npt.NDArray[np.int64]]]
    bench: dict[str, Any]


def _read(name: str) -> _Bag:
    store = typestore()
    t, n = [], []
    for topic, msgtype, _, raw in iter_raw_messages(BAGS / name):
        if topic == '/imu/pulses':
            msg = store.deserialize_cdr(raw, msgtype)
            t.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            n.append(msg.position)
    batch = next(iter_sample_batches(BAGS / name, batch_messages=10**9))
    tables = {}
    for table in ('rate_table', 'position_table'):
        js = batch.joint_state(f'/{table}/joint_states')
        if js is not None:
            idx = batch.stamps(f'/{table}/zero_index')
            assert idx is not None
            tables[table] = (js[0], js[1], js[2], idx)
    from gyro_calib.bagio import bag_info

    return _Bag(np.array(t, dtype=np.int64), np.array(n), tables,
                bag_info(BAGS / name).scenario['bench'])


@dataclass
class _Window:
    start_ns: int
    end_ns: int
    counts: npt.NDArray[np.float64]
    forward: bool
    station_rad: float  # the other table's encoder angle (rate table: position table's)


def _windows(bag: _Bag, table: str, turns: int) -> list[_Window]:
    """One window of ``turns`` whole turns per constant-rate run of ``table``."""
    t, angle, rate, events = bag.tables[table]
    other = bag.tables.get('position_table' if table == 'rate_table' else 'rate_table')
    valid = []
    for e in events.tolist():
        near = np.abs(t - e) <= HALF_FIT_S * 1e9
        r = rate[near]
        if len(r) and abs(r[0]) > 0.1 and np.all(r == r[0]):
            valid.append((e, r[0]))
    out, j = [], 0
    while j + turns < len(valid):
        (a, ra), (b, rb) = valid[j], valid[j + turns]
        same_run = all(valid[k][1] == ra for k in range(j, j + turns + 1)) and ra == rb
        if not same_run:
            j += 1
            continue
        counts = []
        for e in (a, b):
            near = np.abs(bag.pulses_t - e) <= HALF_FIT_S * 1e9
            x = (bag.pulses_t[near] - e) / 1e9
            counts.append([np.polyfit(x, bag.pulses[near, c], 1)[1] for c in range(3)])
        station = 0.0 if other is None else float(np.interp(a, other[0], other[1]))
        out.append(_Window(a, b, np.array(counts[1]) - np.array(counts[0]), ra > 0, station))
        while j < len(valid) and valid[j][1] == ra:  # next run
            j += 1
    return out


Direction = Callable[['_Window'], tuple[npt.NDArray[np.float64], Any]]


def _pairs(bag: _Bag, table: str, turns: int, direction_of: Direction,
           earth_of: Callable[['_Window'], float]) -> list[TriadPair]:
    wins = _windows(bag, table, turns)
    pairs = []
    for fwd, rev in zip(wins[::2], wins[1::2]):
        assert fwd.forward and not rev.forward
        u, d = direction_of(fwd)
        angle = 2 * math.pi * turns
        pairs.append(pair_from_windows(
            u, forward_counts=fwd.counts, reverse_counts=rev.counts,
            counts_std=np.full(3, 0.3), forward_angle_rad=angle, reverse_angle_rad=angle,
            forward_s=(fwd.end_ns - fwd.start_ns) / 1e9, reverse_s=(rev.end_ns - rev.start_ns)
            / 1e9, angle_std_rad=0.15 * RAD_PER_ARCSEC,
            earth_rate_along_u_rad_s=earth_of(fwd),
            direction_sensitivity=d, stamp_ns=fwd.start_ns))
    return pairs


def _check(res: TriadResult, truth: dict[str, Any], tol: dict[str, Any]) -> None:
    k_true = np.array(truth['scale_factor_rad_per_pulse'])
    s_true = np.array(truth['sense_axes'])
    for i, ch in enumerate(res.channels):
        assert ch.scale_factor_rad_per_pulse is not None and ch.sense_axis is not None, ch
        k = ch.scale_factor_rad_per_pulse.value
        assert abs(k / k_true[i] - 1) < tol['scale_factor_relative'][i], (
            ch.name, k / k_true[i] - 1)
        s = np.array([e.value for e in ch.sense_axis])
        angle = math.acos(min(1.0, float(s @ s_true[i]))) / RAD_PER_ARCSEC
        assert angle < tol['sense_axis_arcsec'], (ch.name, angle)
        assert ch.bias_rad_s is not None, ch.bias_missing  # along s_i, Earth rate removed (§F.5)
        bias_deg_h = ch.bias_rad_s.value / RAD_PER_ARCSEC  # ″/s = °/h
        assert abs(bias_deg_h - truth['bias_deg_h_along_sense_axes'][i]) < tol['bias_deg_h'], (
            ch.name, bias_deg_h)


def test_two_axis_bag_gives_its_truth_through_the_estimator() -> None:
    bag = _read('triad_two_axis_bench')
    exp = yaml.safe_load((BAGS / 'triad_two_axis_bench.expected.yaml').read_text())
    lat, heading = float(bag.bench['latitude_deg']), float(bag.bench['heading_deg'])
    tilt = math.radians(float(bag.bench['tilt_deg']))
    inner = _pairs(bag, 'rate_table', int(bag.bench['revolutions_per_window']),
                   lambda w: (inner_axis_direction(), np.zeros((3, 1))),
                   lambda w: earth_rate_along(inner_axis_enu(
                       tilt_rad=tilt, heading_deg=heading,
                       position_table_angle_rad=w.station_rad), lat))
    outer = _pairs(bag, 'position_table', int(bag.bench['position_table_revolutions']),
                   lambda w: (lambda ud: (ud[0], ud[1][:, :1]))(
                       outer_axis_direction(w.station_rad, tilt)),
                   lambda w: earth_rate_along([0.0, 0.0, 1.0], lat))
    assert len(inner) == exp['inner_window_pairs'] and len(outer) == exp['stations']
    res = triad_calibration(inner + outer, parameters=[
        BenchParameter(TILT, float(bag.bench['tilt_std_arcsec']) * RAD_PER_ARCSEC,
                       fitted=True)])
    _check(res, exp['truth'], exp['tolerance'])
    fitted = res.parameters[TILT].value / RAD_PER_ARCSEC  # the correction to the stated α
    true_error = (math.radians(exp['truth']['tilt_deg']) - tilt) / RAD_PER_ARCSEC
    assert abs(fitted - true_error) < exp['tolerance']['tilt_arcsec'], (fitted, true_error)


def test_six_remount_bags_give_the_triad_through_the_estimator() -> None:
    group = 'triad_remount_bench'
    pairs = []
    exp: dict[str, Any] = {}
    for suffix in ('px', 'mx', 'py', 'my', 'pz', 'mz'):
        name = f'{group}_{suffix}'
        bag = _read(name)
        exp = yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text())
        axis = str(bag.bench['mount_axis'])
        lat = float(bag.bench['latitude_deg'])
        u = remount_direction(axis)
        found = _pairs(bag, 'rate_table', int(bag.bench['revolutions_per_window']),
                       lambda w, u=u: (u, None),  # type: ignore[misc]
                       lambda w, lat=lat: earth_rate_along(  # type: ignore[misc]
                           [0.0, 0.0, 1.0], lat))
        assert len(found) == exp['inner_window_pairs'], name
        pairs += found
    _check(triad_calibration(pairs), exp['truth'], exp['tolerance'])
