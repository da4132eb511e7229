"""The Student t is applied once: U = t₀.₉₇₅(ν)·s/√n for a quantity from few repetitions.

An estimator states the scatter of n repetitions as u = t₀.₈₄₁₃(ν)·s/√n (±u covers 68 %,
docs/methods.md conventions); the certificate's U for 95 % is t₀.₉₇₅(ν_eff)·u_GUM with that
line unwidened (GUM G.3, G.4), not t₀.₉₇₅(ν)·u. The numbers are recomputed here with
scipy.stats from the repetitions themselves and from the lines the certificate prints.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import scipy.stats

from gyro_calib.estimate import Estimate
from gyro_calib.handoff import Calibration
from gyro_calib.rbrlg.scale_factor import mean_estimate
from gyro_calib.report.certificate import build_certificate
from gyro_calib.report.evidence import MethodEvidence, RunEvidence
from gyro_calib.report.uncertainty import BudgetLine, basis_widening, expanded_uncertainty

ONE_SIGMA = 0.8413447460685429
REPEATS = [4.0859e-6 + 3e-14 * x for x in (0.3, -1.1, 0.9)]
"""K̃ (rad/pulse) of 3 window pairs whose scatter is above their prediction."""


def _estimate(values: list[float]) -> Estimate:
    est = mean_estimate(values, predicted_std=[1e-20] * len(values), prediction_complete=False)
    assert 'Student t' in est.basis  # the scatter, widened for 68 %
    return est


@pytest.mark.parametrize('values', [REPEATS, REPEATS[:2]])
def test_a_quantity_from_few_repetitions_has_u_t0841_and_U_t0975_times_s_over_root_n(
        values: list[float]) -> None:
    n = len(values)
    s_mean = float(np.std(values, ddof=1)) / math.sqrt(n)
    est = _estimate(values)
    t68, t95 = scipy.stats.t.ppf(ONE_SIGMA, n - 1), scipy.stats.t.ppf(0.975, n - 1)
    assert est.std_uncertainty == pytest.approx(t68 * s_mean, rel=1e-9, abs=0)
    line = BudgetLine(est.basis, est.std_uncertainty, float(est.dof), basis_widening(est.basis))
    exp = expanded_uncertainty(est.std_uncertainty, (line,), n)
    assert exp.expanded == pytest.approx(t95 * s_mean, rel=1e-9, abs=0)
    assert exp.k is not None
    assert exp.expanded == pytest.approx(exp.k * est.std_uncertainty, rel=1e-9, abs=0)
    assert exp.k == pytest.approx(t95 / t68)


def test_an_unwidened_line_keeps_k95_and_a_mixed_budget_combines_unwidened() -> None:
    plain = expanded_uncertainty(2.0, (BudgetLine('scatter of 5', 2.0, 4.0),), 5)
    assert plain.k == pytest.approx(scipy.stats.t.ppf(0.975, 4))
    t2 = float(scipy.stats.t.ppf(ONE_SIGMA, 2))
    a, b = 3.0, 4.0  # a: s/√n of 3 repetitions (stated widened), b: a Type B bound
    stated = math.hypot(t2 * a, b)
    exp = expanded_uncertainty(stated, (BudgetLine('scatter', t2 * a, 2.0, t2),
                                        BudgetLine('bound', b, math.inf)))
    u_gum = math.hypot(a, b)
    nu = u_gum ** 4 / (a ** 4 / 2)  # Welch–Satterthwaite, GUM eq. (G.2b)
    assert exp.dof == pytest.approx(nu)
    assert exp.expanded == pytest.approx(scipy.stats.t.ppf(0.975, nu) * u_gum, rel=1e-6)


def test_the_basis_names_the_widening_else_none() -> None:
    assert basis_widening('scatter of 3 × Student t 1.321 (2 dof)') == pytest.approx(
        scipy.stats.t.ppf(ONE_SIGMA, 2))
    assert basis_widening('scatter of 3') == 1.0
    assert basis_widening('predicted from the fits of 3 (scatter 1e-9 smaller)') == 1.0


def _cells(text: str) -> float:
    return float(re.sub(r'[^0-9.e+-]', '', text))


def test_the_certificate_states_U_a_reader_recomputes_from_its_printed_lines() -> None:
    est = _estimate(REPEATS)
    key = 'k_tilde_rad_per_pulse'
    values = {key: est.value, f'{key}_std': est.std_uncertainty, f'{key}_dof': est.dof}
    record = Calibration(values, {}, 'A-1')
    ev = RunEvidence((MethodEvidence(
        'rbrlg', 'rbrlg', {key: est},
        {key: (BudgetLine(est.basis, est.std_uncertainty, float(est.dof),
                          basis_widening(est.basis)),)},
        {}, (), (), (), (), None),), (), ())
    row = next(r for r in build_certificate(record, ev).rows if r.key == key)
    s_mean = float(np.std(REPEATS, ddof=1)) / math.sqrt(3)
    assert row.expanded_si == pytest.approx(scipy.stats.t.ppf(0.975, 2) * s_mean, rel=1e-9,
                                            abs=0)
    # what is printed: u, k (= U/u), U, and the budget line's u unwidened (s/√n)
    f = row.factor
    assert _cells(row.expanded) == pytest.approx(_cells(row.k) * _cells(row.std), rel=0.03)
    (source, line_u, line_nu, share), = row.budget
    assert 'unwidened' in source and '1.321' in source and line_nu == '2'
    assert _cells(line_u) == pytest.approx(s_mean * f, rel=0.05)
    assert _cells(row.expanded) == pytest.approx(
        scipy.stats.t.ppf(0.975, int(line_nu)) * _cells(line_u), rel=0.05)
    assert _cells(row.expanded) < scipy.stats.t.ppf(0.975, 2) * _cells(row.std) / 1.3  # once
