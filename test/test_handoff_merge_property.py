"""Property: merging runs into a hand-off file loses nothing.

Property (issue 17 item 5): whatever runs of one gyro are merged into its hand-off file, in
whatever order, nothing measured is lost, each quantity is the most precise measurement of it,
the keys that go together come from one run, and the file names that run truthfully.

The runs are drawn here from the physics of repeated measurements of one gyro: each quantity
has one true value; a run measures a random subset of the RBRLG quantity groups (K̃ with its
window pairs; θ with K and its stations; ω′ₑ + ω_B; ω_B), each with its own standard
uncertainty (log-uniform over three decades) and an error of at most 3 of them (so any two
runs agree within the file's 5 combined standard uncertainties). ``GYRO_CALIB_STRESS=1``
raises the example count.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.handoff import Provenance, load_calibration, method_calibration, update_calibration

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')

TRUTH = {'k_tilde_rad_per_pulse': 4.0859845e-06, 'fix_error_angle_rad': 3.1355e-3,
         'scale_factor_rad_per_pulse': 4.0859644e-06, 'bias_plus_earth_rate_rad_s': 3.45e-5,
         'bias_rad_s': 5.2e-8}
"""One gyro's true values (rad/pulse, rad, rad/s)."""

GROUPS = {'k_tilde': ('k_tilde_rad_per_pulse', 'window_pairs'),
          'theta': ('fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'stations'),
          'earth': ('bias_plus_earth_rate_rad_s',), 'bias': ('bias_rad_s',)}
"""What one measurement gives together; the first key leads (the counts follow it)."""

RELATIVE_STD = {'k_tilde_rad_per_pulse': 1e-8, 'fix_error_angle_rad': 1e-4,
                'scale_factor_rad_per_pulse': 1e-8, 'bias_plus_earth_rate_rad_s': 1e-3,
                'bias_rad_s': 0.3}


@st.composite
def runs(draw: st.DrawFn) -> list[dict[str, Any]]:
    out = []
    for i in range(draw(st.integers(1, 6), label='runs')):
        groups = draw(st.lists(st.sampled_from(sorted(GROUPS)), min_size=1, unique=True),
                      label='groups')
        values: dict[str, Any] = {}
        for group in groups:
            n = draw(st.integers(2, 40), label='count')
            for key in GROUPS[group]:
                if key in ('window_pairs', 'stations'):
                    values[key] = n
                    continue
                std = abs(TRUTH[key]) * RELATIVE_STD[key] * 10 ** draw(
                    st.floats(0.0, 3.0), label='log_std')
                values[key] = TRUTH[key] + std * draw(st.floats(-3.0, 3.0), label='error')
                values[key + '_std'] = std
        out.append({'values': values, 'source': f'run {i}',
                    'gyro_id': draw(st.sampled_from(['', 'A-1']), label='gyro_id')})
    return out


@settings(max_examples=300 if STRESS else 40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(runs())
def test_merging_runs_keeps_the_best_of_each_quantity_and_names_its_run(
        tmp_path: Path, sequence: list[dict[str, Any]]) -> None:
    path = tmp_path / 'gyro.yaml'
    path.unlink(missing_ok=True)
    for i, run in enumerate(sequence):
        record = method_calibration('rbrlg', run['values'],
                                    Provenance(run['source'], 10 * i, 10 * i + 5),
                                    gyro_id=run['gyro_id'])
        report: list[str] = []
        before = {k for k in (load_calibration(path).values if path.exists() else {})
                  if not k.endswith(('_std', '_dof'))}
        update_calibration(path, record, report=report)
        told = [line.split(':', 1)[1].split('=')[0].strip() for line in report
                if line.startswith(('added', 'replaced', 'kept', 'dropped'))]
        mine = before | {k for k in run['values'] if not k.endswith(('_std', '_dof'))}
        assert sorted(told) == sorted(mine)  # one line per key, every key
    final = load_calibration(path)
    measured = {k for run in sequence for k in run['values']}
    assert set(final.values) == measured  # nothing lost
    for group in GROUPS.values():
        lead = group[0]
        if lead not in final.values:
            continue
        stds = [run['values'][lead + '_std'] for run in sequence if lead in run['values']]
        assert final.values[lead + '_std'] == min(stds)  # the most precise
        source = final.source_of(lead)
        assert source is not None
        run = next(r for r in reversed(sequence) if r['source'] == source.source)
        for key in group:  # the whole group from the run the file names
            assert final.source_of(key) == source
            assert final.values[key] == run['values'][key]
            if key + '_std' in run['values']:
                assert final.values[key + '_std'] == run['values'][key + '_std']
    assert final.gyro_id == ('A-1' if any(r['gyro_id'] for r in sequence) else '')
    assert math.isfinite(final.values.get('k_tilde_rad_per_pulse', 0.0))
