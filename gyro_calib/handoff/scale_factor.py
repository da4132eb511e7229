"""Whether the values of a hand-off file rest on the file's scale factor.

A model fitted with another K, or a run whose values were turned into rad with a scale factor
other than the file's by enough to move one of them by more than
:data:`MAX_SCALE_FACTOR_SHIFT` of its standard uncertainty, is refused; a smaller difference
is noted (:func:`scale_factor_findings`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from gyro_calib.handoff.runs import CalibrationLike, Provenance, _own_keys
from gyro_calib.handoff.schema import HandoffKey, _numbers, _schema

SCALE_FACTOR_CONDITIONS: dict[str, tuple[tuple[str, ...], int, str]] = {
    'scale_factor_rad_per_pulse': (('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'), 1,
                                   'rad/pulse'),
    'fog_scale_factor_counts_per_rad': (('fog_scale_factor_counts_per_rad',), -1, 'counts/rad'),
}
"""A run condition naming the scale factor its values rest on → (the file's keys holding that
scale factor, the first present being the file's; the power p of the scale factor in those
values: v ∝ Kᵖ, rad = K·pulses, rad = counts/SF; its unit)."""

SCALE_FACTOR_FROM = 'scale_factor_from'
"""The run condition saying where the run's scale factor came from (a flag, a file, stored
bench settings)."""

MAX_SCALE_FACTOR_SHIFT = 0.2
"""A run's values may rest on a scale factor other than the file's only while the difference
moves none of them by more than this fraction of its standard uncertainty."""

SCALE_FACTOR_NOTE = 'scale factor: '
"""How a merge-report line about a run resting on another scale factor begins."""

MAX_MODEL_SCALE_FACTOR_PPM = 100.0
"""A model fitted with a scale factor (thermal) may differ from the file's by this much, ppm."""


@dataclass(frozen=True, slots=True)
class ScaleFactorFindings:
    """What :func:`scale_factor_findings` found: the refusal ('' if none) and merge notes."""

    problem: str = ''
    notes: tuple[str, ...] = ()
    stale: tuple[str, Provenance, str] | None = None
    """A refusal because this merge brings a new scale factor: (method, the file's run that
    rests on the old one, why) — ``replace`` drops that run's values instead."""


def _file_scale_factor(calibration: CalibrationLike, keys: tuple[str, ...],
                       ) -> tuple[str, float] | None:
    for key in keys:
        if key in calibration.values and _numbers(calibration.values[key]):
            return key, float(calibration.values[key])
    return None


def scale_factor_findings(calibration: CalibrationLike,
                          schema: Mapping[str, HandoffKey] | None = None, *,
                          new_methods: Iterable[str] = ()) -> ScaleFactorFindings:
    """Whether the values of ``calibration`` rest on the file's scale factor.

    Two rules, against the file's scale factor (``scale_factor_rad_per_pulse``, else
    ``k_tilde_rad_per_pulse``; a FOG's ``fog_scale_factor_counts_per_rad``):

    * a value that is a model fitted with a scale factor (a mapping stating
      ``…scale_factor_rad_per_pulse``, the thermal model) differing from the file's by more
      than :data:`MAX_MODEL_SCALE_FACTOR_PPM`: refused (the model's bias belongs to its K);
    * a run whose conditions name the scale factor its values rest on
      (:data:`SCALE_FACTOR_CONDITIONS`: dither's θ_d and angles, noise terms in rad) beside
      another in the file: with v ∝ Kᵖ, each value of the run that scales with it
      (:attr:`HandoffKey.scales_with_scale_factor`) would move by |(K_file/K_run)ᵖ − 1|·|v|;
      more than :data:`MAX_SCALE_FACTOR_SHIFT` of its standard uncertainty for any of them
      is refused, else the difference is noted (a merge-report line).

    Args:
        calibration: the file's content (after a merge).
        schema: the known keys.
        new_methods: the methods of the run being merged (their latest runs are this run),
            so the refusal says which side is new and notes name only what this merge brings.
    """
    sch = _schema(schema)
    new = set(new_methods)
    file_k = _file_scale_factor(calibration, SCALE_FACTOR_CONDITIONS[
        'scale_factor_rad_per_pulse'][0])
    if file_k is not None:
        for key, value in calibration.values.items():
            if not isinstance(value, dict):
                continue
            for inner, k in value.items():
                if str(inner).endswith('scale_factor_rad_per_pulse') and _numbers(k) and k > 0 \
                        and abs(file_k[1] / k - 1.0) > MAX_MODEL_SCALE_FACTOR_PPM * 1e-6:
                    run = calibration.source_of(key, sch)
                    other = calibration.source_of(file_k[0], sch)
                    return ScaleFactorFindings(
                        f'the file\'s {file_k[0]} = {file_k[1]!r} rad/pulse '
                        f'({other.source if other else "?"}) differs from the K = {k!r} '
                        f'rad/pulse its {key} was fitted with ({run.source if run else "?"}) '
                        f'by {abs(file_k[1] / k - 1.0) * 1e6:.0f} ppm (more than 100), and the '
                        f'model\'s bias belongs to its K: refit it with this K (--calibration '
                        f'FILE) or use another --out. Nothing written.')
    notes: list[str] = []
    for condition, (file_keys, power, unit) in SCALE_FACTOR_CONDITIONS.items():
        held = _file_scale_factor(calibration, file_keys)
        if held is None:
            continue
        file_key, k_file = held
        k_owner = calibration.source_of(file_key, sch)
        k_is_new = sch[file_key].method in new and k_owner is calibration.methods.get(
            sch[file_key].method)
        for method, latest in calibration.methods.items():
            for run in (latest, *latest.earlier):
                stated = run.conditions.get(condition)
                if not isinstance(stated, (int, float)) or isinstance(stated, bool) \
                        or not stated > 0 or stated == k_file:
                    continue
                k_run = float(stated)
                shift = abs((k_file / k_run) ** power - 1.0)
                worst: tuple[float, str] = (0.0, '')
                for key in sorted(_own_keys(run, latest, method, calibration.values, sch)):
                    v, u = calibration.values.get(key), calibration.values.get(key + '_std')
                    if not (sch[key].scales_with_scale_factor and _numbers(v, u)):
                        continue
                    assert v is not None and u is not None  # numbers, checked above
                    moved = shift * abs(v)
                    sigmas = moved / u if u > 0 else (math.inf if moved > 0 else 0.0)
                    if sigmas >= worst[0]:
                        worst = (sigmas, key)
                if not worst[1]:
                    continue
                run_is_new = method in new and run is latest
                ppm = abs(k_file / k_run - 1.0) * 1e6
                where = run.conditions.get(SCALE_FACTOR_FROM, 'source not stated')
                whose = 'this run\'s' if k_is_new and not run_is_new else 'the file\'s'
                rests = (f'the {method} run {run.source} rests on {condition} = {k_run!r} '
                         f'{unit} ({where}); {whose} {file_key} = {k_file!r} {unit} '
                         f'({k_owner.source if k_owner else "?"}) differs from it by '
                         f'{_figure(ppm)} ppm')
                if worst[0] > MAX_SCALE_FACTOR_SHIFT:
                    moves = (f'{rests}, which would move its {worst[1]} by '
                             f'{_figure(worst[0])} standard uncertainties (more than '
                             f'{MAX_SCALE_FACTOR_SHIFT:g})')
                    if k_is_new and not run_is_new:
                        return ScaleFactorFindings(
                            f'{moves}: not merging values that rest on another scale factor; '
                            f'write this run to another --out, then re-run {method} on '
                            f'{run.source} with --calibration on that file, or give --replace '
                            f'to drop the {method} run\'s values (then re-run {method} with '
                            '--calibration FILE). Nothing written.',
                            stale=(method, run, f'rested on {condition} = {k_run!r} {unit} '
                                   f'({where}), {_figure(ppm)} ppm from the file\'s {file_key} '
                                   f'= {k_file!r} {unit} ({k_owner.source if k_owner else "?"})'))
                    return ScaleFactorFindings(
                        f'{moves}: not merging values that rest on another scale factor; '
                        f're-run {method} with the file\'s scale factor (--calibration FILE), '
                        'or use another --out (--replace does not take values resting on '
                        'another scale factor). Nothing written.')
                if run_is_new or k_is_new or not new:
                    notes.append(f'{SCALE_FACTOR_NOTE}{rests}, which moves its values by at most '
                                 f'{worst[0]:.2g} of their standard uncertainty ({worst[1]}); '
                                 'merged.')
    return ScaleFactorFindings('', tuple(notes))


def _figure(x: float) -> str:
    """3 significant figures, without an exponent up to 10⁹ (ppm, multiples of σ)."""
    return f'{x:.3g}' if x < 1000 or not math.isfinite(x) or x >= 1e9 else f'{x:.0f}'


def scale_factor_inconsistency(calibration: CalibrationLike,
                               schema: Mapping[str, HandoffKey] | None = None) -> str:
    """Why the file is inconsistent ('' if not): :func:`scale_factor_findings`' refusal."""
    return scale_factor_findings(calibration, schema).problem
