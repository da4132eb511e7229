"""The certificate of an IMU: a triad's ``imu:`` section as certificate quantities (METHODS §F).

:func:`imu_quantities` turns a format-4 hand-off's ``imu:`` section into the quantities a lab
quotes, one :class:`ImuQuantity` each (SI; the certificate converts):

* ``imu.<c>.scale_factor_rad_per_pulse`` — K_i of channel c (the hand-off's value and u);
* ``imu.<c>.misalignment_<e>_rad`` — m_ij = s_ij/s_ii, the sense axis of channel c toward the
  other body axes e (small-angle form, the hand-off's ``misalignment_rad``);
* ``imu.<c>.axis_angle_rad`` — the angle between s_i and its body axis e_i;
* ``imu.<a>-<b>.non_orthogonality_rad`` — asin(s_a·s_b): how far the two sense axes are from
  90° (positive: closer than 90°);
* ``imu.bias_<e>_rad_s`` — b along body axis e (Earth rate removed, as the hand-off holds it);
* ``imu.noise.<c>.<term>`` — the noise terms of channel c where a noise run measured them.

The direction quantities' u is propagated to first order from the covariance of M the
hand-off holds (R = M⁻¹, r_i = s_i/K_i: METHODS §F eqs. (10)–(11)), so it keeps the
correlations of the joint fit; without M (a channel not measurable) it is the row's
√trace C(s_i), an upper bound. ν is the hand-off's: K_i's ``scale_factor_rad_per_pulse_dof``
for every quantity of row i (one row fit), the smaller of the two rows' for a pair and for
M; a quantity whose ν the hand-off does not state takes the run's (bags given) or k = 2 with
a line saying so. The per-source budget (counts, swept angle, tilt α: §F eq. (12)) is the
run's, where the bags are given (:func:`budget_shares`).

:func:`imu_group` maps a quantity to the spec key that judges every channel alike
(``imu.scale_factor_rad_per_pulse``, ``imu.misalignment_rad`` …; :data:`GROUPS`).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from gyro_calib.imu_calibration import ImuCalibration

Array = npt.NDArray[np.float64]

BODY_AXES = ('x', 'y', 'z')
"""The body axes e_1, e_2, e_3, by name (rows of M, components of b)."""

GROUPS = {
    'imu.scale_factor_rad_per_pulse': 'every channel\'s scale factor K_i (METHODS §F eq. (10))',
    'imu.misalignment_rad': 'every misalignment m_ij = s_ij/s_ii of a sense axis toward '
                            'another body axis (small angle)',
    'imu.axis_angle_rad': 'every sense axis\'s angle to its own body axis',
    'imu.non_orthogonality_rad': 'every pair of sense axes\' deviation from 90° '
                                 '(asin s_a·s_b)',
    'imu.bias_rad_s': 'every body-frame bias component b_e (Earth rate removed; METHODS §F '
                      'eq. (14))',
}
"""Spec keys judging every channel (pair, axis) alike; ``imu.noise.<term>`` too, per term."""

_PATTERNS = (
    (re.compile(r'^imu\.[^.]+\.scale_factor_rad_per_pulse$'), 'imu.scale_factor_rad_per_pulse'),
    (re.compile(r'^imu\.[^.]+\.misalignment_[xyz]_rad$'), 'imu.misalignment_rad'),
    (re.compile(r'^imu\.[^.]+\.axis_angle_rad$'), 'imu.axis_angle_rad'),
    (re.compile(r'^imu\.[^.]+-[^.]+\.non_orthogonality_rad$'), 'imu.non_orthogonality_rad'),
    (re.compile(r'^imu\.bias_[xyz]_rad_s$'), 'imu.bias_rad_s'),
)
_NOISE = re.compile(r'^imu\.noise\.[^.]+\.([a-z0-9_]+)$')

FLEET_COLUMNS = ('scale_factor_rad_per_pulse', 'misalignment_x_rad', 'misalignment_y_rad',
                 'misalignment_z_rad', 'axis_angle_rad', 'non_orthogonality_rad',
                 'bias_rad_s', 'angle_random_walk_rad_per_sqrt_s')
"""The quantities of an IMU's channel row in the fleet files (see :attr:`ImuQuantity.column`):
channel i's row holds its K, its sense axis's misalignments toward the other body axes (its
own is empty), its axis angle, its non-orthogonality to the next channel (z to x), the bias
along body axis i and its angle random walk."""


def imu_group(key: str) -> str:
    """The spec key judging every channel alike that covers quantity ``key`` ('' none)."""
    for pattern, group in _PATTERNS:
        if pattern.match(key):
            return group
    noise = _NOISE.match(key)
    return f'imu.noise.{noise.group(1)}' if noise else ''


def certificate_keys(channels: Sequence[str], noise_terms: Sequence[str]) -> list[str]:
    """Every per-channel (pair, component) key a certificate of these channels may hold."""
    ch = list(channels)
    keys: list[str] = []
    for i, c in enumerate(ch):
        keys.append(f'imu.{c}.scale_factor_rad_per_pulse')
        keys += [f'imu.{c}.misalignment_{e}_rad' for j, e in enumerate(BODY_AXES)
                 if j != i]
        keys.append(f'imu.{c}.axis_angle_rad')
    if len(ch) == 3:
        keys += [f'imu.{ch[a]}-{ch[b]}.non_orthogonality_rad' for a, b in ((0, 1), (1, 2), (2, 0))]
    keys += [f'imu.bias_{e}_rad_s' for e in BODY_AXES]
    keys += [f'imu.noise.{c}.{t}' for c in ch for t in noise_terms]
    return keys


def spec_key_refusal(key: str, channels: Sequence[str], noise_terms: Sequence[str],
                     where: str) -> str | None:
    """Why spec key ``key`` names no quantity of an IMU with ``channels`` (None: it does).

    A group key (:data:`GROUPS`, ``imu.noise.<term>``) and a key that is not an IMU's pass;
    a per-channel key (``imu.<c>.…``, ``imu.<a>-<b>.…``, ``imu.noise.<c>.<term>``) must
    name a channel (pair, the channel's other body axes) of this IMU: a misspelt channel
    would judge nothing. ``where``: the spec file and the hand-off file, as the line names
    them.
    """
    if not is_imu_key(key) or key in GROUPS or not imu_group(key):
        return None
    valid = certificate_keys(channels, noise_terms)
    if key in valid:
        return None
    ch = list(channels)
    pairs = ', '.join(f'{ch[a]}-{ch[b]}' for a, b in ((0, 1), (1, 2), (2, 0))) \
        if len(ch) == 3 else 'none'
    near = difflib.get_close_matches(key, valid, n=1, cutoff=0.0)
    hint = f'did you mean {near[0]}? ' if near else ''
    return (f'quantities.{key} in {where} names no quantity of this IMU ({hint}its channels '
            f'are {", ".join(ch)}, its pairs {pairs}; a channel\'s misalignments are toward '
            'the other body axes): a misspelt channel would judge nothing; name one of them, '
            'or use the group key ' f'{imu_group(key)} for every channel.')


def is_imu_key(key: str) -> bool:
    """A certificate quantity (or spec key) of an IMU: ``imu.`` prefixed."""
    return key.startswith('imu.')


@dataclass(frozen=True, slots=True)
class ImuQuantity:
    """One quantity of an IMU, SI.

    Attributes:
        key: as the certificate names it (module docstring).
        description: what it is.
        value, std: value and standard uncertainty.
        dof: ν where the hand-off states it (None: not stated).
        channel: the fleet row it belongs to ('' none: M); ``column`` its column there.
        budget: the evidence budget it is split by ('' none), see :func:`budget_shares`.
        note: a line for the row ('' none).
        estimate: the run's estimate key it is compared with ('' none).
    """

    key: str
    description: str
    value: float
    std: float
    dof: float | None
    channel: str = ''
    column: str = ''
    budget: str = ''
    note: str = ''
    estimate: str = ''


def _angles(m_vec: Array) -> Array:
    """[K_i, m_ij (i≠j), θ_i, δ_ab] from vec_row(M) (the order of :func:`_angle_keys`)."""
    r = np.linalg.inv(m_vec.reshape(3, 3))
    k = 1.0 / np.linalg.norm(r, axis=1)
    s = r * k[:, None]
    out = list(k)
    out += [s[i, j] / s[i, i] for i in range(3) for j in range(3) if j != i]
    out += [math.atan2(math.hypot(*[s[i, j] for j in range(3) if j != i]), s[i, i])
            for i in range(3)]
    out += [math.asin(float(np.clip(s[a] @ s[b], -1.0, 1.0)))
            for a, b in ((0, 1), (1, 2), (2, 0))]
    return np.array(out)


def _propagated(m: Array, cov: Array) -> Array:
    """Covariance of :func:`_angles` from C(vec M), by a central-difference Jacobian."""
    x = m.reshape(9)
    steps = np.maximum(np.abs(x), np.max(np.abs(x))) * 1e-6
    jac = np.empty((15, 9))
    for j in range(9):
        dx = np.zeros(9)
        dx[j] = steps[j]
        jac[:, j] = (_angles(x + dx) - _angles(x - dx)) / (2 * steps[j])
    return np.asarray(jac @ cov @ jac.T, dtype=np.float64)


def _finite(x: Any) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def imu_quantities(imu: ImuCalibration,
                   noise_description: Callable[[str], str] | None = None,
                   ) -> list[ImuQuantity]:
    """The certificate quantities of an ``imu:`` section (module docstring), in print order."""
    ch = imu.channels
    k, k_std, k_dof = (imu.scale_factor_rad_per_pulse, imu.scale_factor_rad_per_pulse_std,
                       imu.scale_factor_rad_per_pulse_dof)
    solved = [i for i in range(3) if k is not None and math.isfinite(float(k[i]))]
    dof: list[float | None] = [None, None, None]
    if k_dof is not None:  # .inf stays inf
        dof = [float(k_dof[i]) if i in solved and not math.isnan(k_dof[i]) else None
               for i in range(3)]
    cov = None
    if imu.pulses_to_body_rad is not None and imu.pulses_to_body_rad_covariance is not None:
        cov = _propagated(np.asarray(imu.pulses_to_body_rad, float),
                          np.asarray(imu.pulses_to_body_rad_covariance, float))
    u_of = (lambda idx: math.sqrt(max(float(cov[idx, idx]), 0.0))) if cov is not None \
        else None
    bound = ('u: √trace C(s_i) of the row, an upper bound (the hand-off holds no covariance of '
             'M: a channel is not measurable)')
    out: list[ImuQuantity] = []
    s = imu.sense_axes
    off = [(i, j) for i in range(3) for j in range(3) if j != i]
    for i in solved:
        assert k is not None and k_std is not None
        out.append(ImuQuantity(
            f'imu.{ch[i]}.scale_factor_rad_per_pulse', f'channel {ch[i]}: scale factor K_i = '
            '1/|r_i| (METHODS §F eq. (10))', float(k[i]), float(k_std[i]), dof[i], ch[i],
            'scale_factor_rad_per_pulse', f'imu.{ch[i]}.scale_factor_rad_per_pulse',
            estimate=f'imu.{ch[i]}.scale_factor_rad_per_pulse'))
        if s is None:
            continue
        row_std = float(imu.sense_axes_std_rad[i]) if imu.sense_axes_std_rad is not None \
            else math.nan
        for j in range(3):
            if j == i:
                continue
            value = float(s[i, j] / s[i, i])
            std = u_of(3 + off.index((i, j))) if u_of else row_std
            out.append(ImuQuantity(
                f'imu.{ch[i]}.misalignment_{BODY_AXES[j]}_rad',
                f'channel {ch[i]}: misalignment of its sense axis toward body {BODY_AXES[j]}, '
                f'm = s·e_{BODY_AXES[j]}/s·e_{BODY_AXES[i]} (small angle)', value, std, dof[i],
                ch[i], f'misalignment_{BODY_AXES[j]}_rad', f'imu.{ch[i]}.sense_axis_rad',
                '' if u_of else bound))
        angle = math.atan2(math.hypot(*[s[i, j] for j in range(3) if j != i]), s[i, i])
        out.append(ImuQuantity(
            f'imu.{ch[i]}.axis_angle_rad', f'channel {ch[i]}: angle of its sense axis to body '
            f'axis {BODY_AXES[i]}', angle, u_of(9 + i) if u_of else row_std, dof[i], ch[i],
            'axis_angle_rad', f'imu.{ch[i]}.sense_axis_rad', '' if u_of else bound))
    if s is not None:
        for n, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
            if a not in solved or b not in solved:
                continue
            value = math.asin(float(np.clip(s[a] @ s[b], -1.0, 1.0)))
            std = u_of(12 + n) if u_of else math.hypot(float(imu.sense_axes_std_rad[a]),
                                                       float(imu.sense_axes_std_rad[b])) \
                if imu.sense_axes_std_rad is not None else math.nan
            nu = [d for d in (dof[a], dof[b]) if d is not None]
            out.append(ImuQuantity(
                f'imu.{ch[a]}-{ch[b]}.non_orthogonality_rad',
                f'channels {ch[a]}, {ch[b]}: non-orthogonality of their sense axes, '
                '90° − their angle', value, std, min(nu) if len(nu) == 2 else None, ch[a],
                'non_orthogonality_rad', f'imu.{ch[a]}.sense_axis_rad',
                '' if u_of else bound))
    if imu.bias_rad_s is not None and imu.bias_rad_s_std is not None:
        for i, e in enumerate(BODY_AXES):
            out.append(ImuQuantity(
                f'imu.bias_{e}_rad_s', f'bias along body {e}, Earth rate removed (ω_B = M·ṅ − '
                'b; METHODS §F eq. (14))', float(imu.bias_rad_s[i]), float(imu.bias_rad_s_std[i]),
                None, ch[i], 'bias_rad_s', f'imu.bias_rad_s.{e}',
                estimate=f'imu.bias_rad_s.{e}'))
    for name in ch:
        terms = imu.noise.get(name, {})
        for term in terms:
            if term + '_std' not in terms or term.endswith(('_std', '_dof')):
                continue
            what = noise_description(term) if noise_description else term
            out.append(ImuQuantity(
                f'imu.noise.{name}.{term}', f'channel {name}: {what} (METHODS §E)',
                float(terms[term]), float(terms[term + '_std']),
                _finite(terms.get(term + '_dof')), name, term))
    return out


def noise_bounds(imu: ImuCalibration) -> list[tuple[str, float]]:
    """(``imu.noise.<c>.<term>``, value) of the noise terms only bounded (2σ upper bounds)."""
    return [(f'imu.noise.{name}.{term}', float(v)) for name in imu.channels
            for term, v in imu.noise.get(name, {}).items()
            if term.endswith('_upper_bound_2sigma')]


def budget_shares(std: float, lines: tuple[tuple[str, float, float], ...],
                  ) -> tuple[tuple[str, float, float], ...]:
    """A quantity's u split in the shares of a budget ((source, u_source, ν), SI).

    The triad's budget of a sense axis is its direction's √trace C(s_i) per source (§F eq.
    (12)); a component (misalignment, angle) takes each source's share of it.
    """
    total = math.sqrt(sum(u * u for _, u, _ in lines))
    if not total > 0:
        return ()
    return tuple((source, std * u / total, nu) for source, u, nu in lines)


def matrix_text(imu: ImuCalibration) -> str:
    """M with the standard uncertainty of each element (rad/pulse), one row a line."""
    m = imu.pulses_to_body_rad
    if m is None:
        return ''
    cov = imu.pulses_to_body_rad_covariance
    std = (np.sqrt(np.maximum(np.diag(np.asarray(cov, float)), 0.0)).reshape(3, 3)
           if cov is not None else np.full((3, 3), math.nan))
    return '\n'.join('  '.join(f'{m[i, j]: .10e} ± {std[i, j]:.2e}' for j in range(3))
                     for i in range(3))


def procedure_text(conditions: Mapping[str, Any]) -> str:
    """Two-axis bench or remount, from the run's conditions (``mount_axis``)."""
    mounts = str(conditions.get('mount_axis') or '')
    if mounts:
        return (f'remount on a single-axis rate table: one bag per mount ({mounts}); METHODS '
                '§F')
    return ('two-axis bench: rate-table (inner axis) pairs and position-table stations, the '
            'tilt α fitted; METHODS §F')
