"""Coverage factors, expanded uncertainties and budgets (GUM; GTC, the GUM Tree Calculator).

Each measured quantity carries its standard uncertainty u and, where the estimator knows
them, its degrees of freedom ν and the sources u is made of. The budget combines the sources
as independent inputs of a sum (GUM eq. 10 with unit sensitivities) in GTC, which gives the
Welch–Satterthwaite degrees of freedom (GUM G.4.1); the coverage factor for 95 % is Student
t at those degrees of freedom (GUM G.3), and U = k·u.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from GTC import reporting, ureal

P_COVERAGE_PERCENT = 95.0
"""The coverage probability of the expanded uncertainty, %."""


@dataclass(frozen=True, slots=True)
class BudgetLine:
    """One source of a quantity's standard uncertainty.

    Attributes:
        source: what it is (the estimator's own words: scatter, prediction, rocking …).
        std: its standard uncertainty, in the quantity's SI unit.
        dof: its degrees of freedom (inf for a Type B bound taken as exact).
    """

    source: str
    std: float
    dof: float


@dataclass(frozen=True, slots=True)
class Expanded:
    """A quantity's uncertainty statement.

    Attributes:
        std: combined standard uncertainty u (k = 1), SI.
        dof: effective degrees of freedom (Welch–Satterthwaite), inf, or None when unknown.
        k: coverage factor for 95 % (None when the degrees of freedom are below 1).
        expanded: U = k·u (None with k).
        budget: the sources with their contributions, largest first.
        note: how k was obtained, in one sentence.
    """

    std: float
    dof: float | None
    k: float | None
    expanded: float | None
    budget: tuple[BudgetLine, ...]
    note: str


def expanded_uncertainty(std: float, budget: tuple[BudgetLine, ...] = ()) -> Expanded:
    """The k = k₉₅(ν) expanded uncertainty of a quantity of standard uncertainty ``std``.

    Args:
        std: the combined standard uncertainty u, SI (as the hand-off states it).
        budget: its sources; empty when nothing is known of them (then ν is unknown and
            k = 2 is stated as an assumption).

    Returns:
        The statement; the budget's sources combined in GTC give ν (GUM G.4.1).
    """
    if not budget:
        return Expanded(std, None, 2.0, 2.0 * std, (), 'degrees of freedom not known (no '
                        'data given): k = 2 assumed (normal distribution)')
    y = ureal(0.0, 0.0)
    for line in budget:
        df = line.dof if line.dof >= 1 or math.isinf(line.dof) else 1.0
        y = y + ureal(0.0, line.std, df, label=line.source)
    dof = float(y.df)
    combined = float(y.u)
    if combined > 0 and abs(combined - std) > 1e-6 * std:
        note = (f'the budget combines to {combined:.4g}, the stated u is {std:.4g}; '
                'k from the budget\'s degrees of freedom')
    else:
        note = ''
    ordered = tuple(sorted(budget, key=lambda b: -b.std))
    if any(b.dof < 1 and not math.isinf(b.dof) for b in budget):
        return Expanded(std, dof, None, None, ordered,
                        'fewer than 1 degree of freedom: no coverage interval can be stated')
    k = float(reporting.k_factor(dof, P_COVERAGE_PERCENT))
    what = ('ν = ∞: normal' if math.isinf(dof)
            else f'Student t, ν = {dof:.3g}' + (' (Welch–Satterthwaite)' if len(budget) > 1
                                                   else ''))
    return Expanded(std, dof, k, k * std, ordered,
                    '; '.join(x for x in (f'k for {P_COVERAGE_PERCENT:g} %: {what}', note) if x))


def contribution_percent(line: BudgetLine, std: float) -> float:
    """A source's share of the variance u², %."""
    return 100.0 * (line.std / std) ** 2 if std > 0 else math.nan
