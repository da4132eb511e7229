"""Acceptance specifications: limits per quantity and the decision rule (ILAC-G8, ISO 17025 7.8.6).

A spec file is YAML::

    # limits in the unit the certificate quotes (see gyro_calib/report/units.py)
    decision_rule: guarded_k2        # default; or guarded_k95, simple
    quantities:
      k_tilde_rad_per_pulse: {unit: ″/pulse, min: 0.8427, max: 0.8429}
      bias_rad_s: {unit: °/h, min: -0.05, max: 0.05}
      dither_axis_misalignment_rad: {unit: ′, max: 5.0}

Decision rules: ``guarded_k2`` — PASS when the k = 2 interval lies inside the limits, FAIL
when it lies entirely outside, otherwise CONDITIONAL; ``guarded_k95`` — the same with the
interval ±U at k₉₅(ν); ``simple`` — PASS when the value lies inside (shared risk, no
CONDITIONAL). The unit's verdict is FAIL if any quantity fails, CONDITIONAL if any is
conditional or not measured, else PASS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.errors import ConfigError
from gyro_calib.report.units import user_unit

RULES = {
    'guarded_k2': 'PASS when value ± 2u lies inside the limits, FAIL when it lies entirely '
                  'outside, otherwise CONDITIONAL',
    'guarded_k95': 'PASS when value ± U (k for 95 % from the degrees of freedom) lies inside '
                   'the limits, FAIL when it lies entirely outside, otherwise CONDITIONAL',
    'simple': 'PASS when the value lies inside the limits, else FAIL (simple acceptance, '
              'shared risk)',
}
DEFAULT_RULE = 'guarded_k2'

PASS, FAIL, CONDITIONAL, NOT_MEASURED = 'PASS', 'FAIL', 'CONDITIONAL', 'NOT MEASURED'


@dataclass(frozen=True, slots=True)
class Limit:
    """The acceptance limits of one quantity, in its quoted unit (None: no bound that side)."""

    key: str
    unit: str
    low: float | None
    high: float | None

    def text(self) -> str:
        """The limits as printed, e.g. '−0.05 … 0.05 °/h' or '≤ 5 ′'."""
        if self.low is not None and self.high is not None:
            return f'{self.low:g} … {self.high:g} {self.unit}'
        if self.high is not None:
            return f'≤ {self.high:g} {self.unit}'
        return f'≥ {self.low:g} {self.unit}'


@dataclass(frozen=True, slots=True)
class Spec:
    """A spec file: the decision rule and the limits by hand-off key."""

    rule: str
    limits: dict[str, Limit]
    source: str

    @property
    def rule_text(self) -> str:
        """The decision rule in words."""
        return f'{self.rule}: {RULES[self.rule]}'


def load_spec(path: Path) -> Spec:
    """Read and check a spec file.

    Raises:
        ConfigError: unreadable, not YAML, unknown rule, unit that is not the quoted unit of
            the key, limits that are not numbers or min > max — in one line naming the file.
    """
    try:
        data = yaml.safe_load(Path(path).read_text(encoding='utf-8'))
    except OSError as exc:
        raise ConfigError(f'cannot read spec file {path}: {exc.strerror or exc}.') from None
    except yaml.YAMLError as exc:
        raise ConfigError(f'spec file {path} is not valid YAML: '
                          f'{" ".join(str(exc).split())}.') from None
    return spec_from_dict(data, source=str(path))


def spec_from_dict(data: Any, *, source: str = 'spec') -> Spec:
    """Validate the spec mapping (see the module docstring)."""
    if not isinstance(data, dict) or not isinstance(data.get('quantities'), dict):
        raise ConfigError(f'spec file {source} must be a mapping with a "quantities" mapping '
                          '(hand-off key → {unit, min, max}).')
    unknown = sorted(set(data) - {'decision_rule', 'quantities'})
    if unknown:
        raise ConfigError(f'unknown field(s) {", ".join(unknown)} in spec file {source}.')
    rule = data.get('decision_rule', DEFAULT_RULE)
    if rule not in RULES:
        raise ConfigError(f'decision_rule {rule!r} in spec file {source} is unknown; use one '
                          f'of {", ".join(RULES)}.')
    limits: dict[str, Limit] = {}
    for key, entry in data['quantities'].items():
        where = f'quantities.{key} in spec file {source}'
        if not isinstance(entry, dict) or set(entry) - {'unit', 'min', 'max'}:
            raise ConfigError(f'{where} must be a mapping of unit, min, max.')
        unit = user_unit(str(key)).label
        if entry.get('unit', unit) != unit:
            raise ConfigError(f'{where} gives unit {entry.get("unit")!r}; the certificate '
                              f'quotes {key} in {unit!r}: give the limits in {unit!r}.')
        bounds = []
        for side in ('min', 'max'):
            value = entry.get(side)
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, (int, float)) or not math.isfinite(value)):
                raise ConfigError(f'{where}: {side} = {value!r} is not a finite number.')
            bounds.append(None if value is None else float(value))
        low, high = bounds
        if low is None and high is None:
            raise ConfigError(f'{where} gives neither min nor max.')
        if low is not None and high is not None and low > high:
            raise ConfigError(f'{where}: min {low:g} is above max {high:g}.')
        limits[str(key)] = Limit(str(key), unit, low, high)
    return Spec(str(rule), limits, source)


def verdict(limit: Limit, value: float, std: float, expanded: float | None,
            rule: str) -> str:
    """PASS / FAIL / CONDITIONAL of one quantity (value, u, U in the limit's unit)."""
    low = -math.inf if limit.low is None else limit.low
    high = math.inf if limit.high is None else limit.high
    if rule == 'simple':
        return PASS if low <= value <= high else FAIL
    half = 2.0 * std if rule == 'guarded_k2' else expanded
    if half is None or not math.isfinite(half):
        return CONDITIONAL
    lo, hi = value - half, value + half
    if lo >= low and hi <= high:
        return PASS
    if hi < low or lo > high:
        return FAIL
    return CONDITIONAL


def overall(verdicts: list[str]) -> str:
    """The unit's verdict from its quantities' verdicts."""
    if FAIL in verdicts:
        return FAIL
    if CONDITIONAL in verdicts or NOT_MEASURED in verdicts:
        return CONDITIONAL
    return PASS
