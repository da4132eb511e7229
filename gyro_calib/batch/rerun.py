"""A re-run gyro against its earlier hand-off: each value's move said, a move beyond 5σ refused.

A batch re-run calibrates a changed gyro (its bags, its manifest row's settings or methods)
anew and writes its hand-off whole. As ``calibrate`` and ``noise`` merge a run into a file
(:mod:`gyro_calib.handoff.merge`), a value that moves more than
:data:`~gyro_calib.handoff.merge.MAX_DISAGREEMENT_SIGMA` combined standard uncertainties
from the earlier file's is not taken unless asked for (``--replace``): the gyro is refused,
its row says why in one line (the value, both numbers, the settings that changed), and its
folder keeps the earlier run's files (issue 35 item 1). Every value replaced is a line, old
→ new.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from gyro_calib.handoff.merge import MAX_DISAGREEMENT_SIGMA

SECTIONS = ('gyro', 'imu')
"""The hand-off sections whose values a re-run replaces."""


def replaced_lines(path: Path, new_text: bytes, *, replace: bool = False) -> list[str]:
    """What this run's hand-off replaces of the gyro's earlier one, a line per value.

    ``replaced: KEY = new ± u — was old ± u (z combined standard uncertainties)``, or
    ``dropped:`` for a value the new file no longer has (issue 35 item 1: every replacement,
    on every front door, says old → new); a move beyond 5σ taken under ``replace`` says so.
    """
    old, new = _sections(path, new_text)
    if old is None or new is None:
        return []
    lines: list[str] = []
    for section in SECTIONS:
        before, after = old.get(section) or {}, new.get(section) or {}
        if not isinstance(before, dict) or not isinstance(after, dict):
            continue
        for key, was in before.items():
            if str(key).endswith(('_std', '_dof')) or key not in after and section == 'imu':
                continue
            if key not in after:
                lines.append(f'dropped: {section}.{key} (was {was})')
                continue
            now = after[key]
            if now == was:
                continue
            z = _z(now, was, after.get(f'{key}_std'), before.get(f'{key}_std'))
            far = '; --replace' if replace and z > MAX_DISAGREEMENT_SIGMA else ''
            lines.append(f'replaced: {section}.{key} = {_with_u(now, after, key)} — was '
                         f'{_with_u(was, before, key)}'
                         + (f' ({z:.1f} combined standard uncertainties{far})'
                            if math.isfinite(z) or far else ''))
    return lines


def refused_move(path: Path, new_text: bytes, schema: Mapping[str, Any],
                 gyro: str) -> str:
    """Why this run's hand-off may not replace the earlier one at ``path`` ('' if it may).

    A value (a single gyro's key, a triad's K_i or b, a channel's noise or thermal term)
    more than :data:`MAX_DISAGREEMENT_SIGMA` combined standard uncertainties from the earlier
    file's, as ``calibrate`` refuses it; bench-specific keys (a bias with the Earth rate in
    it) are not compared, as there. One line: the value furthest out, both numbers, how many
    more moved, and what differs between the two runs (the settings, old -> new, or the data).
    """
    old, new = _sections(path, new_text)
    if old is None or new is None:
        return ''
    far = sorted(((z, key, now, u_now, was, u_was)
                  for key, now, u_now, was, u_was in _pairs(old, new)
                  if not getattr(schema.get(key.split('.')[-1]), 'bench_specific', False)
                  for z in [_z(now, was, u_now, u_was)] if z > MAX_DISAGREEMENT_SIGMA),
                 key=lambda m: -m[0])
    if not far:
        return ''
    z, key, now, u_now, was, u_was = far[0]
    more = f' (and {len(far) - 1} more value(s))' if len(far) > 1 else ''
    return (f'refused: {key} would move to {_num(now, u_now)} from the {_num(was, u_was)} of '
            f'{path.name} ({z:.1f} combined standard uncertainties){more}: '
            f'{_what_differs(old, new)} {path.parent.name}/ keeps the earlier run\'s files; '
            f'check, then give --replace to take this run\'s values for {gyro}.')


def _sections(path: Path, new_text: bytes) -> tuple[dict[str, Any] | None,
                                                    dict[str, Any] | None]:
    import yaml

    try:
        old = yaml.safe_load(path.read_text(encoding='utf-8')) or {}
        new = yaml.safe_load(new_text.decode('utf-8')) or {}
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None, None
    if not isinstance(old, dict) or not isinstance(new, dict):
        return None, None
    return old, new


def _pairs(old: dict[str, Any], new: dict[str, Any]) -> Iterator[tuple[str, Any, Any, Any, Any]]:
    """(key, new value, its u, old value, its u) for every value both files hold."""
    for section in SECTIONS:
        yield from _walk(section, old.get(section), new.get(section))


def _walk(where: str, before: Any, after: Any) -> Iterator[tuple[str, Any, Any, Any, Any]]:
    if not isinstance(before, dict) or not isinstance(after, dict):
        return
    for key, was in before.items():
        if str(key).endswith(('_std', '_dof')) or key not in after:
            continue
        now, name = after[key], f'{where}.{key}'
        u_now, u_was = after.get(f'{key}_std'), before.get(f'{key}_std')
        if isinstance(was, dict):
            yield from _walk(name, was, now)
        elif isinstance(was, list) and isinstance(now, list):  # a triad's per-axis values
            labels = 'xyz' if 'bias' in str(key) else (  # b per body axis, K_i per channel
                after.get('channels') or before.get('channels') or 'xyz')
            for i, (a, b) in enumerate(zip(now, was, strict=False)):
                label = labels[i] if i < len(labels) else i
                yield (f'{name}[{label}]', a, _at(u_now, i), b, _at(u_was, i))
        else:
            yield name, now, u_now, was, u_was


def _at(values: Any, i: int) -> Any:
    return values[i] if isinstance(values, list) and i < len(values) else None


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(
        value)


def _z(now: Any, was: Any, u_now: Any, u_was: Any) -> float:
    """|now − was| in combined standard uncertainties (NaN when either lacks a number or u)."""
    if not all(_number(v) for v in (now, was, u_now, u_was)):
        return math.nan
    spread = math.hypot(float(u_now), float(u_was))
    if spread > 0:
        return abs(float(now) - float(was)) / spread
    return 0.0 if now == was else math.inf


def _with_u(value: Any, values: dict[str, Any], key: str) -> str:
    u = values.get(f'{key}_std')
    return f'{value} ± {u:.3g}' if isinstance(u, (int, float)) else str(value)


def _num(value: Any, u: Any) -> str:
    return f'{value:.6g} ± {u:.3g}' if _number(value) and _number(u) else str(value)


def _what_differs(old: dict[str, Any], new: dict[str, Any]) -> str:
    """'the same data under other settings (name: old -> new; ...) — …?', or what else differs."""
    before, after = _runs(old), _runs(new)
    changes: dict[str, str] = {}
    same_data = bool(before) and bool(after)
    for method in sorted(set(before) | set(after)):
        was, now = before.get(method, {}), after.get(method, {})
        if (was.get('source'), was.get('data_start_stamp_ns')) != (
                now.get('source'), now.get('data_start_stamp_ns')):
            same_data = False
        s0, s1 = was.get('settings') or {}, now.get('settings') or {}
        for name in sorted(set(s0) | set(s1)):
            if s0.get(name) != s1.get(name):
                changes[name] = (f'{name}: {s0.get(name, "not given")!r} -> '
                                 f'{s1.get(name, "not given")!r}')
    settings = '; '.join(changes.values())
    if same_data:
        return (f'the same data under other settings ({settings}) — which are right?'
                if settings else 'the same data under the same settings — another gyro_calib '
                'version?')
    return ('other data' + (f' under other settings ({settings})' if settings else '')
            + ' — a changed gyro, another gyro, or a wrong bench setting?')


def _runs(handoff: dict[str, Any]) -> dict[str, dict[str, Any]]:
    methods = handoff.get('methods')
    if not isinstance(methods, dict):
        return {}
    return {str(m): run for m, run in methods.items() if isinstance(run, dict)}
