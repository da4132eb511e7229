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
CONDITIONAL). A quantity whose method states an interval of its own (the dither misalignment)
is judged on that interval under both guarded rules. The unit's verdict is FAIL if any
quantity fails; else NO VERDICT (not measured: …) if a quantity of the spec that a method
that ran gives was not measured, or if no quantity of the spec was measured at all; else
CONDITIONAL if any is conditional; else PASS — never PASS without grounds.

An IMU's quantities are judged by the keys of docs/certificates_imu.md: a group judging every
channel alike (``imu.scale_factor_rad_per_pulse``, ``imu.misalignment_rad``,
``imu.axis_angle_rad``, ``imu.non_orthogonality_rad``, ``imu.bias_rad_s``,
``imu.noise.<term>``) or one quantity by its certificate key
(``imu.y.scale_factor_rad_per_pulse``), which takes precedence over its group.

Every quantity of a spec must be a hand-off key with a standard uncertainty, and its unit the
one the certificate quotes it in; anything else is refused naming the nearest known key or
unit (a misspelt key would otherwise be skipped, and a FAIL read as a PASS).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.errors import ConfigError
from gyro_calib.handoff import HandoffKey
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
NO_VERDICT = 'NO VERDICT'


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


def _quantities(schema: Mapping[str, HandoffKey] | None) -> dict[str, HandoffKey]:
    """The keys a spec may judge: hand-off keys with a standard uncertainty."""
    if schema is None:
        from gyro_calib.registry import handoff_schema

        schema = handoff_schema()
    return {k: v for k, v in schema.items() if v.has_std}


def _imu_groups() -> list[str]:
    from gyro_calib.report.imu import GROUPS

    return sorted(GROUPS)


def _imu_key(key: str, known: Mapping[str, HandoffKey]) -> bool:
    """An IMU quantity a spec may judge (docs/certificates_imu.md).

    A group judging every channel alike (``imu.misalignment_rad`` …, ``imu.noise.<term>``)
    or one quantity (``imu.y.scale_factor_rad_per_pulse``, ``imu.noise.y.<term>``).
    """
    from gyro_calib.report.imu import GROUPS, imu_group

    if key in GROUPS:
        return True
    parts = key.split('.')
    if key.startswith('imu.noise.') and len(parts) in (3, 4):
        return parts[-1] in known and known[parts[-1]].method == 'noise'
    return bool(imu_group(key))


def _nearest(word: str, choices: Sequence[str]) -> str:
    """The closest of ``choices`` to ``word`` (difflib), or the first when none is close."""
    close = difflib.get_close_matches(word, choices, n=1, cutoff=0.0)
    return close[0] if close else choices[0]


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


def spec_from_dict(data: Any, *, source: str = 'spec',
                   schema: Mapping[str, HandoffKey] | None = None) -> Spec:
    """Validate the spec mapping (see the module docstring).

    Raises:
        ConfigError: in one line naming the file: a quantity that is not a hand-off key with
            an uncertainty (with the nearest that is), a unit the certificate does not quote
            it in (with the one it does), limits that are not numbers, min > max.
    """
    known = _quantities(schema)
    if not isinstance(data, dict) or not isinstance(data.get('quantities'), dict):
        raise ConfigError(f'spec file {source} must be a mapping with a "quantities" mapping '
                          '(hand-off key → {unit, min, max}).')
    unknown = sorted(set(data) - {'decision_rule', 'quantities'})
    if unknown:
        near = {u: difflib.get_close_matches(u, ['decision_rule', 'quantities'], n=1)
                for u in unknown}
        hint = '; '.join(f'did you mean {near[u][0]} for {u}?' for u in unknown if near[u])
        raise ConfigError(f'unknown field(s) {", ".join(unknown)} in spec file {source}'
                          + (f' ({hint})' if hint else '') + '.')
    if not data['quantities']:
        raise ConfigError(f'spec file {source} lists no quantities: give each limit under '
                          '"quantities" (hand-off key → {unit, min, max}), or leave --spec out '
                          'for a certificate without verdicts.')
    rule = data.get('decision_rule', DEFAULT_RULE)
    if rule not in RULES:
        raise ConfigError(f'decision_rule {rule!r} in spec file {source} is unknown; use one '
                          f'of {", ".join(RULES)}.')
    limits: dict[str, Limit] = {}
    for key, entry in data['quantities'].items():
        where = f'quantities.{key} in spec file {source}'
        if str(key) not in known and not _imu_key(str(key), known):
            raise ConfigError(f'quantities.{key} in spec file {source} is not a measured '
                              f'quantity of the hand-off file (did you mean '
                              f'{_nearest(str(key), sorted(known) + _imu_groups())}?): a '
                              'misspelt quantity would never be judged; docs/reference lists '
                              'the hand-off keys and docs/certificates_imu.md the IMU groups.')
        if not isinstance(entry, dict) or set(entry) - {'unit', 'min', 'max'}:
            raise ConfigError(f'{where} must be a mapping of unit, min, max.')
        quoted = user_unit(str(key))
        unit = quoted.label or quoted.si
        if entry.get('unit', unit) != unit:
            raise ConfigError(f'{where} gives unit {entry.get("unit")!r}, which {key} cannot be '
                              f'given in: the certificate quotes it in {unit!r}; give the '
                              f'limits in {unit!r}.')
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


def refuse_unknown_imu_channels(spec: Spec | None, channels: Sequence[str] | None,
                                handoff: str) -> None:
    """Refuse a spec key naming a channel (pair, body axis) the IMU ``channels`` does not have.

    Checked once the hand-off file is known (its ``imu.channels``), before any certificate is
    written; a spec judging no IMU (``channels`` None) is not checked.

    Raises:
        ConfigError: one line naming the key, the channels and pairs there are.
    """
    if spec is None or channels is None:
        return
    from gyro_calib.imu_calibration import NOISE_TERMS
    from gyro_calib.report.imu import spec_key_refusal

    where = f'spec file {spec.source} (for {handoff or "the hand-off file"})'
    for key in spec.limits:
        why = spec_key_refusal(key, channels, NOISE_TERMS, where)
        if why is not None:
            raise ConfigError(why)


def limit_for(limits: Mapping[str, Limit], key: str) -> Limit | None:
    """The limit judging quantity ``key``: its own, else its IMU group's.

    ``imu.misalignment_rad`` judges every ``imu.<c>.misalignment_<e>_rad``
    (:func:`gyro_calib.report.imu.imu_group`).
    """
    if key in limits:
        return limits[key]
    from gyro_calib.report.imu import imu_group

    group = imu_group(key)
    return limits.get(group) if group else None


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


def interval_verdict(limit: Limit, value: float, interval: tuple[float, float],
                     rule: str) -> str:
    """PASS / FAIL / CONDITIONAL of a quantity judged on its method's own interval.

    The guarded rules take the interval [lower, upper] as it is (asymmetric: the measured
    statement); ``simple`` the value.
    """
    low = -math.inf if limit.low is None else limit.low
    high = math.inf if limit.high is None else limit.high
    if rule == 'simple':
        return PASS if low <= value <= high else FAIL
    lo, hi = interval
    if lo >= low and hi <= high:
        return PASS
    if hi < low or lo > high:
        return FAIL
    return CONDITIONAL


def overall(verdicts: Sequence[str], not_measured: Sequence[str] = ()) -> str:
    """The unit's verdict from its quantities' verdicts and the spec keys not measured.

    FAIL if any fails; NO VERDICT (naming what was not measured) if a spec quantity was not
    measured or nothing was judged; CONDITIONAL if any is; else PASS.
    """
    if FAIL in verdicts:
        return FAIL
    if not_measured:
        return f'{NO_VERDICT} (not measured: {", ".join(not_measured)})'
    if not verdicts:
        return f'{NO_VERDICT} (none of the specification\'s quantities was measured)'
    if CONDITIONAL in verdicts:
        return CONDITIONAL
    return PASS


def overall_class(text: str) -> str:
    """The CSS class of a unit's verdict: PASS, FAIL, CONDITIONAL or NOVERDICT."""
    return 'NOVERDICT' if text.startswith(NO_VERDICT) else text
