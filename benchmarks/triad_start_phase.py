"""Why the noise-free sim_nodes bench over-covers: its errors are a function of start phases.

Run (from the repository root, niced):

    PYTHONPATH=$PWD nice python benchmarks/triad_start_phase.py            # ~15 min
    PYTHONPATH=$PWD nice python benchmarks/triad_start_phase.py --grid 8 --drawn 10

``triad_two_axis_bench`` (sim_nodes, 250 Hz, ARW 0, stated) through the real session, as in
benchmarks/triad_coverage.py. With no angle random walk the only random things in a run are
each gyro's start count phase (uniform) and the zero-index jitter; the scale factors, axes and
table motions are the scenario's. Printed:

1. **same phase, other seeds**: the start phases fixed, the seed (index jitter, procedure)
   varied: the nine z = error/u agree to ~10⁻⁴, so each run's errors are a function of the
   three start phases alone — every window end's rounding follows from one phase per gyro,
   through the fixed pulse offsets between the ends.
2. **phase grid**: the start phases on a grid of ``--grid`` points (u, u + 1/3, u + 2/3): the
   rms z and the fraction within ±1σ over a uniform phase — the coverage this one noise-free
   bench can show over seeds (benchmarks/triad_coverage.py's 100 sim_nodes seeds sample it).
3. **K drawn**: ``--drawn`` runs with each K_i drawn within ±50 ppm of the scenario's (the
   pulse offsets between the window ends then differ by whole pulses run to run, as between
   benches, or with any ARW): rms z and coverage over the runs, what eq. (6a) states — an
   rms over the ends' phases taken as independent.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'test'))

from triad_bench_physics import Recording  # noqa: E402
from triad_coverage_helpers import run_session, scores  # noqa: E402

from gyro_calib.triad.solve import solve_pairs  # noqa: E402

PARAMETERS = ('K_x', 's_x·e_y', 's_x·e_z', 'K_y', 's_y·e_x', 's_y·e_z', 'K_z', 's_z·e_x',
              's_z·e_y')
K_SPREAD = 50e-6
"""K_i drawn within ±this (relative) of the scenario's in part 3."""


@contextmanager
def start_phases(phase: np.ndarray | None) -> Iterator[None]:
    """sim_nodes' gyros start at count phases ``phase`` (3,), pulses; None: their seeded draw."""
    import sim_nodes.triad.gyros as gyros

    init = gyros.TriadGyroSimulator.__init__

    def fixed(self: gyros.TriadGyroSimulator, *args: object, **kw: object) -> None:
        init(self, *args, **kw)  # type: ignore[arg-type]
        if phase is not None:
            self._start_phase = np.array(phase, dtype=np.float64)

    gyros.TriadGyroSimulator.__init__ = fixed  # type: ignore[method-assign]
    try:
        yield
    finally:
        gyros.TriadGyroSimulator.__init__ = init  # type: ignore[method-assign]


def scenario(seed: int, k_scale: np.ndarray | None = None, quantise: bool = True
             ) -> tuple[Any, Any]:
    """triad_two_axis_bench, 250 Hz, ARW 0, ``seed`` everywhere, K_i × ``k_scale``: (sc, gyros)."""
    from sim_nodes.triad.scenarios import SCENARIOS

    sc = SCENARIOS['triad_two_axis_bench']
    gy = dataclasses.replace(sc.gyros, seed=seed, angle_random_walk_deg_sqrt_h=(0.0,) * 3,
                             quantise=quantise)
    if k_scale is not None:
        gy = dataclasses.replace(gy, scale_factor_arcsec_per_pulse=tuple(
            float(k) for k in np.asarray(gy.scale_factor_arcsec_per_pulse) * k_scale))
    sc = dataclasses.replace(
        sc, table=dataclasses.replace(sc.table, seed=seed, sample_rate_hz=250.0,
                                      joint_state_decimation=1),
        gyros=gy, procedure=dataclasses.replace(sc.procedure, seed=seed))
    return sc, gy


def run(seed: int, phase: np.ndarray | None = None, k_scale: np.ndarray | None = None
        ) -> list[float]:
    """The nine z of one ARW-0 run of triad_two_axis_bench (ARW stated as 0)."""
    sc, gy = scenario(seed, k_scale)
    with start_phases(phase):
        ch = sc.bench().record()
    session = run_session(recording_of(ch), sc.bench_settings())
    stated, _, _ = solve_pairs(session.pairs, session.channels, session.bench.tilt_std_rad,
                               np.zeros(3))
    assert stated is not None
    return scores(stated, gy.scale_factor_rad_per_pulse(), gy.unit_sense_axes())[0]


def recording_of(ch: Any) -> Recording:
    """A sim_nodes two-axis TriadChunk as test/triad_bench_physics.py's Recording."""
    assert ch.position_table is not None and ch.position_zero_index_ns is not None
    return Recording(ch.pulse_t_ns, ch.pulse_counts, ch.rate_table[0],
                     np.column_stack(ch.rate_table[1:]), ch.rate_zero_index_ns,
                     ch.position_table[0], np.column_stack(ch.position_table[1:]),
                     ch.position_zero_index_ns)


def coverage_table(title: str, z: np.ndarray) -> None:
    """Per parameter: within ±1σ, rms z, max |z| of the runs' z (runs × nine)."""
    print(f'\n{title}')
    print(f'  {"parameter":<10} {"within ±1σ":>10} {"rms z":>7} {"max |z|":>8}')
    for i, name in enumerate(PARAMETERS):
        print(f'  {name:<10} {100 * np.mean(np.abs(z[:, i]) <= 1):9.0f}% '
              f'{np.sqrt(np.mean(z[:, i] ** 2)):7.2f} {np.max(np.abs(z[:, i])):8.2f}')
    print(f'  {"all nine":<10} {100 * np.mean(np.abs(z) <= 1):9.0f}% '
          f'{np.sqrt(np.mean(z ** 2)):7.2f} {np.max(np.abs(z)):8.2f}')


def main(argv: list[str] | None = None) -> int:
    """Print the three parts."""
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--grid', type=int, default=24, help='start phases on the grid')
    p.add_argument('--drawn', type=int, default=60, help='runs with K drawn')
    a = p.parse_args(argv)
    offsets = np.array([0.0, 1 / 3, 2 / 3])
    phase = np.mod(0.5 / a.grid + offsets, 1.0)
    same = np.array([run(seed, phase) for seed in (0, 1, 2)])
    print('1. start phases fixed, seeds 0, 1, 2: the nine z')
    for seed, z in enumerate(same):
        print(f'  seed {seed}: ' + ' '.join(f'{v:+.4f}' for v in z))
    print(f'  largest difference between seeds: {np.max(np.ptp(same, axis=0)):.1e}')
    grid = np.array([run(0, np.mod((j + 0.5) / a.grid + offsets, 1.0))
                     for j in range(a.grid)])
    coverage_table(f'2. one noise-free bench, start phases on a grid of {a.grid}', grid)
    drawn = []
    for seed in range(a.drawn):
        rng = np.random.default_rng(777 + seed)
        drawn.append(run(seed, None, 1.0 + K_SPREAD * rng.uniform(-1.0, 1.0, size=3)))
    coverage_table(f'3. K_i drawn within ±{K_SPREAD * 1e6:g} ppm, seeded start phases: '
                   f'{a.drawn} runs', np.array(drawn))
    return 0


if __name__ == '__main__':
    sys.exit(main())
