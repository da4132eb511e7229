"""Greenhall's EDF is computed without allantools, and is the very float allantools gives.

``gyro_calib.noise.edf`` evaluates Greenhall & Riley (2004) itself (importing allantools
pulled scipy.stats and scipy.signal into every ``gyro-calib noise`` run, most of its
start-up, issue 40). The committed bags' numbers stay bit for bit only if every EDF is
``allantools.edf_greenhall``'s own float, so the two are compared with ``==`` over a grid of
every case of the algorithm (modified or not, J ≤ J_max, r > d + 1, the m' branch, white PM
with ⌈r⌉ ≤ d) and the edges of the record's length.
"""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest

from gyro_calib.noise import edf

allantools = pytest.importorskip('allantools')

ALPHAS = (2, 1, 0, -1, -2)
FACTORS = (1, 2, 3, 5, 8, 16, 25, 33, 34, 100, 128, 4096, 2**20, 2**26)


def allantools_edf(alpha: int, d: int, m: int, n: int, modified: bool) -> float:
    """The EDF as the package took it from allantools before (the same fallbacks)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')
            value = float(allantools.edf_greenhall(alpha=alpha, d=d, m=m, N=n,
                                                   overlapping=True, modified=modified))
    except NotImplementedError:
        if d == 2 and not modified:
            return float(edf.edf_oadev(n, m, alpha))
        return edf.MIN_EDF
    except (AssertionError, ValueError, ZeroDivisionError, OverflowError):
        return edf.MIN_EDF
    return value if np.isfinite(value) and value > edf.MIN_EDF else edf.MIN_EDF


def record_lengths(m: int, d: int) -> list[int]:
    """Phase points around every branch of the algorithm for factor m and difference d."""
    near = {d * m + 1, d * m + 2, (d + 1) * m - 1, (d + 1) * m, (d + 1) * m + 1,
            2 * (d + 1) * m, 33 * m + 3, 34 * m, 50 * m, 100 * m + 7, 101 * m, 1000 * m,
            10**5 * m + 1, 10, 4097, 10**6, 10**8 + 1, 10**9}
    return sorted(n for n in near if n - d * m >= 1)


@pytest.mark.parametrize('d', [2, 3])
@pytest.mark.parametrize('modified', [False, True])
def test_greenhall_edf_is_allantools_float_on_a_grid(d: int, modified: bool) -> None:
    differ = [(alpha, m, n, edf._greenhall.__wrapped__(alpha, d, m, n, modified),
               allantools_edf(alpha, d, m, n, modified))
              for m in FACTORS for n in record_lengths(m, d) for alpha in ALPHAS]
    differ = [case for case in differ if case[3] != case[4]]
    assert not differ, differ[:5]


def test_greenhall_edf_is_allantools_float_at_random_factors_and_lengths() -> None:
    rng = np.random.default_rng(40)
    for _ in range(2000):
        d, modified = int(rng.choice([2, 3])), bool(rng.integers(2))
        m = int(np.exp(rng.uniform(0.0, np.log(1e6))))
        n = d * m + 1 + int(np.exp(rng.uniform(0.0, np.log(300 * m + 10))))
        alpha = int(rng.integers(-2, 3))
        ours = edf._greenhall.__wrapped__(alpha, d, m, n, modified)
        assert ours == allantools_edf(alpha, d, m, n, modified), (alpha, d, m, n, modified)


def test_edf_module_does_not_import_allantools() -> None:
    code = ('import sys\n'
            'import numpy as np\n'
            'from gyro_calib.noise.edf import edf_greenhall\n'
            'edf_greenhall(np.array([4096, 10**6]), np.array([16, 1024]), np.array([0, 1]))\n'
            'edf_greenhall(4096, 16, -1, modified=True)\n'
            "assert 'allantools' not in sys.modules\n"
            "assert 'scipy.stats' not in sys.modules\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
