"""Coverage factors, expanded uncertainties and budgets (GUM; GTC, the GUM Tree Calculator).

Each measured quantity carries its standard uncertainty u and, where the estimator knows
them, its degrees of freedom ν and the sources u is made of. The budget combines the sources
as independent inputs of a sum (GUM eq. 10 with unit sensitivities) in GTC, which gives the
Welch–Satterthwaite degrees of freedom (GUM G.4.1); the coverage factor for 95 % is Student
t at those degrees of freedom (GUM G.3).

A line an estimator widened by its Student t for 68 % (u = t₀.₈₄₁₃(ν)·s/√n, docs/methods.md
conventions, §A eq. (3d)) enters the combination unwidened (s/√n): Student t for 95 % at its
ν is the GUM's whole allowance for the few repetitions, so U = t₀.₉₇₅(ν_eff)·u_GUM. The stated
k is the effective factor U/u on the stated u (the same number when no line was widened).
"""

from __future__ import annotations

import math
import re
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
        widening: the Student t for 68 % (t₀.₈₄₁₃(ν)) the estimator widened ``std`` by, 1
            when it did not: the GUM standard uncertainty is ``std / widening``.
    """

    source: str
    std: float
    dof: float
    widening: float = 1.0

    @property
    def gum_std(self) -> float:
        """The line's standard uncertainty unwidened (s/√n for a widened scatter), SI."""
        return self.std / self.widening


_WIDENED = re.compile(r'× Student t [0-9.]+ \((\d+) dof\)')


def basis_widening(basis: str) -> float:
    """The Student t for 68 % an estimator's basis says its u was widened by, else 1.

    The estimators that widen a scatter say so as ``… × Student t 1.321 (2 dof)``
    (docs/methods.md §A eq. (3d)); the factor is recomputed at full precision from the ν.
    """
    match = _WIDENED.search(basis)
    if match is None or int(match.group(1)) < 1:
        return 1.0
    from gyro_calib.estimate import student_t_factor

    return student_t_factor(int(match.group(1)))


@dataclass(frozen=True, slots=True)
class Expanded:
    """A quantity's uncertainty statement.

    Attributes:
        std: combined standard uncertainty u (k = 1), SI.
        dof: effective degrees of freedom (Welch–Satterthwaite), inf, or None when unknown.
        k: coverage factor for 95 % on the stated u, U/u (None when the degrees of freedom
            are below 1): k₉₅(ν)·u_GUM/u, k₉₅(ν) itself when no line was widened.
        expanded: U = k·u = k₉₅(ν)·u_GUM (None with k).
        budget: the sources with their contributions, largest first.
        note: how k was obtained, in one sentence.
    """

    std: float
    dof: float | None
    k: float | None
    expanded: float | None
    budget: tuple[BudgetLine, ...]
    note: str
    k95: float | None = None
    std_gum: float | None = None


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
        y = y + ureal(0.0, line.gum_std, df, label=line.source)
    dof = float(y.df)
    combined_gum = float(y.u)
    combined = math.sqrt(sum(line.std ** 2 for line in budget))
    # the stated u unwidened in the budget's proportion (u itself when nothing was widened)
    std_gum = std * combined_gum / combined if combined > 0 else std
    notes = []
    if combined > 0 and abs(combined - std) > 1e-6 * std:
        notes.append(f'the budget combines to {combined:.4g}, the stated u is {std:.4g}; '
                     'k from the budget\'s degrees of freedom')
    if n is not None and n >= 2 and dof > n - 1:
        notes.append(f'ν capped at n − 1 = {n - 1} (the {n} independent measurements; '
                     f'{format_dof(dof)} from the sources alone)')
        dof = float(n - 1)
    ordered = tuple(sorted(budget, key=lambda b: -b.gum_std))
    if any(b.dof < 1 and not math.isinf(b.dof) for b in budget):
        return Expanded(std, dof, None, None, ordered,
                        'fewer than 1 degree of freedom: no coverage interval can be stated',
                        None, std_gum)
    k95 = float(reporting.k_factor(dof, P_COVERAGE_PERCENT))
    what = ('ν = ∞: normal' if math.isinf(dof)
            else f'Student t, ν = {format_dof(dof)}' + (' (Welch–Satterthwaite)'
                                                      if len(budget) > 1 else ''))
    k = k95
    if any(b.widening != 1.0 for b in budget) and std > 0:
        k = k95 * std_gum / std
        notes.insert(0, 'the budget\'s lines enter unwidened (each widened one ÷ its '
                     f'Student t for 68 %): U = {k95:.3f} × u_GUM (the budget\'s u combined) = '
                     f'{k:.3f} × the stated u (k shown: U/u)')
    return Expanded(std, dof, k, k * std, ordered,
                    '; '.join([f'k for {P_COVERAGE_PERCENT:g} %: {what}',
                               *notes]), k95, std_gum)


def budget_source(line: BudgetLine) -> str:
    """A line's source as printed: a widened one says its u is shown unwidened, and by what."""
    if line.widening == 1.0:
        return line.source
    return (f'{line.source}: u shown unwidened (s/√n); the stated u is it × '
            f'{line.widening:.3f} (Student t for 68 %)')


def contribution_percent(line: BudgetLine, std: float) -> float:
    """A source's share of the variance u² (unwidened lines, of u_GUM² then), %."""
    return 100.0 * (line.gum_std / std) ** 2 if std > 0 else math.nan
