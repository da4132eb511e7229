"""Candidate terms, fits and stepwise selection.

Candidate terms, fits with honest covariance, stepwise selection (METHODS §D.2–4),
with the paper's own bias tables of gyros A-1 and A-2 as regression data.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.thermal.allan import allan_long_run_variance
from gyro_calib.thermal.regression import fit_linear, stepwise
from gyro_calib.thermal.terms import (
    candidate_terms,
    design_columns,
    distinct_levels,
    main_effects,
    min_levels_for,
    parse_term,
    scaling_from_data,
)

# METHODS §D.4, Table 1 of the paper: bias (°/h) at the seven chamber temperatures
PAPER_T_C = np.array([-35.0, -25.0, -15.0, 0.0, 15.0, 25.0, 35.0])
PAPER_A1 = np.array([0.1073, 0.1748, 0.3288, 0.4461, 0.6321, 0.6633, 0.1369])
PAPER_A2 = np.array([0.4991, 0.4578, 0.4204, 0.4159, 0.3613, 0.2561, 0.1683])


def _static_columns(max_power: int) -> dict[str, np.ndarray]:
    terms = candidate_terms('static', max_h_power=max_power)
    scaling = scaling_from_data({'H': PAPER_T_C})
    cols = design_columns(terms, {'H': PAPER_T_C}, scaling)
    return {t.name: cols[:, j] for j, t in enumerate(terms)}


@pytest.mark.parametrize('text, name, key', [
    ('H', 'H', 'h'), ('H^3', 'H^3', 'h3'), ('Hdot*H', 'H*Hdot', 'h_hdot'),
    ('dTab^2', 'dTab^2', 'dtab2'), ('H*H', 'H^2', 'h2'), (' dTcs ', 'dTcs', 'dtcs'),
])
def test_terms_parse_to_canonical_names_and_keys(text: str, name: str, key: str) -> None:
    term = parse_term(text)
    assert (term.name, term.key) == (name, key)


@pytest.mark.parametrize('bad', ['T', 'H^0', 'H^10', 'H+Hdot', ''])
def test_malformed_term_is_a_config_error_naming_it(bad: str) -> None:
    with pytest.raises(ConfigError, match='term'):
        parse_term(bad)


def test_named_sets_follow_eq_14_eq_17_and_model_2() -> None:
    assert [t.name for t in candidate_terms('static')] == ['H', 'H^2', 'H^3']
    dyn = [t.name for t in candidate_terms('dynamic')]
    assert dyn == ['H', 'H^2', 'H^3', 'Hdot', 'Hdot^2', 'Hdot^3', 'dTab', 'dTcs']
    assert 'dTcs' not in [t.name for t in candidate_terms('dynamic', shell=False)]
    second = candidate_terms('second_order')
    assert len(second) == 9  # K1…K9 beside the intercept K0
    assert {t.degree for t in second} == {1, 2}
    assert [t.name for t in candidate_terms('H, H^2 ,Hdot,H')] == ['H', 'H^2', 'Hdot']


def test_scaling_maps_h_onto_minus_one_to_one() -> None:
    sc = scaling_from_data({'H': np.array([-35.0, 0.0, 37.0]), 'Hdot': np.array([0.01, -0.02])})
    x = sc.scaled('H', np.array([-35.0, 37.0]))
    assert np.allclose(x, [-1.0, 1.0])
    assert sc.centre['Hdot'] == 0.0 and sc.scale['Hdot'] == pytest.approx(0.02)


def test_paper_static_models_fit_a1_and_a2() -> None:
    """The paper's static models fit A-1 and A-2.

    Eq. 14 with m = 3 on the published points: A-2 (near-linear) is fitted to 0.017 °/h
    rms; the strongly non-monotonic A-1 leaves 0.1 °/h (a cubic cannot follow its drop
    from 25 to 35 °C), m = 4 brings it to 0.06 °/h.
    """
    f2 = fit_linear(PAPER_A2, _static_columns(3), ['H', 'H^2', 'H^3'])
    f1 = fit_linear(PAPER_A1, _static_columns(3), ['H', 'H^2', 'H^3'])
    f1q = fit_linear(PAPER_A1, _static_columns(4), ['H', 'H^2', 'H^3', 'H^4'])
    assert f2.residual_std == pytest.approx(0.0172, abs=5e-4)
    assert f1.residual_std == pytest.approx(0.1000, abs=5e-4)
    assert f1q.residual_std == pytest.approx(0.0618, abs=5e-4)
    assert f2.coefficients[0] == pytest.approx(0.4056, abs=1e-4)  # bias at 0 °C, °/h
    assert f2.dof == 3 and f2.covariance_kind == 'ols'


def test_stepwise_picks_different_terms_for_a1_and_a2() -> None:
    """Stepwise picks different terms for A-1 and A-2.

    MATLAB-style stepwise (enter p < 0.05, remove p > 0.10) from the full model, over
    H…H⁴: the non-monotonic A-1 keeps H, H³, H⁴, the near-linear A-2 keeps H, H², H³.
    """
    cols = _static_columns(4)
    a1 = stepwise(PAPER_A1, cols, list(cols), p_enter=0.05, p_remove=0.10, start='full')
    a2 = stepwise(PAPER_A2, cols, list(cols), p_enter=0.05, p_remove=0.10, start='full')
    assert a1.terms == ('H', 'H^3', 'H^4')
    assert a2.terms == ('H', 'H^2', 'H^3')
    assert [s.term for s in a1.steps if s.action == 'remove'] == ['H^2']
    # the calibrator's marginality rule (H stays while a higher power does) keeps both
    keep = {t: main_effects(parse_term(t)) for t in cols}
    assert stepwise(PAPER_A1, cols, list(cols), keep_while=keep).terms == a1.terms
    assert stepwise(PAPER_A2, cols, list(cols), keep_while=keep).terms == a2.terms


def test_stepwise_keeps_a_first_power_while_a_higher_power_of_it_stays() -> None:
    """Stepwise keeps a first power while a higher power is in.

    A curve in H³ alone (no H): plain stepwise removes H and keeps H³; with the main
    effects kept (METHODS §D.3), H stays beside H³; a term nothing needs still leaves.
    """
    rng = np.random.default_rng(1)
    x = np.linspace(-1.0, 1.0, 60)
    r = rng.uniform(-1.0, 1.0, 60)
    y = 0.8 * x**3 + 0.01 * rng.standard_normal(60)
    cols = {'H': x, 'H^3': x**3, 'Hdot': r}
    plain = stepwise(y, cols, list(cols))
    assert plain.terms == ('H^3',)
    keep = {t: main_effects(parse_term(t)) for t in cols}
    assert main_effects(parse_term('H^3')) == ('H',)
    assert main_effects(parse_term('H*Hdot')) == ('H', 'Hdot')
    assert main_effects(parse_term('Hdot')) == ()
    kept = stepwise(y, cols, list(cols), keep_while=keep)
    assert kept.terms == ('H', 'H^3')


def test_forward_stepwise_from_constant_misses_the_non_monotonic_a1() -> None:
    """Forward stepwise from a constant misses the non-monotonic A-1.

    Forward entry cannot find terms that only matter together: no single power of H is
    significant for A-1 (its best, H², has p = 0.12), while A-2 gets H. Why the default
    start is the full model.
    """
    cols = _static_columns(3)
    a1 = stepwise(PAPER_A1, cols, list(cols), start='constant')
    a2 = stepwise(PAPER_A2, cols, list(cols), start='constant')
    assert a1.terms == ()
    assert a2.terms == ('H',)


def test_stepwise_recovers_true_terms_and_skips_collinear_ones() -> None:
    rng = np.random.default_rng(4)
    n = 400
    x = rng.uniform(-1, 1, n)
    r = rng.uniform(-1, 1, n)
    cols = {'H': x, 'H^2': x**2, 'H^3': x**3, 'Hdot': r, 'Hdot_copy': 2 * r}
    y = 1.0 + 0.5 * x - 0.3 * x**3 + 0.2 * r + 0.01 * rng.standard_normal(n)
    res = stepwise(y, cols, list(cols), p_enter=0.01, p_remove=0.02)
    assert set(res.terms) == {'H', 'H^3', 'Hdot'}
    assert [s.term for s in res.steps if s.action == 'skip'] == ['Hdot_copy']


def test_stepwise_refuses_p_enter_above_p_remove() -> None:
    with pytest.raises(ConfigError, match='p_enter'):
        stepwise(np.zeros(10), {'H': np.arange(10.0)}, ['H'], p_enter=0.2, p_remove=0.1)


def test_fit_with_no_degree_of_freedom_left_is_refused() -> None:
    with pytest.raises(InsufficientDataError, match='degree of freedom'):
        fit_linear(np.zeros(3), {'a': np.arange(3.0), 'b': np.arange(3.0) ** 2}, ['a', 'b'])


def test_wls_birge_ratio_inflates_but_never_shrinks_the_covariance() -> None:
    x = np.linspace(-1, 1, 9)
    cols = {'H': x}
    sigma = np.full(9, 0.1)
    exact = fit_linear(1 + x, cols, ['H'], sigma=sigma)
    scattered = fit_linear(1 + x + 0.5 * (-1) ** np.arange(9), cols, ['H'], sigma=sigma)
    base = np.sqrt(np.diag(np.linalg.inv(np.column_stack([np.ones(9), x]).T
                                         @ np.column_stack([np.ones(9), x]))) * 0.01)
    assert np.allclose(exact.std_uncertainties, base)  # Birge ratio 0: stated σ kept
    assert scattered.birge_ratio > 1
    assert np.allclose(scattered.std_uncertainties, base * scattered.birge_ratio)


def test_allan_covariance_covers_the_truth_where_naive_ols_does_not() -> None:
    """The Allan covariance covers the truth where naive OLS does not.

    Residuals = AR(1) (φ = 0.9, like bias instability between fit blocks) + white, with
    a slowly varying regressor: the naive OLS standard error is ~4× too small; the one
    from the Allan long-run variance is honest.
    """
    rng = np.random.default_rng(8)
    n, reps = 2000, 80
    x = np.sin(np.linspace(0, 3 * np.pi, n))
    z_naive, z_allan = [], []
    for _ in range(reps):
        e = lfilter([1.0], [1.0, -0.9], rng.standard_normal(n)) + rng.standard_normal(n)
        y = 2.0 * x + e
        naive = fit_linear(y, {'H': x}, ['H'])
        allan = fit_linear(y, {'H': x}, ['H'], lrv_max_rows=128)
        z_naive.append((naive.coefficients[1] - 2.0) / naive.std_uncertainties[1])
        z_allan.append((allan.coefficients[1] - 2.0) / allan.std_uncertainties[1])
    assert allan.covariance_kind == 'allan' and allan.lrv_rows >= 16
    assert np.std(z_naive) > 2.5
    assert 0.75 < np.std(z_allan) < 1.2


@pytest.mark.parametrize('phi', [0.0, 0.5, 0.9])
def test_allan_long_run_variance_of_ar1_noise(phi: float) -> None:
    """AR(1) with unit innovations: long-run variance 1/(1 − φ)² (white: the variance)."""
    e = lfilter([1.0], [1.0, -phi], np.random.default_rng(3).standard_normal(200_000))
    lrv, m = allan_long_run_variance(e, 1024)
    assert lrv == pytest.approx(1.0 / (1.0 - phi) ** 2, rel=0.15)


def test_distinct_levels_and_the_levels_a_power_needs() -> None:
    assert distinct_levels(np.array([0.1, 0.2, 5.0, 5.5, 20.0, np.nan]), 2.0) == 3
    assert min_levels_for(candidate_terms('static', max_h_power=3)) == 5
    assert min_levels_for(candidate_terms('Hdot')) == 0


def _random_poly_case(seed: int, order: int) -> tuple[np.ndarray, dict[str, np.ndarray],
                                                       np.ndarray, set[str]]:
    """Small generator from the physics: a soaked gyro.

    Small generator from the physics: a gyro soaked at random temperatures, H lagging
    each set point, bias a random polynomial in H, white noise on the block means.
    """
    rng = np.random.default_rng(seed)
    points = np.sort(rng.uniform(-40, 40, rng.integers(9, 14)))
    h = np.concatenate([p + (q - p) * np.exp(-np.arange(60) / rng.uniform(5, 20))
                        for p, q in zip(points, np.concatenate(([points[0]], points[:-1])))])
    x = (h - h.mean()) / (np.ptp(h) / 2)
    coef = rng.uniform(0.3, 1.0, order) * rng.choice([-1, 1], order)
    y = 0.5 + sum(c * x ** (j + 1) for j, c in enumerate(coef)) + 0.01 * rng.standard_normal(
        len(x))
    cols = {('H' if j == 1 else f'H^{j}'): x**j for j in range(1, 5)}
    truth = {('H' if j == 1 else f'H^{j}') for j in range(1, order + 1)}
    return y, cols, np.concatenate(([0.5], coef)), truth


def test_stepwise_recovers_the_true_polynomial_order_most_of_the_time() -> None:
    hits = 0
    for seed in range(20):
        y, cols, _, truth = _random_poly_case(seed, 1 + seed % 3)
        hits += set(stepwise(y, cols, list(cols), p_enter=0.01, p_remove=0.02).terms) == truth
    assert hits >= 17


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**20), order=st.integers(1, 3))
def test_coefficients_lie_within_their_stated_uncertainty(seed: int, order: int) -> None:
    """Property: every coefficient is within its stated uncertainty.

    Property: with the true terms, every coefficient is within 4.5 standard
    uncertainties of the truth (white noise: OLS uncertainty is honest).
    """
    y, cols, coef, truth = _random_poly_case(seed, order)
    names = sorted(truth, key=lambda t: (len(t), t))
    fit = fit_linear(y, cols, names)
    assert np.all(np.abs(fit.coefficients - coef) < 4.5 * fit.std_uncertainties)
