"""A noise run's checks before the bags are read, and its verdict when no term came out.

Plain functions of the method for the front door (``gyro-calib noise``,
:mod:`gyro_calib.cli.noise`): the outlier settings asked for (:func:`outlier_settings`), a
scale factor given for another input than the one read
(:func:`refuse_scale_flag_of_another_input`), whether a hand-off file already holds noise
terms (:func:`holds_noise_terms`), and why no term was resolved (:func:`why_no_term`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.errors import ConfigError

if TYPE_CHECKING:
    from gyro_calib.handoff import HandoffKey
    from gyro_calib.noise.session import NoiseSession

MIN_FIT_POINTS = 8
"""Fewest usable τ a term fit needs (:func:`gyro_calib.noise.fit.fit_noise_terms`)."""


def outlier_settings(outliers: str | None, outlier_sigma: str | None) -> dict[str, Any]:
    """--outliers and --outlier-sigma as settings, checked before any bag is read.

    Returns:
        The settings given (``outliers``, ``outlier_sigma``), none when neither flag is.

    Raises:
        ConfigError: a mode other than keep or remove, or k not a positive number.
    """
    from gyro_calib.noise.outliers import OUTLIER_MODES

    given: dict[str, Any] = {}
    if outliers is not None:
        if outliers not in OUTLIER_MODES:
            raise ConfigError(f'--outliers {outliers!r} is invalid: it must be keep (the '
                              'record as recorded, the spikes reported) or remove (each '
                              'replaced by the median of its neighbours). Nothing was read.')
        given['outliers'] = outliers
    if outlier_sigma is not None:
        try:
            k = float(outlier_sigma)
        except ValueError:
            k = float('nan')
        if not (k > 0 and k != float('inf')):
            raise ConfigError(f'--outlier-sigma {outlier_sigma!r} is invalid: it must be '
                              'a positive number of robust standard deviations (default 8). '
                              'Nothing was read.')
        given['outlier_sigma'] = k
    return given


def holds_noise_terms(path: Path, schema: Mapping[str, HandoffKey]) -> bool:
    """True when the hand-off file at ``path`` holds a noise term (of any run, or imu.noise)."""
    from gyro_calib.handoff import load_calibration

    if not path.exists():
        return False
    record = load_calibration(path, schema)
    return (any(getattr(schema.get(k), 'method', '') == 'noise' for k in record.values)
            or (record.imu is not None and bool(record.imu.noise)))  # a triad's imu.noise


def why_no_term(session: NoiseSession, taus: str | None) -> str:
    """Why no term came out, in a phrase for the failing line.

    A fixed τ list (setting ``taus``) that leaves fewer usable τ than a fit needs is named,
    with the flag (``taus``: the ``--taus`` given, if any) or setting it came from; else the
    reasons above are pointed to.
    """
    spec = session.settings.tau_spec
    fits = [r.fit for r in session.axis_results().values() if r.fit is not None]
    if not isinstance(spec, tuple) or not fits or any(f.estimates for f in fits):
        return 'see the reasons above'
    usable = max(int(f.used.sum()) for f in fits)
    if usable >= MIN_FIT_POINTS:
        return 'see the reasons above'
    setting = (f'--taus {taus}' if taus is not None else
               f'the setting taus = {", ".join(f"{t:g}" for t in spec)} (--config)')
    if len(spec) < MIN_FIT_POINTS:
        return (f'{setting} lists {len(spec)} averaging time(s), fewer than the '
                f'{MIN_FIT_POINTS} a term fit needs, so no record can give a term: list at '
                'least 8 τ, or leave taus at its default grid')
    return (f'{setting}: {usable} of its {len(spec)} averaging times are usable on this '
            f'record, fewer than the {MIN_FIT_POINTS} a term fit needs: list more within the '
            'record, or leave taus at its default grid')


def refuse_scale_flag_of_another_input(kind: str, topic: str, *,
                                       scale_factor_rad_per_pulse: float | None = None,
                                       scale_factor_counts_per_rad: float | None = None) -> None:
    """A scale-factor flag for an input that is not the one read is refused, not ignored.

    Args:
        kind: the input read (:func:`gyro_calib.noise.session.input_kind` of ``topic``).
        topic: the topic read.
        scale_factor_rad_per_pulse: ``--scale-factor-rad-per-pulse``, if given.
        scale_factor_counts_per_rad: ``--scale-factor-counts-per-rad``, if given.

    Raises:
        ConfigError: naming the flag, the input read and the input the flag is for.
    """
    for flag, value, fits in (('--scale-factor-rad-per-pulse', scale_factor_rad_per_pulse,
                               ('pulses', 'gyro')),
                              ('--scale-factor-counts-per-rad', scale_factor_counts_per_rad,
                               ('fog', 'gyro'))):
        if value is not None and kind not in fits:
            meant = '/gyro/pulses' if 'pulse' in flag else '/fog/output'
            raise ConfigError(f'{flag} applies to {meant}, but the input read is {topic} '
                              f'({kind}); it would be ignored. Drop it (or choose the input '
                              'with --topic). Nothing was read.')
