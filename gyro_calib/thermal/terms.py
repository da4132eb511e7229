"""Candidate terms of the thermal bias models and their (centred, scaled) design columns.

Variables (per averaging interval):

- ``H``: mean cavity temperature (cavity_a + cavity_b)/2, °C;
- ``Hdot``: its rate of change, °C/s (causal least-squares slope, see
  :func:`gyro_calib.thermal.intervals.causal_slope`);
- ``dTab``: arm-to-arm gradient cavity_a − cavity_b, °C;
- ``dTcs``: cavity-to-shell gradient H − shell, °C (needs the shell sensor).

A term is a product of variable powers written ``H``, ``H^2``, ``H*Hdot``, ``dTab^2``.
Named candidate sets (METHODS §D.2–3):

- ``static``: H, H², …, H^m (eq. 14; m = ``max_h_power``);
- ``dynamic``: the static terms, Ḣ, Ḣ², Ḣ³ and the gradient terms (eq. 17). With three
  sensors only two independent differences exist (T_a − T_b and H − T_s; T_a − T_s and
  T_b − T_s are combinations of them), so the paper's t₇…t₉ become ``dTab`` and ``dTcs``;
  ``dTcs`` is offered only when the shell sensor is recorded;
- ``second_order``: model (2): T, Ṫ, ΔT, their squares and all cross products (K₁…K₉ with
  K₀ the intercept), with T = H and ΔT = dTab.

Every variable enters as (x − centre)/scale, with the centre and scale stored in the
model (:class:`VariableScaling`), so the columns are O(1) and a cubic stays well
conditioned; the intercept is therefore the bias at the centre.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import ConfigError

if TYPE_CHECKING:
    import numpy.typing as npt

VARIABLES = ('H', 'Hdot', 'dTab', 'dTcs')
"""Model variables, in canonical order."""
VARIABLE_UNITS = {'H': 'c', 'Hdot': 'c_per_s', 'dTab': 'c', 'dTcs': 'c'}
"""Unit suffix of each variable in hand-off keys."""
NAMED_SETS = ('static', 'dynamic', 'second_order')
"""Names accepted for a candidate term set."""

_FACTOR = re.compile(r'^(H|Hdot|dTab|dTcs)(?:\^([1-9]))?$')


@dataclass(frozen=True, slots=True)
class Term:
    """A product of variable powers, e.g. H² or H·Ḣ.

    Attributes:
        powers: (variable, power) pairs in canonical variable order.
    """

    powers: tuple[tuple[str, int], ...]

    @property
    def name(self) -> str:
        """Canonical text form: ``H^2``, ``H*Hdot``."""
        return '*'.join(v if p == 1 else f'{v}^{p}' for v, p in self.powers)

    @property
    def key(self) -> str:
        """Lower-case form for hand-off keys: ``h2``, ``h_hdot``, ``dtab2``."""
        return '_'.join(v.lower() + (str(p) if p > 1 else '') for v, p in self.powers)

    @property
    def variables(self) -> tuple[str, ...]:
        """Variables the term needs."""
        return tuple(v for v, _ in self.powers)

    @property
    def degree(self) -> int:
        """Total degree."""
        return sum(p for _, p in self.powers)

    def h_power(self) -> int:
        """Power of H in the term (0 if absent)."""
        return dict(self.powers).get('H', 0)


def main_effects(term: Term) -> tuple[str, ...]:
    """Names of the first powers of the term's variables.

    Names of the first powers of the term's variables, the term itself excluded: the
    terms kept while it is in a model (METHODS §D.3): ``H^3`` → ``H``; ``H*Hdot`` → ``H``,
    ``Hdot``; ``Hdot`` → none.
    """
    return tuple(v for v, _ in term.powers if Term(((v, 1),)) != term)


def parse_term(text: str) -> Term:
    """Parse ``H``, ``H^3``, ``H*Hdot``, ``Hdot*dTab`` … into a :class:`Term`.

    Raises:
        ConfigError: naming the term and the accepted forms.
    """
    powers: dict[str, int] = {}
    for factor in text.strip().split('*'):
        m = _FACTOR.match(factor.strip())
        if m is None:
            raise ConfigError(
                f'candidate term {text!r} is invalid: write products of H, Hdot, dTab, dTcs '
                "with optional powers 1–9, e.g. 'H^2', 'H*Hdot', 'dTab'.")
        var, power = m.group(1), int(m.group(2) or 1)
        powers[var] = powers.get(var, 0) + power
    return Term(tuple((v, powers[v]) for v in VARIABLES if v in powers))


def named_terms(name: str, *, max_h_power: int = 3, shell: bool = True) -> tuple[Term, ...]:
    """A named candidate set (see the module docstring)."""
    static = [f'H^{j}' if j > 1 else 'H' for j in range(1, max_h_power + 1)]
    if name == 'static':
        texts = static
    elif name == 'dynamic':
        texts = static + ['Hdot', 'Hdot^2', 'Hdot^3', 'dTab'] + (['dTcs'] if shell else [])
    elif name == 'second_order':
        texts = ['H', 'Hdot', 'dTab', 'H^2', 'Hdot^2', 'dTab^2', 'H*Hdot', 'H*dTab',
                 'Hdot*dTab']
    else:
        raise ConfigError(f'candidate set {name!r} is unknown: use one of '
                          f'{", ".join(NAMED_SETS)} or a comma-separated list of terms.')
    return tuple(parse_term(t) for t in texts)


def candidate_terms(spec: str, *, max_h_power: int = 3, shell: bool = True
                    ) -> tuple[Term, ...]:
    """Terms from a named set or a comma-separated list (duplicates removed, order kept)."""
    spec = spec.strip()
    if spec in NAMED_SETS:
        terms = named_terms(spec, max_h_power=max_h_power, shell=shell)
    else:
        terms = tuple(parse_term(t) for t in spec.split(',') if t.strip())
        if not terms:
            raise ConfigError('candidate_terms is empty: name a set (static, dynamic, '
                              'second_order) or list terms such as "H,H^2,Hdot".')
    out: list[Term] = []
    for t in terms:
        if t not in out:
            out.append(t)
    return tuple(out)


@dataclass(frozen=True, slots=True)
class VariableScaling:
    """Centre and scale of each variable: a term uses (x − centre)/scale.

    Attributes:
        centre: per variable (H °C, Hdot °C/s, dTab °C, dTcs °C).
        scale: per variable, same units, positive.
    """

    centre: dict[str, float]
    scale: dict[str, float]

    def scaled(self, var: str, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """(values − centre)/scale of one variable."""
        return (np.asarray(values, np.float64) - self.centre[var]) / self.scale[var]


def scaling_from_data(variables: dict[str, npt.NDArray[np.float64]]) -> VariableScaling:
    """Choose centres and scales from the calibration data.

    H: centre = middle of its range, scale = half the range (≥ 1 °C), so H maps to −1…1;
    Hdot: centre 0 (the intercept is then the static bias), scale = max |Ḣ| (≥ 1e-4 °C/s);
    gradients: centre = median, scale = largest distance from it (≥ 0.01 °C).
    """
    centre: dict[str, float] = {}
    scale: dict[str, float] = {}
    for var in VARIABLES:
        x = np.asarray(variables.get(var, np.zeros(0)), np.float64)
        x = x[np.isfinite(x)]
        if var == 'H':
            lo, hi = (float(x.min()), float(x.max())) if len(x) else (0.0, 0.0)
            centre[var], scale[var] = 0.5 * (lo + hi), max(0.5 * (hi - lo), 1.0)
        elif var == 'Hdot':
            centre[var] = 0.0
            scale[var] = max(float(np.max(np.abs(x))) if len(x) else 0.0, 1e-4)
        else:
            c = float(np.median(x)) if len(x) else 0.0
            centre[var] = c
            scale[var] = max(float(np.max(np.abs(x - c))) if len(x) else 0.0, 0.01)
    return VariableScaling(centre, scale)


def design_columns(terms: tuple[Term, ...], variables: dict[str, npt.NDArray[np.float64]],
                   scaling: VariableScaling) -> npt.NDArray[np.float64]:
    """Columns (n × len(terms)) of the scaled terms; the intercept is not included."""
    n = len(next(iter(variables.values()))) if variables else 0
    out = np.empty((n, len(terms)))
    cache: dict[str, npt.NDArray[np.float64]] = {}
    for j, term in enumerate(terms):
        col = np.ones(n)
        for var, power in term.powers:
            if var not in cache:
                cache[var] = scaling.scaled(var, variables[var])
            col = col * cache[var] ** power
        out[:, j] = col
    return out


def required_variables(terms: tuple[Term, ...]) -> tuple[str, ...]:
    """Variables the terms need, in canonical order."""
    needed = {v for t in terms for v in t.variables}
    return tuple(v for v in VARIABLES if v in needed)


def distinct_levels(h_c: npt.NDArray[np.float64], step_c: float) -> int:
    """Number of distinct temperature levels: occupied bins of width ``step_c``."""
    h = np.asarray(h_c, np.float64)
    h = h[np.isfinite(h)]
    if not len(h):
        return 0
    return len(np.unique(np.floor(h / step_c)))


def min_levels_for(terms: tuple[Term, ...]) -> int:
    """Distinct temperatures a polynomial in H of the terms' highest H power needs (+1 dof)."""
    top = max((t.h_power() for t in terms), default=0)
    return top + 2 if top else 0
