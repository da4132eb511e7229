"""The multiposition results on the real recordings, as tables (docs/multiposition.md).

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/multiposition_real.py

Prints the Xsens comparison with IMU-TK (its own g, 9.81744 m/s²; the misalignments, which
IMU-TK does not publish, from its re-implementation test/peers/imu_tk_reference.py), the
Ferraris session beside imucal 2.6.0 (when installed), the three MPU-9150 units with their
spread, and the conditioning line of each recording.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from gyro_calib.multiposition.calibrator import calibrate, inverse_scale, misalignment_deg
from gyro_calib.multiposition.ferraris import ferraris
from gyro_calib.multiposition.readers import read_imu_tk, read_imucal, read_xyz6

REAL = Path(__file__).resolve().parents[1] / 'test' / 'data' / 'real'
sys.path.insert(0, str(REAL.parents[1]))  # test/: the IMU-TK peer (test/peers/)

from peers.imu_tk_reference import calibrate as imu_tk_calibrate  # noqa: E402

IMU_TK = {'gyro inverse scale': [4777.96, 4764.21, 4773.66],
          'gyro bias': [32777.14, 32459.80, 32511.85],
          'accelerometer inverse scale': [414.459, 412.010, 414.649],
          'accelerometer bias': [33124.18, 33275.18, 32364.42]}


def xsens() -> None:
    """Ours against IMU-TK's on its Xsens recording."""
    rec = read_imu_tk(REAL / 'imu_tk_xsens' / 'xsens_acc.mat.xz',
                      REAL / 'imu_tk_xsens' / 'xsens_gyro.mat.xz')
    r = calibrate(rec, gravity_m_s2=9.81744, gravity_std_m_s2=0.0)
    assert r.accelerometer is not None and r.gyro is not None
    peer = imu_tk_calibrate(REAL / 'imu_tk_xsens' / 'xsens_acc.mat.xz',
                            REAL / 'imu_tk_xsens' / 'xsens_gyro.mat.xz', g=9.81744)
    peer_angles = {'accelerometer': np.degrees(peer.acc.misalignment[:3]),
                   'gyro': np.degrees(peer.gyro.misalignment)}
    print('## Xsens MTi (IMU-TK recording), counts')
    print('| quantity | axis | ours | u (k = 1) | ν | IMU-TK | ours − IMU-TK | in 95 % interval |')
    print('|---|---|---|---|---|---|---|---|')
    for sensor, fit in (('accelerometer', r.accelerometer), ('gyro', r.gyro)):
        inv, u_inv = inverse_scale(fit)
        bias = fit.bias_raw
        u_bias = fit.std[-3:]
        from scipy import stats
        for label, vals, us, nus in ((f'{sensor} inverse scale', inv, u_inv, fit.dof[-6:-3]),
                                     (f'{sensor} bias', bias, u_bias, fit.dof[-3:])):
            for j, axis in enumerate('xyz'):
                peer = IMU_TK[label][j]
                k = float(stats.t.ppf(0.975, min(float(nus[j]), 1e6)))
                diff = vals[j] - peer
                print(f'| {label} | {axis} | {vals[j]:.2f} | {us[j]:.2f} | {nus[j]:.0f} | '
                      f'{peer:.2f} | {diff:+.2f} ({diff / peer * 100:+.3f} %) | '
                      f'{"yes" if abs(diff) <= k * us[j] else "no"} |')
        for j, (name, (v, u)) in enumerate(misalignment_deg(fit).items()):
            theirs = float(peer_angles[sensor][j])
            k = float(stats.t.ppf(0.975, min(float(fit.dof[j]), 1e6)))
            print(f'| {sensor} {name[:-4]} | | {v:.4f}° | {u:.4f}° | {fit.dof[j]:.0f} | '
                  f'{theirs:.4f}° (peer) | {v - theirs:+.4f}° | '
                  f'{"yes" if abs(v - theirs) <= k * u else "no"} |')
    print()
    for line in r.conditioning:
        print(f'conditioning: {line}')
    print(f'static intervals: {len(r.detection.intervals)} used, {len(r.detection.rejected)} '
          'rejected')
    print(f'residual RMS: accelerometer {r.accelerometer.residual_rms:.2e} m/s², gyro '
          f'{r.gyro.residual_rms:.2e} (unit vector)')
    print()


def imucal_session() -> None:
    """The Ferraris variant on imucal's example session, beside imucal when installed."""
    path = REAL / 'imucal' / 'example_ferraris_session.csv.xz'
    sections = {k: (v['start'], v['end']) for k, v in json.loads(
        (REAL / 'imucal' / 'example_ferraris_session_list.json').read_text()).items()}
    rec = read_imucal(path, 102.4)
    from gyro_calib.multiposition.recording import Recording
    raw = Recording(rec.t_s, rec.acc, rec.gyro, 'm/s²', 'deg/s')
    ours = ferraris(raw, sections, rate_hz=102.4, gravity=9.81, angle_rad=-360.0)
    theirs = None
    try:
        import lzma

        import imucal
        import pandas as pd
        with lzma.open(path, 'rt') as f:
            data = pd.read_csv(f, header=0, index_col=0)
        regions = imucal.ferraris_regions_from_section_list(data, pd.read_json(
            REAL / 'imucal' / 'example_ferraris_session_list.json').T)
        theirs = imucal.FerrarisCalibration().compute(regions, 102.4, from_acc_unit='m/s^2',
                                                      from_gyr_unit='deg/s')
    except ImportError:
        pass
    print('## imucal Ferraris example session (m/s², deg/s)')
    print('| quantity | ours | u (k = 1) | imucal 2.6.0 | |ours − imucal| |')
    print('|---|---|---|---|---|')
    for name in ('K_a', 'b_a', 'K_g', 'b_g'):
        v, u = ours.values[name], ours.std(name)
        t = np.diag(getattr(theirs, name)) if theirs is not None and name.startswith('K') \
            else (np.asarray(getattr(theirs, name)) if theirs is not None else None)
        for j, axis in enumerate('xyz'):
            peer = f'{t[j]:.6f}' if t is not None else '—'
            d = f'{abs(v[j] - t[j]):.1e}' if t is not None else '—'
            print(f'| {name} {axis} | {v[j]:.6f} | {u[j]:.1e} | {peer} | {d} |')
    for name in ('R_a', 'R_g'):
        off = ours.values[name] - np.diag(np.diag(ours.values[name]))
        print(f'| {name} largest off-diagonal | {np.max(np.abs(off)):.5f} '
              f'({math.degrees(float(np.max(np.abs(off)))):.2f}°) | | | |')
    print()
    print(f'basis: {ours.basis}')
    print()


def mpu9150() -> None:
    """Each unit with u, then the unit-to-unit spread."""
    print('## MPU-9150 units (mikoff/imu-calib), g = 9.80665 ± 0.015 m/s² (site unknown)')
    print('| unit | acc scale x / y / z − 1 (%) | acc bias x / y / z (m/s²) | '
          'gyro scale x / y / z − 1 (%) | gyro bias x / y / z (mrad/s) | poses | conditioning |')
    print('|---|---|---|---|---|---|---|')
    scales = []
    for unit in range(3):
        rec = read_xyz6(REAL / 'mikoff_mpu9150' / f'imu{unit}.log.xz', 100.0)
        r = calibrate(rec, gravity_m_s2=9.80665, gravity_std_m_s2=0.015)
        a, g = r.accelerometer, r.gyro
        assert a is not None and g is not None
        sa, ua = a.values[3:6], a.std[3:6]
        sg, ug = g.values[6:9], g.std[6:9]
        scales.append(np.concatenate((sa, sg)))
        print(f'| {unit} | ' + ' / '.join(f'{(s - 1) * 100:+.2f}±{u * 100:.2f}'
                                         for s, u in zip(sa, ua, strict=True))
              + ' | ' + ' / '.join(f'{b:+.3f}±{u:.3f}' for b, u in zip(
                  a.bias_raw, a.std[6:9], strict=True))
              + ' | ' + ' / '.join(f'{(s - 1) * 100:+.2f}±{u * 100:.2f}'
                                   for s, u in zip(sg, ug, strict=True))
              + ' | ' + ' / '.join(f'{b * 1e3:+.2f}±{u * 1e3:.2f}' for b, u in zip(
                  g.bias_raw, g.std[9:12], strict=True))
              + f' | {a.n_used} | {r.conditioning[0].split(";")[-1].strip()}; '
              f'{r.conditioning[1].split(";")[-1].strip()} |')
    spread = np.std(np.array(scales), axis=0, ddof=1) * 100
    print(f'| spread (s, %) | {spread[0]:.2f} / {spread[1]:.2f} / {spread[2]:.2f} | | '
          f'{spread[3]:.2f} / {spread[4]:.2f} / {spread[5]:.2f} | | | |')


if __name__ == '__main__':
    xsens()
    imucal_session()
    mpu9150()
