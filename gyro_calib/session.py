"""One calibration run of one method: the shape every method's session follows.

A session wraps a method's streaming calibrator for the shared front door: the bag
calibration feeds it :class:`~gyro_calib.bag.SampleBatch` es, ``gyro-calib calibrate`` and
``info`` print its summary and rejections, ``--json`` its results, ``--plot`` its figures,
``--out`` its hand-off record, and its node its diagnostics. Each method's session lives in
its own subpackage (``gyro_calib/<method>/session.py``) and is named in
:mod:`gyro_calib.registry`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.handoff import Calibration, Provenance, method_calibration
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from gyro_calib.bag import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection


@dataclass(frozen=True, slots=True)
class CalibrationOptions:
    """What the user told the front door (CLI flags, node parameters); None = not given.

    Each method takes the options it needs; a bag's stored bench settings (``scenario``)
    fill in what the user did not give.

    Attributes:
        latitude_deg: site latitude, ° (separates the bias from the Earth rate).
        heading_deg: table-base heading from East, °.
        config_file: the method's settings YAML (plain mapping or ROS 2 parameter file).
        position_table_revolutions: RBRLG n.
        scale_factor_rad_per_pulse: a pulse gyro's K, rad/pulse.
        scale_factor_counts_per_rad: a FOG's K, counts/rad.
        calibration_file: a hand-off file to take scale factors (and the gyro id) from.
        topic: the input topic when a method reads any topic of a type (noise: an Imu).
        sense_axis_elevation_deg, sense_axis_azimuth_deg: the sense axis on a static base, °.
        gyro_id: the gyro's serial or name (hand-off identity).
        scenario: the bench settings and truth a simulated bag stores (metadata), or {}.
        settings: the method's settings by field name (a node's ROS parameters); the
            config file's values win over them.
    """

    latitude_deg: float | None = None
    heading_deg: float | None = None
    config_file: Path | None = None
    position_table_revolutions: int | None = None
    scale_factor_rad_per_pulse: float | None = None
    scale_factor_counts_per_rad: float | None = None
    calibration_file: Path | None = None
    topic: str | None = None
    sense_axis_elevation_deg: float | None = None
    sense_axis_azimuth_deg: float | None = None
    gyro_id: str = ''
    scenario: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)

    def bench(self, key: str, default: Any) -> Any:
        """A bench setting stored in the bag (``scenario['bench'][key]``), else ``default``."""
        stored = self.scenario.get('bench', {}) if isinstance(self.scenario, dict) else {}
        return stored.get(key, default) if isinstance(stored, dict) else default

    def pick(self, given: Any, key: str, default: Any) -> Any:
        """The user's value if given, else the bag's stored bench setting, else ``default``."""
        return given if given is not None else self.bench(key, default)

    @property
    def latitude(self) -> float:
        """Latitude, ° (NaN when unknown)."""
        return float(self.pick(self.latitude_deg, 'latitude_deg', math.nan))


class MethodSession(ABC):
    """A method's calibrator behind the shared front door (see the module docstring)."""

    name: str = ''
    """The method's registry name."""

    @abstractmethod
    def topics(self) -> dict[str, str]:
        """Topic → message type this session reads."""

    @abstractmethod
    def feed(self, batch: SampleBatch) -> None:
        """Hand the samples of one batch (any of the session's topics) to the calibrator."""

    @abstractmethod
    def process(self, *, flush: bool = False) -> list[str]:
        """Do the work the data allows; new log lines. ``flush`` at the end of the data."""

    @abstractmethod
    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (only those measured)."""

    @abstractmethod
    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured, for every key the method would give."""

    @abstractmethod
    def rejections(self) -> list[Rejection]:
        """Everything rejected so far, each with its reason."""

    @abstractmethod
    def data_span_ns(self) -> tuple[int, int] | None:
        """First and last stamp the results rest on, or None."""

    def notices(self) -> list[str]:
        """Stream events worth reporting (restarts, dropped samples)."""
        return []

    def start_bag(self, index: int, path: Path) -> None:
        """The next batches come from bag ``index`` at ``path`` (methods whose bags are
        separate runs: :attr:`gyro_calib.registry.Method.separate_bags`). No-op by default."""

    def handoff_values(self) -> dict[str, Any]:
        """The hand-off keys and values (``_std`` twins beside the uncertain ones)."""
        out: dict[str, Any] = {}
        for key, est in self.results().items():
            out[key] = est.value
            out[key + '_std'] = est.std_uncertainty
        return out

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's hand-off record, or None when nothing was measured."""
        values = self.handoff_values()
        span = self.data_span_ns()
        if not values or span is None:
            return None
        return method_calibration(self.name, values,
                                  Provenance(source, span[0], span[1], self.missing()),
                                  gyro_id=gyro_id)

    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """(quantity, value, standard uncertainty, n) rows of the summary table."""
        rows = []
        for key, est in self.results().items():
            rows.append((key, f'{est.value:.10g}', f'{est.std_uncertainty:.3g}', str(est.n_used)))
        return rows

    def summary_lines(self) -> list[str]:
        """Lines under the table: counts, what is missing and why."""
        return [f'{key}: not measured — {why}' for key, why in self.missing().items()]

    def info_lines(self) -> list[str]:
        """What the method would use in the bag (``gyro-calib info``)."""
        return self.summary_lines()

    def limiting(self) -> str:
        """One line: what limits the result most (``gyro-calib info`` ends with it)."""
        missing = self.missing()
        if not self.results():
            return next(iter(missing.values()), 'no input for this method.')
        if missing:
            key, why = next(iter(missing.items()))
            return f'{key} not measured: {why}'
        return 'every quantity measured.'

    def json_section(self) -> dict[str, Any]:
        """``{"results": {KEY: {"value", "std", "n"}}, "rejections": [...]}`` (``--json``)."""
        return {
            'results': {k: {'value': e.value, 'std': e.std_uncertainty, 'n': e.n_used}
                        for k, e in self.results().items()},
            'missing': dict(self.missing()),
            'rejections': [f'{format_stamp(r.stamp_ns)}: {r.reason}' for r in self.rejections()],
        }

    def plot(self, out_dir: Path) -> list[Path]:
        """Write the method's figures (PNG) into ``out_dir``; return their paths."""
        return []

    def calibrated_anything(self) -> bool:
        """True when at least one quantity was measured."""
        return bool(self.results())
