"""student_t_factor is scipy.stats.t.ppf's float at ±1σ coverage, without importing scipy.stats.

The RBRLG uncertainties widen by it (docs/methods.md §A eq. (3d), §F.5); it is evaluated by
``scipy.special.stdtrit`` to keep scipy.stats out of ``gyro-calib calibrate`` (issue 40), so
the committed bags' numbers stay bit for bit only if it is the very float t.ppf gives.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from scipy.stats import t

from gyro_calib.estimate import ONE_SIGMA_PROBABILITY, student_t_factor


def test_every_degree_of_freedom_to_1000_and_a_log_grid_to_1e9_gives_t_ppf() -> None:
    dofs = [*range(1, 1001), *np.unique(np.geomspace(1e3, 1e9, 200).astype(int)).tolist()]
    differ = [d for d in dofs if student_t_factor(d) != float(t.ppf(ONE_SIGMA_PROBABILITY, d))]
    assert not differ, differ[:10]


def test_the_factor_covers_as_one_sigma_does() -> None:
    assert student_t_factor(1) > student_t_factor(10) > student_t_factor(10**6) > 1.0
    assert abs(student_t_factor(10**8) - 1.0) < 1e-6


def test_it_does_not_import_scipy_stats() -> None:
    code = ('import sys\n'
            'from gyro_calib.estimate import student_t_factor\n'
            'student_t_factor(4)\n'
            "assert 'scipy.stats' not in sys.modules\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
