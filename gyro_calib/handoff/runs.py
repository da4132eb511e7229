"""Runs: where the values of a hand-off file came from, and which keys each run gave.

:class:`Provenance` is one run of a method (source, data span, bench conditions, the keys it
gave, the earlier runs whose keys the file kept); :class:`CalibrationLike` is what the merge
and scale-factor rules read of a whole file (:class:`~gyro_calib.handoff.calibration.Calibration`
satisfies it), so those rules sit below the record that uses them.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from gyro_calib.handoff.schema import HandoffKey, _base_key
from gyro_calib.imu_calibration import ImuCalibration


def _utc_now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')


def source_identity(source: str) -> tuple[str, ...]:
    """The places a run's ``source`` names, however their paths were spelled.

    Each comma-separated bag path that exists here is resolved (relative to the working
    directory, through links); 'live' and paths not found (a record written on another
    machine) are kept as written, so records written before stay comparable.
    """
    from pathlib import Path

    out = []
    for part in source.split(', '):
        try:
            path = Path(part)
            out.append(str(path.resolve()) if part and path.exists() else part)
        except (OSError, ValueError):  # an odd name: compared as written
            out.append(part)
    return tuple(out)


@dataclass(frozen=True, slots=True)
class Provenance:
    """Where one method's values came from.

    Attributes:
        source: 'live' or the bag path(s) calibrated.
        data_start_stamp_ns, data_end_stamp_ns: header stamps of the first and last sample the
            values rest on, int ns.
        missing: keys this method would measure from such a bench but did not, with why.
        created_utc: when the values were produced, ISO-8601 UTC.
        conditions: the bench settings the values rest on (latitude_deg, heading_deg, the
            scale factor a model was fitted with...), by name.
        not_measurable: keys the method gives, but not from such a bench, with why.
        keys: the keys (no ``_std``) of the file this run gave; None = all of its method's
            (a record not yet merged, or a format 1/2 file).
        earlier: earlier runs of the method whose keys the file kept (each with its keys).
        deviations: the per-τ tables the run's values rest on, by axis (a noise run: τ,
            ADEV, MDEV, HDEV, TOTDEV with their standard uncertainties and EDF; see
            :data:`DEVIATION_FIELDS`); empty for the other methods.
        settings: every setting the run was given that may change its numbers (flags,
            config-file values, by name; :func:`gyro_calib.session.run_settings`): part of
            the run's identity (:meth:`same_run`).
    """

    source: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    missing: Mapping[str, str] = field(default_factory=dict)
    created_utc: str = field(default_factory=_utc_now_iso)
    conditions: Mapping[str, Any] = field(default_factory=dict)
    not_measurable: Mapping[str, str] = field(default_factory=dict)
    keys: tuple[str, ...] | None = None
    earlier: tuple[Provenance, ...] = ()
    deviations: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    settings: Mapping[str, Any] = field(default_factory=dict)

    def same_data(self, other: Provenance) -> bool:
        """True when both rest on the same data (source and first stamp).

        The sources are compared as the places they name (:func:`source_identity`): one bag
        given once as ``bags/x`` and once as ``/abs/bags/x`` is the same data.
        """
        return (self.data_start_stamp_ns == other.data_start_stamp_ns
                and source_identity(self.source) == source_identity(other.source))

    def same_run(self, other: Provenance) -> bool:
        """True when both describe one run (a live node rewriting its file as it goes).

        One run: the same data (:meth:`same_data`) under the same settings. The same bag
        re-run with another setting (outlier mode, latitude, τ list, a config value) is
        another run: its values are checked against the file's like any other run's.
        """
        return self.same_data(other) and dict(self.settings) == dict(other.settings)

    def settings_change(self, older: Provenance) -> str:
        """The settings that differ from ``older``'s, 'name: old -> new; ...' ('' if none)."""
        names = sorted(set(self.settings) | set(older.settings))
        return '; '.join(f'{n}: {older.settings.get(n, "not given")!r} -> '
                         f'{self.settings.get(n, "not given")!r}' for n in names
                         if self.settings.get(n) != older.settings.get(n))

    def label(self) -> str:
        """The run in one phrase, for merge lines."""
        return f'{self.source} ({self.created_utc})'


def _run_keys(prov: Provenance, method: str, values: Mapping[str, Any],
              schema: Mapping[str, HandoffKey]) -> set[str]:
    """The base keys of ``values`` that ``prov`` (a run of ``method``) gave."""
    mine = {_base_key(k) for k in values
            if schema.get(_base_key(k), HandoffKey(k, '', '')).method == method}
    return mine if prov.keys is None else mine & set(prov.keys)


def _own_keys(run: Provenance, latest: Provenance, method: str, values: Mapping[str, Any],
              schema: Mapping[str, HandoffKey]) -> set[str]:
    """The base keys of ``values`` that ``run`` (``latest`` or one of its earlier runs) gave."""
    keys = _run_keys(run, method, values, schema)
    if run.keys is None and run is latest:
        keys -= {k for e in latest.earlier if e.keys for k in e.keys}
    return keys


class CalibrationLike(Protocol):
    """What the merge and scale-factor rules read of a hand-off file's content.

    :class:`~gyro_calib.handoff.calibration.Calibration` is one; the rules take this so that
    they need not import the record that applies them.
    """

    @property
    def values(self) -> Mapping[str, Any]:
        """Hand-off key → value (with the ``_std`` and ``_dof`` twins)."""

    @property
    def methods(self) -> Mapping[str, Provenance]:
        """Method → its latest run (with the earlier runs whose keys were kept)."""

    @property
    def imu(self) -> ImuCalibration | None:
        """The ``imu:`` section, if any."""

    def source_of(self, key: str, schema: Mapping[str, HandoffKey] | None = None,
                  ) -> Provenance | None:
        """The run a value came from (None when absent)."""
