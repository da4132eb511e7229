"""The drift a triad calibration removes, shown with navigation libraries nobody here wrote.

Issue 27 §3. A gyro triad is simulated from the physics (METHODS §F): the pulse rates are
ṅ = M⁻¹·(ω_B + b + β(t) + n(t)), with the true M (per-channel scale factor K_i = K₀·(1 + s_i),
sense axes misaligned by tens of arcseconds), a bias b, white rate noise n of density N
(angle random walk) and a bias random walk β of strength K. Two streams are made from the
same pulses:

- raw: the nominal calibration, ω = K₀·ṅ (nominal K, nominal axes, bias 0);
- calibrated: imu_corrector's maths with the hand-off's values, ω = M̂·ṅ − b̂, where the
  hand-off's b̂ differs from the truth by its stated uncertainty u(b) (drawn per seed).

(1) ``inu`` (PyPI): ``mech_inv`` gives the ideal sensor output of a trajectory (Earth rate
included), ``mech`` navigates the raw and the calibrated output (accelerometers ideal,
height aided) over (a) one hour static at a stated latitude and (b) a manoeuvring run; the
heading and attitude errors are printed (and plotted with ``--plot DIR``).

(2) GTSAM ``PreintegratedAhrsMeasurements`` with the noise terms ``gyro-calib export --format
gtsam`` writes from the triad's hand-off: the predicted attitude covariance (white noise from
GTSAM's own preintegration, bias uncertainty through its bias Jacobian, obtained from GTSAM by
perturbing the bias, bias random walk K²t³/3) against the error of the calibrated stream's
preintegrated rotation over many seeds: the calibrated heading error stays within 3σ and the
NEES is near 1; the raw one does not.

    python benchmarks/navigation_benefit.py [--seeds 50] [--static-s 3600] [--plot DIR]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

Array = npt.NDArray[np.float64]
DEG_H = math.pi / 180 / 3600  # rad/s per °/h
K0 = 4.0e-6  # nominal scale factor, rad/pulse
LATITUDE_DEG = 45.0
T_S = 0.1  # sample period of the navigation runs, s
N_ARW = 0.002 * math.pi / 180 / 60  # 0.002 °/√h in rad/√s
K_RRW = 1e-4 * DEG_H / 60  # 1e-4 °/h/√h in rad/s/√s
BIAS = np.array([0.3, -0.5, 0.8]) * DEG_H  # true triad bias, rad/s
BIAS_STD = 0.002 * DEG_H  # the hand-off's u(b), rad/s
SCALE_PPM = np.array([150.0, -220.0, 300.0])
MISALIGN_ARCSEC = np.array([[0.0, 40.0, -25.0], [-30.0, 0.0, 55.0], [20.0, -45.0, 0.0]])


@dataclass(frozen=True)
class Triad:
    """The true triad and the hand-off's estimates of it."""

    m: Array  # true M (ω_B = M·ṅ − b), rad/pulse
    bias: Array  # true b, rad/s


def true_triad() -> Triad:
    """K_i = K₀(1 + s_i), rows s_i = e_i + misalignment (unit), M = R⁻¹, r_i = s_i/K_i."""
    axes = np.eye(3) + MISALIGN_ARCSEC * math.pi / 180 / 3600
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    k = K0 * (1 + SCALE_PPM * 1e-6)
    r = axes / k[:, None]
    return Triad(np.asarray(np.linalg.inv(r), dtype=np.float64), BIAS.copy())


def pulse_rates(omega: Array, triad: Triad, rng: np.random.Generator, t_s: float) -> Array:
    """ṅ = M⁻¹·(ω + b + β + n) per sample (pulses/s; rows = samples)."""
    n = len(omega)
    white = rng.normal(0.0, N_ARW / math.sqrt(t_s), (n, 3))
    walk = np.cumsum(rng.normal(0.0, K_RRW * math.sqrt(t_s), (n, 3)), axis=0)
    return (np.linalg.inv(triad.m) @ (omega + triad.bias + walk + white).T).T


def streams(rates: Array, triad: Triad, bias_hat: Array) -> tuple[Array, Array]:
    """(raw, calibrated) body rates: K₀·ṅ, and M̂·ṅ − b̂ (imu_corrector's maths)."""
    return K0 * rates, (triad.m @ rates.T).T - bias_hat


def handoff_text(triad: Triad) -> str:
    """The triad's hand-off (format 4 ``imu:`` section with per-channel noise)."""
    from gyro_calib.imu_calibration import ImuCalibration

    noise = {c: {'angle_random_walk_rad_per_sqrt_s': N_ARW,
                 'angle_random_walk_rad_per_sqrt_s_std': N_ARW * 0.02,
                 'rate_random_walk_rad_per_s_sqrt_s': K_RRW,
                 'rate_random_walk_rad_per_s_sqrt_s_std': K_RRW * 0.2} for c in 'xyz'}
    imu = ImuCalibration(('x', 'y', 'z'), pulses_to_body_rad=triad.m,
                         pulses_to_body_rad_covariance=np.zeros((9, 9)),
                         bias_rad_s=triad.bias, bias_rad_s_std=np.full(3, BIAS_STD),
                         noise=noise)
    return yaml.safe_dump({'format_version': 4, 'gyro_id': 'SIM-TRIAD',
                           'imu': imu.to_section()}, sort_keys=False)


def exported_gtsam(triad: Triad) -> tuple[dict[str, Array], Array]:
    """GTSAM matrices from ``gyro-calib export --format gtsam`` of the triad's hand-off."""
    from gyro_calib.export import ExportOptions, export_text
    from gyro_calib.export.gtsam import gtsam_matrices
    from gyro_calib.export.source import read_source

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / 'triad.yaml'
        path.write_text(handoff_text(triad), encoding='utf-8')
        text = export_text(path, 'gtsam', ExportOptions())
        src = read_source(path)
    assert src.imu is not None and src.imu.bias_rad_s_std is not None
    return gtsam_matrices(text), np.diag(src.imu.bias_rad_s_std ** 2)


# -- trajectories ------------------------------------------------------------------------

def trajectory(kind: str, duration_s: float, t_s: float = T_S) -> tuple[Array, Array]:
    """(llh, rpy) rows: 'static' at LATITUDE_DEG heading 30°, or 'manoeuvring'."""
    n = int(round(duration_s / t_s))
    t = np.arange(n) * t_s
    llh = np.tile([math.radians(LATITUDE_DEG), 0.0, 100.0], (n, 1))
    rpy = np.zeros((n, 3))
    rpy[:, 2] = math.radians(30.0)
    if kind == 'manoeuvring':
        llh[:, 0] += 5.0 * t / 6.371e6  # 5 m/s north
        rpy[:, 0] = math.radians(5.0) * np.sin(2 * math.pi * t / 37.0)
        rpy[:, 1] = math.radians(3.0) * np.sin(2 * math.pi * t / 53.0)
        rpy[:, 2] += math.radians(90.0) * np.sin(2 * math.pi * t / 240.0) + 0.2 * t / 60.0
    return llh, rpy


def wrap(a: Array) -> Array:
    return (a + math.pi) % (2 * math.pi) - math.pi


def inu_errors(kind: str, duration_s: float, seed: int = 0) -> dict[str, Any]:
    """Heading and attitude errors of inu.mech with raw and calibrated rates, deg."""
    import inu

    llh, rpy = trajectory(kind, duration_s)
    fbbi, wbbi = inu.mech_inv(llh, rpy, T_S)
    triad = true_triad()
    rng = np.random.default_rng(seed)
    bias_hat = triad.bias + rng.normal(0.0, BIAS_STD, 3)
    raw, cal = streams(pulse_rates(wbbi, triad, rng, T_S), triad, bias_hat)
    vne0 = (llh[1] - llh[0]) / T_S * np.array([6.371e6, 0.0, 0.0])
    out: dict[str, Any] = {'t_s': np.arange(len(llh)) * T_S}
    for name, w in (('raw', raw), ('calibrated', cal)):
        _, _, r = inu.mech(fbbi, w, llh[0], vne0, rpy[0], T_S, hae_t=llh[:, 2],
                           show_progress=False)
        err = np.degrees(wrap(r - rpy))
        out[name] = {'heading_deg': err[:, 2], 'attitude_deg': np.hypot(err[:, 0], err[:, 1])}
    return out


# -- GTSAM consistency -----------------------------------------------------------------------

def preintegrate(params: Any, omega: Array, t_s: float, bias_hat: Array | None = None,
                 checks: tuple[int, ...] = ()) -> list[Any]:
    """The rotation and its covariance at each check index (PreintegratedAhrsMeasurements)."""
    import gtsam

    pim = gtsam.PreintegratedAhrsMeasurements(params, np.zeros(3) if bias_hat is None
                                              else bias_hat)
    out = []
    want = set(checks)
    for k, w in enumerate(omega):
        pim.integrateMeasurement(w, t_s)
        if k + 1 in want:
            # copies: the wheel hands out views of the integrator's own memory
            out.append((gtsam.Rot3(np.array(pim.deltaRij().matrix())),
                        np.array(pim.preintMeasCov(), copy=True)))
    return out


def consistency(seeds: int, duration_s: float, n_checks: int = 6,
                t_s: float = 1.0) -> dict[str, Any]:
    """Calibrated and raw rotation errors against GTSAM's predicted covariance, static."""
    import gtsam
    import inu

    llh, rpy = trajectory('static', duration_s, t_s)
    _, wbbi = inu.mech_inv(llh, rpy, t_s)
    triad = true_triad()
    m, bias_cov = exported_gtsam(triad)
    params = gtsam.PreintegratedRotationParams()
    params.setGyroscopeCovariance(m['gyroscope_covariance'])
    checks = tuple(int(round(len(wbbi) * (i + 1) / n_checks)) for i in range(n_checks))
    truth = preintegrate(params, wbbi, t_s, checks=checks)
    # the bias Jacobian of ΔR, from GTSAM itself: integrate with a perturbed bias estimate
    eps = 1e-7
    jac = np.zeros((n_checks, 3, 3))
    for j in range(3):
        shifted = preintegrate(params, wbbi, t_s, bias_hat=eps * np.eye(3)[j], checks=checks)
        for c in range(n_checks):
            jac[c][:, j] = gtsam.Rot3.Logmap(truth[c][0].between(shifted[c][0])) / eps
    k2 = np.diag(m['bias_omega_covariance'])
    times = np.array(checks) * t_s
    predicted = [truth[c][1] + jac[c] @ bias_cov @ jac[c].T + np.diag(k2) * times[c] ** 3 / 3
                 for c in range(n_checks)]
    errors: dict[str, list[Array]] = {'raw': [], 'calibrated': []}
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        bias_hat = triad.bias + rng.normal(0.0, BIAS_STD, 3)
        raw, cal = streams(pulse_rates(wbbi, triad, rng, t_s), triad, bias_hat)
        for name, w in (('raw', raw), ('calibrated', cal)):
            est = preintegrate(params, w, t_s, checks=checks)
            errors[name].append(np.array([gtsam.Rot3.Logmap(truth[c][0].between(est[c][0]))
                                          for c in range(n_checks)]))
    result: dict[str, Any] = {'t_s': times, 'sigma_heading_deg': np.degrees(
        np.sqrt([p[2, 2] for p in predicted]))}
    for name, errs in errors.items():
        e = np.array(errs)  # seeds × checks × 3
        nees = np.array([[e[s, c] @ np.linalg.solve(predicted[c], e[s, c])
                          for c in range(n_checks)] for s in range(len(e))]) / 3.0
        z = np.abs(e[:, :, 2]) / np.sqrt([p[2, 2] for p in predicted])
        result[name] = {'nees_mean': float(nees.mean()),
                        'within_3sigma': float(np.mean(z <= 3.0)),
                        'seeds_always_within_3sigma': int(np.sum(np.all(z <= 3.0, axis=1))),
                        'heading_rms_deg': np.degrees(np.sqrt(np.mean(e[:, :, 2] ** 2,
                                                                       axis=0)))}
    result['seeds'] = seeds
    return result


# -- main --------------------------------------------------------------------------------------

def _table(name: str, run: dict[str, Any], marks_s: list[float]) -> list[str]:
    t = run['t_s']
    rows = [f'{name}: heading / attitude error (deg) at', f'{"t (s)":>8s} {"raw heading":>12s} '
            f'{"cal heading":>12s} {"raw attitude":>13s} {"cal attitude":>13s}']
    for mark in marks_s:
        i = min(int(np.searchsorted(t, mark)), len(t) - 1)
        rows.append(f'{t[i]:8.0f} {run["raw"]["heading_deg"][i]:12.4f} '
                    f'{run["calibrated"]["heading_deg"][i]:12.5f} '
                    f'{run["raw"]["attitude_deg"][i]:13.5f} '
                    f'{run["calibrated"]["attitude_deg"][i]:13.6f}')
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the inu tables and the GTSAM consistency table (and plot with --plot)."""
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seeds', type=int, default=50)
    p.add_argument('--static-s', type=float, default=3600.0)
    p.add_argument('--manoeuvre-s', type=float, default=900.0)
    p.add_argument('--plot', type=Path, metavar='DIR')
    a = p.parse_args(argv)
    static = inu_errors('static', a.static_s)
    man = inu_errors('manoeuvring', a.manoeuvre_s)
    lines = _table(f'(a) static, {a.static_s:g} s at {LATITUDE_DEG:g}° N', static,
                   [a.static_s * f for f in (0.1, 0.25, 0.5, 1.0)])
    lines += [''] + _table(f'(b) manoeuvring, {a.manoeuvre_s:g} s', man,
                           [a.manoeuvre_s * f for f in (0.1, 0.25, 0.5, 1.0)])
    c = consistency(a.seeds, a.static_s)
    lines += ['', f'GTSAM PreintegratedAhrsMeasurements, exported noise terms, {c["seeds"]} '
              f'seeds, static {a.static_s:g} s:',
              f'{"t (s)":>8s} {"σ heading (deg)":>16s} {"raw rms":>10s} {"cal rms":>10s}']
    for i, t in enumerate(c['t_s']):
        lines.append(f'{t:8.0f} {c["sigma_heading_deg"][i]:16.5f} '
                     f'{c["raw"]["heading_rms_deg"][i]:10.4f} '
                     f'{c["calibrated"]["heading_rms_deg"][i]:10.5f}')
    for name in ('calibrated', 'raw'):
        r = c[name]
        lines.append(f'{name}: NEES mean {r["nees_mean"]:.3g}; heading within 3σ at '
                     f'{100 * r["within_3sigma"]:.1f} % of (seed, time); seeds within 3σ at '
                     f'every check: {r["seeds_always_within_3sigma"]} of {c["seeds"]}')
    print('\n'.join(lines))
    if a.plot is not None:
        import matplotlib

        matplotlib.use('Agg')
        import matplotlib.pyplot as plt

        a.plot.mkdir(exist_ok=True)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for ax, run, title in ((axes[0], static, 'static 1 h'), (axes[1], man, 'manoeuvring')):
            ax.plot(run['t_s'], np.abs(run['raw']['heading_deg']), label='raw heading')
            ax.plot(run['t_s'], np.abs(run['calibrated']['heading_deg']),
                    label='calibrated heading')
            ax.plot(run['t_s'], run['raw']['attitude_deg'], '--', label='raw tilt')
            ax.plot(run['t_s'], run['calibrated']['attitude_deg'], '--', label='calibrated tilt')
            ax.set_yscale('log')
            ax.set_xlabel('t (s)')
            ax.set_ylabel('|error| (deg)')
            ax.set_title(f'inu.mech, {title}')
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(a.plot / 'navigation_benefit.png', dpi=100)
        print(f'figure: {a.plot / "navigation_benefit.png"}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
