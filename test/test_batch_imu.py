"""``gyro-calib batch`` with IMUs (issue 37): triads beside a gyro in one manifest.

Three simulated triads — two on the two-axis bench, one remounted on a single-axis table (one
bag per mount) — written here from the bench kinematics (test/triad_bench_physics.py, not
sim_nodes), a FOG gyro from its committed bag and a broken bag run in one fleet. Each IMU gets
its hand-off and certificate and three rows in fleet.csv/.parquet, one per channel, with its
values in SI, u, ν and verdicts; the gyro keeps its rows per quantity; the broken bag is one
row naming it. The fleet page gives Cpk per channel and quantity. A re-run skips them all.
"""

from __future__ import annotations

import csv
import json
import math
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from dask_helpers import in_process_client
from triad_bench_physics import Bench, Recording, random_triad, record

from gyro_calib import topics
from gyro_calib.batch.fleet import IMU_COLUMNS
from gyro_calib.batch.manifest import load_manifest
from gyro_calib.batch.run import run_batch
from gyro_calib.handoff import load_calibration
from gyro_calib.registry import handoff_schema
from gyro_calib.report.spec import load_spec

BAGS = Path(__file__).resolve().parent.parent / 'bags'
CHANNELS = ('gx', 'gy', 'gz')
IMUS = ('IMU-1', 'IMU-2', 'IMU-3')
STATIONS = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
SPEC = {'quantities': {
    'imu.scale_factor_rad_per_pulse': {'unit': '″/pulse', 'min': 0.5, 'max': 5.0},
    'imu.misalignment_rad': {'unit': '″', 'min': -1100.0, 'max': 1100.0},
    'imu.bias_rad_s': {'unit': '°/h', 'min': -1.0, 'max': 1.0},
    'fog_scale_factor_counts_per_rad': {'min': 0.0, 'max': 1e12}}}


class FastJointStates:
    """/imu/pulses JointState CDR of the three channels: one serialised template, patched.

    The bytes equal ``ContractMessages.joints_state`` (checked on the first message); patching
    the stamp and positions is what makes a bag of 10⁴ messages take a fraction of a second.
    """

    def __init__(self) -> None:
        from gyro_calib.bagio.writer import ContractMessages

        self.cdr = ContractMessages()
        sec, nsec, pos = 123456789, 987654321, (1.25, 2.5, 3.75)
        self.template = self.cdr.joints_state(sec * 10**9 + nsec, CHANNELS, pos)
        self.stamp_at = self.template.find(struct.pack('<iI', sec, nsec))
        self.positions_at = self.template.find(struct.pack('<3d', *pos))

    def __call__(self, t_ns: int, positions: list[float]) -> bytes:
        out = bytearray(self.template)
        struct.pack_into('<iI', out, self.stamp_at, *divmod(t_ns, 10**9))
        struct.pack_into('<3d', out, self.positions_at, *positions)
        return bytes(out)


def write_triad_bag(path: Path, rec: Recording, bench: Bench) -> None:
    """The bench's topics and its settings (as a simulated bag stores them)."""
    from gyro_calib.bagio.writer import BagMessage, write_bag

    pulses = FastJointStates()
    first_t, first_c = int(rec.pulse_t[0]), rec.counts[0].tolist()
    assert pulses(first_t, first_c) == pulses.cdr.joints_state(first_t, CHANNELS, first_c)
    cdr = pulses.cdr
    msgs = [BagMessage(topics.IMU_PULSES, t, pulses(t, c))
            for t, c in zip(rec.pulse_t.tolist(), rec.counts.tolist(), strict=True)]
    for topic, joint, t_arr, v in (
            (topics.RATE_TABLE_JOINT_STATES, 'rate_table', rec.rate_t, rec.rate),
            (topics.POSITION_TABLE_JOINT_STATES, 'position_table', rec.position_t,
             rec.position)):
        msgs += [BagMessage(topic, t, cdr.joint_state(t, joint, a, w))
                 for t, (a, w) in zip(t_arr.tolist(), v.tolist(), strict=True)]
    for topic, t_arr in ((topics.RATE_TABLE_ZERO_INDEX, rec.rate_index),
                         (topics.POSITION_TABLE_ZERO_INDEX, rec.position_index)):
        msgs += [BagMessage(topic, t, cdr.header(t, '')) for t in t_arr.tolist()]
    msgs.sort(key=lambda m: m.log_time_ns)
    settings = {'revolutions_per_window': bench.inner_turns, 'latitude_deg': bench.latitude_deg,
                'heading_deg': bench.heading_deg}
    if bench.remount_axis:
        settings['mount_axis'] = bench.remount_axis
    else:
        settings.update({'tilt_deg': math.degrees(bench.tilt_rad), 'tilt_std_arcsec': 60.0,
                         'position_table_revolutions': bench.position_turns})
    write_bag(path, msgs, scenario={'bench': settings})


def imu_bags(tmp: Path) -> dict[str, list[Path]]:
    """IMU-1, IMU-2 on the two-axis bench; IMU-3 remounted (+x, +y, +z up)."""
    out: dict[str, list[Path]] = {}
    fast = {'inner_pairs': 1, 'inner_turns': 1, 'pulse_hz': 100.0, 'encoder_hz': 50.0}
    for n, gid in enumerate(IMUS):
        rng = np.random.default_rng(40 + n)
        triad = random_triad(rng)
        if gid != 'IMU-3':
            bench = Bench(stations_rad=STATIONS, **fast)  # type: ignore[arg-type]
            write_triad_bag(tmp / gid, record(bench, triad, rng), bench)
            out[gid] = [tmp / gid]
            continue
        out[gid] = []
        for axis in ('+x', '+y', '+z'):  # two pairs a mount: 6 pairs, ν = 3
            bench = Bench(remount_axis=axis, **{**fast, 'inner_pairs': 2})  # type: ignore[arg-type]
            path = tmp / f'{gid}_mount{axis[1]}'
            write_triad_bag(path, record(bench, triad, rng), bench)
            out[gid].append(path)
    return out


@pytest.fixture(scope='module')
def client() -> Iterator[Any]:
    """An in-process cluster (the tasks share this process; no worker start-up)."""
    with in_process_client() as c:
        yield c


@pytest.fixture(scope='module')
def fleet(tmp_path_factory: pytest.TempPathFactory, client: Any) -> dict[str, Any]:
    tmp = tmp_path_factory.mktemp('imu_fleet')
    bags = imu_bags(tmp)
    broken = tmp / 'broken_bag'
    broken.mkdir()
    (broken / 'metadata.yaml').write_text('rosbag2_bagfile_information: [not closed\n')
    (broken / 'broken_bag_0.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\0' * 64)
    gyros = [{'id': gid, 'bags': [str(b) for b in bags[gid]]} for gid in IMUS]
    gyros.insert(2, {'id': 'X-1', 'bags': [str(broken)]})
    gyros.append({'id': 'F-1', 'bags': [str(BAGS / 'fog_turntable')]})
    manifest = tmp / 'fleet.yaml'
    manifest.write_text(yaml.safe_dump({'gyros': gyros}), encoding='utf-8')
    spec = tmp / 'spec.yaml'
    spec.write_text(yaml.safe_dump(SPEC, allow_unicode=True), encoding='utf-8')
    out = tmp / 'out'
    outcome = run_batch(load_manifest(manifest), out, client=client, spec=load_spec(spec),
                        spec_path=spec, pdf=False)
    return {'out': out, 'outcome': outcome, 'manifest': manifest, 'spec': spec}


def csv_rows(out: Path) -> list[dict[str, str]]:
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        return list(csv.DictReader(stream))


def test_each_imu_is_calibrated_and_certified_and_the_broken_bag_is_named(
        fleet: dict[str, Any]) -> None:
    outcome, out = fleet['outcome'], fleet['out']
    status = {r['gyro_id']: r['status'] for r in outcome.records}
    assert status == {'IMU-1': 'ok', 'IMU-2': 'ok', 'X-1': 'failed', 'IMU-3': 'ok', 'F-1': 'ok'}
    broken = next(r for r in outcome.records if r['gyro_id'] == 'X-1')
    assert 'broken_bag' in broken['reason'] and 'metadata.yaml' in broken['reason']
    for gid in IMUS:
        imu = load_calibration(out / gid / f'{gid}.yaml', handoff_schema()).imu
        assert imu is not None and imu.channels == CHANNELS
        html = (out / gid / f'{gid}.html').read_text(encoding='utf-8')
        assert f'— IMU {gid}</h1>' in html and 'id="imu-conditions"' in html
    remount = (out / 'IMU-3' / 'IMU-3.html').read_text(encoding='utf-8')
    assert 'remount on a single-axis rate table' in remount


def test_three_rows_per_imu_one_per_channel_in_csv_and_parquet(fleet: dict[str, Any]) -> None:
    import pyarrow.parquet as pq

    out = fleet['out']
    rows = csv_rows(out)
    for gid in IMUS:
        mine = [r for r in rows if r['gyro_id'] == gid]
        assert [r['channel'] for r in mine] == list(CHANNELS), gid
        imu = load_calibration(out / gid / f'{gid}.yaml', handoff_schema()).imu
        assert imu is not None and imu.scale_factor_rad_per_pulse is not None
        assert imu.scale_factor_rad_per_pulse_std is not None and imu.bias_rad_s is not None
        assert imu.scale_factor_rad_per_pulse_dof is not None and imu.misalignment_rad is not None
        for i, row in enumerate(mine):
            assert row['method'] == 'triad' and row['key'] == '' and row['overall'] == 'PASS'
            assert float(row['imu_scale_factor_rad_per_pulse']) == \
                imu.scale_factor_rad_per_pulse[i]  # SI, as the hand-off
            assert float(row['imu_scale_factor_rad_per_pulse_std']) == \
                imu.scale_factor_rad_per_pulse_std[i]
            assert int(row['imu_scale_factor_rad_per_pulse_dof']) == \
                int(imu.scale_factor_rad_per_pulse_dof[i])
            assert float(row['imu_bias_rad_s']) == imu.bias_rad_s[i]
            own = f'imu_misalignment_{"xyz"[i]}_rad'
            assert row[own] == ''  # a sense axis has no misalignment toward its own axis
            for j, e in enumerate('xyz'):
                if j != i:
                    assert float(row[f'imu_misalignment_{e}_rad']) == imu.misalignment_rad[i][j]
                    assert row[f'imu_misalignment_{e}_rad_verdict'] == 'PASS'
            assert row['imu_non_orthogonality_with'] == CHANNELS[(i + 1) % 3]
            assert row['imu_scale_factor_rad_per_pulse_verdict'] == 'PASS'
    gyro = [r for r in rows if r['gyro_id'] == 'F-1']
    assert len(gyro) > 1 and all(r['key'] and r['channel'] == '' for r in gyro)
    assert [r['reason'] for r in rows if r['gyro_id'] == 'X-1'] != ['']
    table = pq.read_table(out / 'fleet.parquet').to_pylist()
    assert [(t['gyro_id'], t['channel'] or '') for t in table] == \
        [(r['gyro_id'], r['channel']) for r in rows]
    for t, r in zip(table, rows, strict=True):
        for column in IMU_COLUMNS:
            assert (t[column] if t[column] is not None else '') == (
                type(t[column])(r[column]) if r[column] != '' else ''), column


def test_the_fleet_page_gives_cpk_per_channel_and_quantity(fleet: dict[str, Any]) -> None:
    page = (fleet['out'] / 'fleet.html').read_text(encoding='utf-8')
    for c in CHANNELS:
        for key in (f'imu.{c}.scale_factor_rad_per_pulse', f'imu.{c}.axis_angle_rad'):
            assert f'data-key="{key}"' in page
    section = page.split('data-key="imu.gy.scale_factor_rad_per_pulse"')[1].split('</section>')[0]
    assert '0.5 … 5 ″/pulse' in section and 'ppm of the mean' in section
    cpk = section.split('<th>Cpk</th>')[1]
    cells = cpk.split('<td>')
    assert any(c.split('</td>')[0].replace('.', '').isdigit() for c in cells)  # a number
    records = [json.loads(line) for line in (fleet['out'] / 'fleet.jsonl').read_text()
               .splitlines()]
    imu1 = next(r for r in records if r['gyro_id'] == 'IMU-1')
    assert imu1['certificate']['item'] == 'IMU'


def test_a_rerun_skips_every_imu_and_the_gyro(fleet: dict[str, Any], client: Any) -> None:
    out = fleet['out']
    done = [*IMUS, 'F-1']
    stamps = {g: (out / g / f'{g}.html').stat().st_mtime_ns for g in done}
    again = run_batch(load_manifest(fleet['manifest']), out, client=client,
                      spec=load_spec(fleet['spec']), spec_path=fleet['spec'], pdf=False)
    assert sorted(again.skipped) == sorted(done)
    assert again.failed == ['X-1']
    assert {g: (out / g / f'{g}.html').stat().st_mtime_ns for g in done} == stamps
    assert [r['channel'] for r in csv_rows(out) if r['gyro_id'] == 'IMU-2'] == list(CHANNELS)
