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


DOF_SHOWN_MAX = 1000.0
"""Above this ν the coverage factor no longer changes at the printed two decimals (t₀.₉₇₅ is
1.962 at ν = 1000, 1.960 at ∞): ν is printed as "> 1000"."""


def format_dof(dof: float | None) -> str:
    """ν as printed: '—' unknown, '∞', '> 1000', else at most 4 characters ('2', '3.4', '292')."""
    if dof is None:
        return '—'
    if math.isinf(dof):
        return '∞'
    if dof > DOF_SHOWN_MAX:
        return '> 1000'
    return f'{dof:.2g}' if dof < 10 else f'{dof:.0f}'


def expanded_uncertainty(std: float, budget: tuple[BudgetLine, ...] = (),
                         n: int | None = None) -> Expanded:
    """The k = k₉₅(ν) expanded uncertainty of a quantity of standard uncertainty ``std``.

    Args:
        std: the combined standard uncertainty u, SI (as the hand-off states it).
        budget: its sources; empty when nothing is known of them (then ν is unknown and
            k = 2 is stated as an assumption).
        n: the independent measurements the value rests on, where known: ν is at most
            n − 1 (a Type B part taken as exact cannot lend the statement more degrees of
            freedom than the data it was scaled from; GUM G.3.3, G.4.1).

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
    notes = []
    if combined > 0 and abs(combined - std) > 1e-6 * std:
        notes.append(f'the budget combines to {combined:.4g}, the stated u is {std:.4g}; '
                     'k from the budget\'s degrees of freedom')
    if n is not None and n >= 2 and dof > n - 1:
        notes.append(f'ν capped at n − 1 = {n - 1} (the {n} independent measurements; '
                     f'{format_dof(dof)} from the sources alone)')
        dof = float(n - 1)
    ordered = tuple(sorted(budget, key=lambda b: -b.std))
    if any(b.dof < 1 and not math.isinf(b.dof) for b in budget):
        return Expanded(std, dof, None, None, ordered,
                        'fewer than 1 degree of freedom: no coverage interval can be stated')
    k = float(reporting.k_factor(dof, P_COVERAGE_PERCENT))
    what = ('ν = ∞: normal' if math.isinf(dof)
            else f'Student t, ν = {format_dof(dof)}' + (' (Welch–Satterthwaite)'
                                                      if len(budget) > 1 else ''))
    return Expanded(std, dof, k, k * std, ordered,
                    '; '.join([f'k for {P_COVERAGE_PERCENT:g} %: {what}', *notes]))


def contribution_percent(line: BudgetLine, std: float) -> float:
    """A source's share of the variance u², %."""
    return 100.0 * (line.std / std) ** 2 if std > 0 else math.nan
