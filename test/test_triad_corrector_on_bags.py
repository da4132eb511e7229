"""imu_corrector in triad mode on the committed bags: body rates covered by their covariance.

Issue 26 §3, METHODS §F.6 eqs. (16)–(17): the body rates against the simulator's truth.

The hand-off is `gyro-calib calibrate --method triad` of the committed bags (the two-axis bag;
the six remount bags together). The bag's /imu/pulses go, message by message, through the
rclpy-free core :class:`~gyro_calib.nodes.imu_corrector_core.ImuCorrector`. The truth is
recomputed from the scenario's tables (``sim_nodes/triad``): the body's orientation R_PB at
every stamp composed from the true table angles, and over each sample step exactly what the
gyros integrate — rotvec(R₀ᵀR₁)/Δt plus the Earth rate in the body at the step's midpoint —
so during table accelerations it is the mean rate over the step, as the counts are.

Per sample the error is dominated by quantisation, which §F.6 models as 1/6 pulse² per count
difference (±½ pulse uniform and independent at both ends). At a constant rate the two ends
are not independent: with f the fractional part of the true increment in pulses, the error
is −f or 1 − f and its variance f(1 − f), between 0 (at rest) and 1/4 (f = ½), 1/6 on
average over f. So the mean χ² = eᵀC⁻¹e of a bag is 3 only on average over rates; in each
stretch of the bag it must equal the prediction tr(C⁻¹Σ) with Σ from f(1 − f) and the
gyros' ARW — which checks ω (M, b, Δt, channel order) against the truth, and the
covariance's coverage — and can never exceed 3·(1/4)/(1/6) = 4.5.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from fake_node import FakeNode

from gyro_calib.bagio import iter_raw_messages, typestore
from gyro_calib.cli import main as gyro_calib
from gyro_calib.nodes.imu_corrector_core import IMU_DATA, ImuCorrector
from gyro_calib.units import ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H, NS_PER_S, RAD_PER_ARCSEC
from sim_nodes.scenarios import SCENARIOS
from sim_nodes.triad.bench import CHUNK_SAMPLES
from sim_nodes.triad.gyros import TriadGyroSimulator
from sim_nodes.triad.scenarios import TriadScenario

BAGS = Path(__file__).resolve().parents[1] / 'bags'
REMOUNTS = [f'triad_remount_bench_{m}' for m in ('px', 'mx', 'py', 'my', 'pz', 'mz')]
PREDICTION_TOLERANCE = 0.03
"""Allowed relative difference of a stretch's mean χ² from its prediction (≥ 1000 samples;
the errors are deterministic saw-teeth, so the means agree far better than 1/√n)."""
MIN_STRETCH = 1000
"""Samples a stretch of one table rate needs to be checked on its own."""
Array = npt.NDArray[np.float64]


@dataclass
class _Run:
    stamps: npt.NDArray[np.int64]
    omega: Array  # published, (n − 1, 3)
    covariance: Array  # published, (n − 1, 3, 3)
    truth: Array  # mean body rate over each step, (n − 1, 3)
    predicted_error_covariance: Array  # Σ from f(1 − f) and ARW, (n − 1, 3, 3)


def _truth(scenario: TriadScenario, stamps: npt.NDArray[np.int64], counts: Array
           ) -> tuple[Array, Array]:
    """The mean body rate over each step and the true phase increments, from the tables."""
    bench = scenario.bench()
    rate_sim, pos_sim = bench.simulators()
    gyro = TriadGyroSimulator(bench.gyros, bench.mount)
    t, chi, psi, n = [], [], [], []
    while not rate_sim.finished:  # as TriadBench.chunks, keeping the true angles
        r = rate_sim.step(CHUNK_SAMPLES)
        q = pos_sim.step(CHUNK_SAMPLES) if pos_sim is not None else None
        c = q.true_angle_rad if q is not None else np.zeros_like(r.true_angle_rad)
        t.append(r.t_ns)
        chi.append(c)
        psi.append(r.true_angle_rad)
        n.append(gyro.step(r.t_ns, c, r.true_angle_rad))
    assert np.array_equal(np.concatenate(t), stamps), 'not the scenario of this bag'
    assert np.array_equal(np.concatenate(n), counts), 'not the scenario of this bag'
    chi_a, psi_a = np.concatenate(chi), np.concatenate(psi)
    dt = np.diff(stamps) / NS_PER_S
    rot = bench.mount.orientation(chi_a, psi_a)
    mid = bench.mount.orientation(0.5 * (chi_a[1:] + chi_a[:-1]), 0.5 * (psi_a[1:] + psi_a[:-1]))
    truth = (rot[:-1].inv() * rot[1:]).as_rotvec() / dt[:, None] \
        + mid.inv().apply(bench.gyros.earth_rate_base_rad_s())
    s, k = bench.gyros.unit_sense_axes(), bench.gyros.scale_factor_rad_per_pulse()
    bias = np.asarray(bench.gyros.bias_deg_h) * RAD_PER_ARCSEC  # °/h = ″/s
    increment = (truth @ s.T + bias) * dt[:, None] / k  # pulses per step, without noise
    return np.asarray(truth, dtype=np.float64), np.asarray(increment, dtype=np.float64)


def _replay(name: str, handoff: Path) -> _Run:
    store = typestore()
    stamps, counts, names = [], [], None
    for topic, msgtype, _, raw in iter_raw_messages(BAGS / name):
        if topic == '/imu/pulses':
            msg = store.deserialize_cdr(raw, msgtype)
            stamps.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            counts.append(list(msg.position))
            names = list(msg.name)
    assert names is not None
    corrector = ImuCorrector(FakeNode())
    corrector.poll_file(str(handoff))
    assert corrector.output == IMU_DATA
    outs = []
    for t, c in zip(stamps, counts, strict=True):
        outs += corrector.on_imu_pulses(t, names, c)
    t_arr = np.array(stamps, dtype=np.int64)
    assert [o.stamp_ns for _, o in outs] == stamps[1:]  # one body rate per step, its stamp
    scenario = SCENARIOS[name]
    assert isinstance(scenario, TriadScenario)
    truth, increment = _truth(scenario, t_arr, np.array(counts))
    dt = np.diff(t_arr) / NS_PER_S
    f = increment - np.floor(increment)
    gyros = scenario.bench().gyros
    arw_pulses2 = (np.asarray(gyros.angle_random_walk_deg_sqrt_h)
                   * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H
                   / np.asarray(gyros.scale_factor_arcsec_per_pulse)) ** 2 * dt[:, None]
    m = gyros.pulses_to_body_rad()
    sigma = np.einsum('ij,nj,kj->nik', m, f * (1 - f) + arw_pulses2, m) / dt[:, None, None] ** 2
    return _Run(t_arr, np.array([o.angular_velocity_rad_s for _, o in outs]),
                np.array([o.covariance_rad2_s2 for _, o in outs]).reshape(-1, 3, 3),
                truth, sigma)


def _stretches(run: _Run) -> dict[str, npt.NDArray[np.bool_]]:
    """Samples by true |ω| (to 1 mrad/s): each rate held ≥ MIN_STRETCH samples, and the rest."""
    speed = np.round(np.linalg.norm(run.truth, axis=1), 3)
    values, n = np.unique(speed, return_counts=True)
    out = {f'|ω| = {v:g} rad/s': speed == v for v, c in zip(values, n, strict=True)
           if c >= MIN_STRETCH}
    rest = ~np.any(list(out.values()), axis=0)
    if rest.sum() >= MIN_STRETCH:
        out['changing rate and short holds'] = rest
    return out


def _check(run: _Run) -> float:
    err = run.omega - run.truth
    chi2 = np.einsum('ni,ni->n', err, np.linalg.solve(run.covariance, err[..., None])[..., 0])
    predicted = np.einsum('nii->n', np.linalg.solve(run.covariance,
                                                    run.predicted_error_covariance))
    lines, bad = [], []
    for label, sel in _stretches(run).items():
        obs, pred = float(chi2[sel].mean()), float(predicted[sel].mean())
        line = f'{label:<32} n {sel.sum():>6}  mean χ² {obs:.3f}  predicted {pred:.3f}'
        lines.append(line)
        if abs(obs / pred - 1) > PREDICTION_TOLERANCE or obs > 4.5:
            bad.append(line)
    overall = float(chi2.mean())
    lines.append(f'all {len(chi2)} samples: mean χ² {overall:.3f}, predicted '
                 f'{predicted.mean():.3f}')
    assert len(lines) >= 3 and not bad, '\n'.join(['off:', *bad, '-- all:', *lines])
    return overall


@pytest.fixture(scope='module')
def handoffs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp('triad_handoffs')
    paths = {'two_axis': out / 'two_axis.yaml', 'remount': out / 'remount.yaml'}
    assert gyro_calib(['calibrate', str(BAGS / 'triad_two_axis_bench'), '--method', 'triad',
                       '--out', str(paths['two_axis'])]) == 0
    assert gyro_calib(['calibrate', *[str(BAGS / n) for n in REMOUNTS], '--method', 'triad',
                       '--out', str(paths['remount'])]) == 0
    return paths


def test_two_axis_bag_body_rates_are_covered_by_the_published_covariance(
        handoffs: dict[str, Path]) -> None:
    """Both tables turning, at rest, accelerating: χ² as predicted; over the bag ≈ 3.

    The band for the whole bag, 2.5–3.5: with the rates of this procedure the quantisation
    variance averages close to the model's 1/6, so a right covariance gives 3 within ±1/6
    (σ within ±8 %); the bag holds 6 % samples at rest (χ² ≈ 0.3) and cruises at two rates
    (≈ 3.2 and ≈ 3.9).
    """
    overall = _check(_replay('triad_two_axis_bench', handoffs['two_axis']))
    assert 2.5 < overall < 3.5, overall


@pytest.mark.parametrize('mount', ['px', 'mz'])
def test_remount_bag_body_rates_are_covered_by_the_published_covariance(
        handoffs: dict[str, Path], mount: str) -> None:
    """One table rate dominates a remount bag: its χ² is that rate's, as predicted (≤ 4.5)."""
    _check(_replay(f'triad_remount_bench_{mount}', handoffs['remount']))
