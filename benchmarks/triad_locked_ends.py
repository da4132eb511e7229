"""Why the triad over-covers at ARW 0: every window end's rounding is locked to one phase per gyro.

Run (from the repository root, niced; ~12 s a seed):

    PYTHONPATH=$PWD nice python benchmarks/triad_locked_ends.py --seeds 100 --save a.pkl
    PYTHONPATH=$PWD python benchmarks/triad_locked_ends.py --report a.pkl [b.pkl …]

``triad_two_axis_bench`` (sim_nodes, 250 Hz, ARW 0 stated) with each K_i drawn within ±0.1 %
per seed (``default_rng(9000 + seed)``: other gyros of the type, so no two runs share their
pulse offsets), through the real session. The same bench is recorded a second time unrounded
(``quantise=False``: the same start phases and motion, the counts before the floor), so the
rounding error of every sample is known. The pairs of each run are then solved seven times, with
the same estimates and seven covariances of the window ends' rounding (docs/methods/triad.md
§F.2 eq. (6a)):

- ``stated``: what the estimator states (eq. (6a) at the fit's own rate, ends independent);
- ``exact_ends``: each end's variance over a uniform start phase at the true sample phases,
  ends still independent;
- ``exact_pairs``: the exact covariance of the (up to four) ends within each pair — the end of
  a forward window and the start of its reverse lie at the same table angle, so their phases
  differ by the Earth rate and bias over the reversal alone, whatever K;
- ``exact_all``: the exact covariance of all ends of a gyro, across pairs too (one start phase
  per gyro; with no walk nothing randomises the offsets between its ends);
- ``measured_locked``: what an estimator could compute from its own data — the same locked
  covariance with the phases from the fits (the fitted count at the instant plus the fit's rate)
  and each offset smeared by the ends' own rounding variance (Fourier series of R, damped by
  exp(−2π²n²σ²));
- ``rate_averaged``: ends independent, each end's (6a) averaged over the uncertainty of the
  fit's rate (9-point Gauss–Hermite, the slope's u with the residuals read as white);
- ``consistent_locked``: as ``measured_locked`` with each end's phase and rate the centre of
  the set consistent with the whole-pulse counts of its fit span (count = floor(φ + ρ·τ) on every
  sample; where no linear phase is consistent, the fit's).

``--generator physics_paper``: the same on test/triad_bench_physics.py's paper plan (a random
triad per seed, ``default_rng(10_000 + seed)`` as benchmarks/triad_coverage.py, pulses at
500 Hz, its ``unrounded`` counts; ~30 s a seed).

Printed per variant: within ±1σ, rms z and max |z| for each of the nine parameters.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import pickle
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'test'))

from triad_bench_physics import Bench, random_triad, record  # noqa: E402
from triad_coverage_helpers import run_session, scores, session_of  # noqa: E402
from triad_start_phase import coverage_table, recording_of, scenario  # noqa: E402

import gyro_calib.triad.estimator as estimator  # noqa: E402
import gyro_calib.triad.session as triad_session  # noqa: E402
from gyro_calib.triad.quantisation import sawtooth_covariance  # noqa: E402
from gyro_calib.triad.solve import solve_pairs  # noqa: E402
from gyro_calib.windows import fit_half_width_ns  # noqa: E402

VARIANTS = ('stated', 'exact_ends', 'exact_pairs', 'exact_all', 'measured_locked',
            'rate_averaged', 'consistent_locked')
K_SPREAD = 1e-3
HARMONICS = np.arange(1, 65)
HERMITE_X, HERMITE_W = np.polynomial.hermite.hermgauss(9)

End = tuple[str, int]
Fit = tuple[np.ndarray, np.ndarray]


def smeared_sawtooth_covariance(d: np.ndarray, var: float) -> np.ndarray:
    """E[R(d + w)], w ~ N(0, var) pulses²: R's Fourier series Σ cos(2πnd)/(2π²n²), damped."""
    if var <= 0.0:
        return sawtooth_covariance(d)
    damp = np.exp(-2.0 * np.pi**2 * HARMONICS**2 * var) / (2.0 * np.pi**2 * HARMONICS**2)
    return np.asarray(np.cos(2.0 * np.pi * d[..., None] * HARMONICS) @ damp)


def _bench(seed: int, quantise: bool) -> tuple[Any, Any, Any]:
    k_scale = 1.0 + K_SPREAD * np.random.default_rng(9000 + seed).uniform(-1.0, 1.0, size=3)
    sc, gy = scenario(seed, k_scale, quantise)
    return sc, gy, sc.bench().record()


def _consistent_phases(x: np.ndarray, y: np.ndarray, slope: float, slope_std: float
                       ) -> np.ndarray | None:
    """Sample phases at the centre of the (φ, ρ) consistent with y = floor(φ + ρ·x); or None."""
    rates = slope + np.linspace(-5.0, 5.0, 401) * slope_std
    low = np.max(y[None, :] - rates[:, None] * x[None, :], axis=1)
    high = np.min(y[None, :] + 1.0 - rates[:, None] * x[None, :], axis=1)
    width = np.maximum(high - low, 0.0)
    if width.sum() <= 0.0:
        return None
    rate = float(width @ rates / width.sum())
    phase = float(width @ (0.5 * (low + high)) / width.sum())
    return np.asarray(phase + rate * x)


def _covariance_of(fits: dict[End, Fit], smear: bool) -> Callable[[End, End], float]:
    """Cov of the rounding errors of two end fits (w, phases), pulses² (eq. (6a) across ends)."""
    cache: dict[tuple[End, End], float] = {}

    def own(e: End) -> float:
        w, x = fits[e]
        return float(w @ sawtooth_covariance(x[:, None] - x[None, :]) @ w)

    def cov(e: End, f: End) -> float:
        if (e, f) not in cache:
            (we, xe), (wf, xf) = fits[e], fits[f]
            d = xe[:, None] - xf[None, :]
            r = smeared_sawtooth_covariance(d, own(e) + own(f)) if smear and e != f \
                else sawtooth_covariance(d)
            cache[(e, f)] = cache[(f, e)] = float(we @ r @ wf)
        return cache[(e, f)]
    return cov


def _with_end_covariance(pairs: list[tuple[Any, str]], cov: Callable[[End, End], float],
                         within: bool) -> list[tuple[Any, str]]:
    """The pairs with ΔN's and Σ's u from ``cov`` (ends correlated within a pair or not)."""
    out = []
    for p, label in pairs:
        if not p.end_terms:
            out.append((p, label))
            continue
        stamps = sorted(s for s, _, _ in p.end_terms)
        coef = {s: cf for s, cf, _ in p.end_terms}
        d = np.array([coef[s] for s in stamps])
        if len(stamps) == 4:
            t_sum = (stamps[1][1] - stamps[0][1] + stamps[3][1] - stamps[2][1]) / 1e9
            s_coef = np.array([-1.0, 1.0, -1.0, 1.0]) / t_sum
        else:  # windows back to back: the shared end cancels in the sum
            s_coef = np.array([-1.0, 0.0, 1.0]) / ((stamps[-1][1] - stamps[0][1]) / 1e9)
        diff, total, var = [], [], []
        for c in range(3):
            cm = np.array([[cov((a[0] + str(c), a[1]), (b[0] + str(c), b[1]))
                            if within or a == b else 0.0 for b in stamps] for a in stamps])
            diff.append(math.sqrt(max(float(d @ cm @ d), 0.0)))
            total.append(math.sqrt(max(float(s_coef @ cm @ s_coef), 0.0)))
            var.append(np.diag(cm))
        ends = tuple((s, coef[s], np.array([var[c][i] for c in range(3)]))
                     for i, s in enumerate(stamps))
        out.append((dataclasses.replace(p, model_difference_std=np.array(diff),
                                        model_sum_rate_std=np.array(total), end_terms=ends),
                    label))
    return out


def _recorded(generator: str, seed: int) -> tuple[Any, Any, np.ndarray, np.ndarray, np.ndarray,
                                                   np.ndarray, np.ndarray]:
    """(session, its settings, pulse stamps, counts, unrounded counts, K true, axes true)."""
    seen: list[Any] = []
    cut = triad_session.pair_windows

    def spy(*args: Any, **kw: Any) -> Any:
        seen.append(args[0])
        return cut(*args, **kw)

    triad_session.pair_windows = spy  # the session's settings, as it cuts
    try:
        if generator == 'sim_nodes':
            sc, gy, ch = _bench(seed, True)
            _, _, unrounded = _bench(seed, False)
            session = run_session(recording_of(ch), sc.bench_settings())
            return (session, seen[-1], ch.pulse_t_ns, ch.pulse_counts, unrounded.pulse_counts,
                    gy.scale_factor_rad_per_pulse(), gy.unit_sense_axes())
        rng = np.random.default_rng(10_000 + seed)  # as benchmarks/triad_coverage.py
        triad = random_triad(rng, arw_rad_sqrt_s=0.0)
        bench = Bench(inner_pairs=2, inner_turns=5, outer_margin_turns=0.6, pulse_hz=500.0)
        rec = record(bench, triad, rng)
        assert rec.unrounded is not None
        session = session_of(bench, rec)
        return (session, seen[-1], rec.pulse_t, rec.counts, rec.unrounded,
                triad.scale_factor_rad_per_pulse, triad.sense_axes)
    finally:
        triad_session.pair_windows = cut


def run(seed: int, generator: str = 'sim_nodes') -> dict[str, list[float]]:
    """The nine z of one run under each variant."""
    session, settings, t, counts, unrounded, k_true, s_true = _recorded(generator, seed)
    exact: dict[End, Fit] = {}
    measured: dict[End, Fit] = {}
    consistent: dict[End, Fit] = {}
    averaged: dict[End, float] = {}
    for p, _ in session.pairs:
        for (mount, at), _, _ in p.end_terms:
            h = fit_half_width_ns(settings, at, t)
            lo = int(np.searchsorted(t, at - h, 'left'))
            hi = int(np.searchsorted(t, at + h, 'right'))
            x = (t[lo:hi] - at) / 1e9
            solve = np.linalg.pinv(np.vander(x, settings.fit_order + 1, increasing=True))
            for c in range(3):
                key = (mount + str(c), at)
                exact[key] = (solve[0], unrounded[lo:hi, c])
                y = counts[lo:hi, c]
                fit = solve @ (y - y[0])
                measured[key] = (solve[0], y[0] + fit[0] + fit[1] * x)
                slope_std = math.sqrt(float(solve[1] @ solve[1]) / 12.0)
                averaged[key] = float(sum(
                    q * solve[0] @ sawtooth_covariance(
                        (fit[1] + math.sqrt(2.0) * slope_std * g) * (x[:, None] - x[None, :]))
                    @ solve[0] for g, q in zip(HERMITE_X, HERMITE_W / HERMITE_W.sum(),
                                               strict=True)))
                inside = _consistent_phases(x, y - y[0], fit[1], slope_std)
                consistent[key] = measured[key] if inside is None else (solve[0], y[0] + inside)
    exact_cov = _covariance_of(exact, smear=False)
    measured_cov = _covariance_of(measured, smear=True)
    consistent_cov = _covariance_of(consistent, smear=True)
    cases: dict[str, tuple[list[tuple[Any, str]], Callable[[End, End], float] | None]] = {
        'stated': (session.pairs, None),
        'exact_ends': (_with_end_covariance(session.pairs, exact_cov, within=False), None),
        'exact_pairs': (_with_end_covariance(session.pairs, exact_cov, within=True), None),
        'exact_all': (_with_end_covariance(session.pairs, exact_cov, within=True), exact_cov),
        'measured_locked': (_with_end_covariance(session.pairs, measured_cov, within=True),
                            measured_cov),
        'rate_averaged': (_with_end_covariance(
            session.pairs, lambda e, f: averaged[e] if e == f else 0.0, within=False), None),
        'consistent_locked': (_with_end_covariance(session.pairs, consistent_cov, within=True),
                              consistent_cov),
    }
    shared_ends = estimator._Solver._shared_ends
    out = {}
    for name, (pairs, across) in cases.items():
        if across is not None:
            estimator._Solver._shared_ends = _across_pairs(across)  # type: ignore[method-assign]
        try:
            stated, _, _ = solve_pairs(pairs, session.channels, session.bench.tilt_std_rad,
                                       np.zeros(3))
        finally:
            estimator._Solver._shared_ends = shared_ends  # type: ignore[method-assign]
        assert stated is not None
        out[name] = scores(stated, k_true, s_true)[0]
    return out


def _across_pairs(cov: Callable[[End, End], float]) -> Callable[..., np.ndarray]:
    """A ``_Solver._shared_ends`` with the covariance of every two ends of different pairs."""
    def shared(self: Any, whiten: list[np.ndarray], n_obs: int) -> np.ndarray:
        row, offset = [], 0
        for _, cs in self.groups:
            row.append(offset)
            offset += len(cs)
        raw = np.zeros((n_obs, n_obs))
        for g, (kg, cs_g) in enumerate(self.groups):
            for h in range(g + 1, len(self.groups)):
                kh, cs_h = self.groups[h]
                for c in set(cs_g) & set(cs_h):
                    v = sum(ce * cf * cov((e[0] + str(c), e[1]), (f[0] + str(c), f[1]))
                            for e, ce, _ in self.pairs[kg].end_terms
                            for f, cf, _ in self.pairs[kh].end_terms)
                    i, j = row[g] + cs_g.index(c), row[h] + cs_h.index(c)
                    raw[i, j] = raw[j, i] = v
        lw = estimator._block_diag(whiten, n_obs)
        return np.asarray(lw @ raw @ lw.T)
    return shared


def report(z: dict[str, np.ndarray]) -> None:
    """Per variant and parameter: within ±1σ, rms z, max |z|."""
    for name in VARIANTS:
        coverage_table(f'{name} ({len(z[name])} runs)', z[name])


def main(argv: list[str] | None = None) -> int:
    """Run seeds (saving as it goes) or report saved runs."""
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seeds', type=int, default=100)
    p.add_argument('--first', type=int, default=0, help='first seed')
    p.add_argument('--generator', choices=('sim_nodes', 'physics_paper'), default='sim_nodes',
                   help='physics_paper: test/triad_bench_physics.py on the paper plan, a random '
                        'triad per seed, 500 Hz (as benchmarks/triad_coverage.py)')
    p.add_argument('--save', type=Path, help='pickle the z here after every run')
    p.add_argument('--report', type=Path, nargs='+', help='report these saved runs')
    a = p.parse_args(argv)
    runs: list[dict[str, list[float]]] = []
    if a.report:
        for f in a.report:
            runs += pickle.loads(f.read_bytes())
    else:
        for seed in range(a.first, a.first + a.seeds):
            runs.append(run(seed, a.generator))
            if a.save:
                a.save.write_bytes(pickle.dumps(runs))
    report({name: np.array([r[name] for r in runs]) for name in VARIANTS})
    return 0


if __name__ == '__main__':
    sys.exit(main())
