"""One calibration run of one method: the shape every method's session follows.

A session wraps a method's streaming calibrator for the shared front door: the bag
calibration feeds it :class:`~gyro_calib.bagio.SampleBatch` es, ``gyro-calib calibrate`` and
``info`` print its summary and rejections, ``--json`` its results, ``--plot`` its figures,
``--out`` its hand-off record, and its node its diagnostics. Each method's session lives in
its own subpackage (``gyro_calib/<method>/session.py``) and is named in
:mod:`gyro_calib.registry`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from gyro_calib.config import (
    BENCH_SETTINGS,
    check_bench_setting,
    field_defaults,
    given,
    read_method_file,
)
from gyro_calib.errors import ConfigError
from gyro_calib.handoff import Calibration, Provenance, method_calibration
from gyro_calib.streams import late_summary
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection


_OPTION_OF = {'fog_scale_factor_counts_per_rad': 'scale_factor_counts_per_rad'}
"""Bench setting → the CalibrationOptions attribute that carries it, where they differ."""


RUN_SETTING_OPTIONS = ('latitude_deg', 'heading_deg', 'position_table_revolutions',
                       'scale_factor_rad_per_pulse', 'scale_factor_counts_per_rad',
                       'calibration_file', 'topic', 'sense_axis_elevation_deg',
                       'sense_axis_azimuth_deg')
"""The :class:`CalibrationOptions` fields that may change a run's numbers (with ``settings``,
``config_bench`` and the config file's content: :func:`run_settings`)."""


def run_settings(options: CalibrationOptions) -> dict[str, Any]:
    """Every setting a run was given that may change its numbers, by name (its identity).

    The bench settings and scale factors given (flag or node parameter), the method
    settings given (``--outliers``, ``--taus``, a node's parameters), the bench settings of
    the config file and its content (``config_file_sha256``, so an edited file is another
    run). Written with the run in the hand-off file (``methods.<name>.settings``): the same
    bag re-run with other settings is another run, its values checked against the file's
    (:meth:`gyro_calib.handoff.Provenance.same_run`).
    """
    import hashlib

    out: dict[str, Any] = {}
    for name in RUN_SETTING_OPTIONS:
        value = getattr(options, name)
        if given(value):
            out[name] = str(value) if isinstance(value, Path) else value
    for name, value in sorted({**options.config_bench, **options.settings}.items()):
        if given(value):
            out[name] = value if isinstance(value, (bool, int, float, str)) else repr(value)
    if options.config_file is not None:
        try:
            content = Path(options.config_file).read_bytes()
        except OSError:
            content = str(options.config_file).encode()
        out['config_file_sha256'] = hashlib.sha256(content).hexdigest()[:16]
    return out


@dataclass(frozen=True, slots=True)
class CalibrationOptions:
    """What the user told the front door (CLI flags, node parameters); None = not given.

    Each method takes the options it needs. A bench setting (:data:`gyro_calib.config.
    BENCH_SETTINGS`) is resolved by :meth:`setting`: the flag or node parameter, else the
    config file, else the bench settings stored with the method's own bags, else the
    default — each value range-checked by the same code wherever it came from.

    Attributes:
        latitude_deg: site latitude, ° (separates the bias from the Earth rate).
        heading_deg: table-base heading from East towards North, °.
        config_file: the method's settings YAML (plain mapping or ROS 2 parameter file).
        position_table_revolutions: RBRLG n.
        scale_factor_rad_per_pulse: a pulse gyro's K, rad/pulse.
        scale_factor_counts_per_rad: a FOG's K, counts/rad.
        calibration_file: a hand-off file to take scale factors (and the gyro id) from.
        topic: the input topic when a method reads any topic of a type (noise: an Imu).
        sense_axis_elevation_deg: the sense axis' elevation on a static base, °.
        sense_axis_azimuth_deg: its azimuth from North towards East, °.
        gyro_id: the gyro's serial or name (hand-off identity).
        scenario: the bench settings and truth a simulated bag stores (metadata), or {}.
        settings: the method's settings by field name (a node's ROS parameters); the
            config file's values win over them.
        stored_benches: (bag, its stored ``scenario.bench``) of each of the method's own bags;
            when empty, ``scenario['bench']`` is the one stored bench.
        config_bench: the bench settings found in the config file (by name).
        given_by: 'flag' (CLI), 'parameter' (node) or 'manifest' (batch): how messages name
            a given setting.
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
    stored_benches: tuple[tuple[str, Mapping[str, Any]], ...] = ()
    config_bench: Mapping[str, Any] = field(default_factory=dict)
    given_by: str = 'flag'

    def __post_init__(self) -> None:
        """Range-check every bench setting given (flag or node parameter).

        Raises:
            ConfigError: naming the setting, the flag or parameter, its unit and range.
        """
        for name in BENCH_SETTINGS:
            value = getattr(self, _OPTION_OF.get(name, name), None)
            if given(value):
                check_bench_setting(name, value, self.origin_of_given(name))
        for name, value in self.config_bench.items():
            if given(value):
                check_bench_setting(name, value, f'config file {self.config_file}')

    def origin_of_given(self, name: str) -> str:
        """How a given setting is named: its flag, its node parameter or manifest setting."""
        if self.given_by == 'parameter':
            return f'parameter {name}'
        if self.given_by == 'manifest':
            return f'the manifest\'s {name}'
        return BENCH_SETTINGS[name].flag

    def _benches(self) -> tuple[tuple[str, Mapping[str, Any]], ...]:
        if self.stored_benches:
            return self.stored_benches
        stored = self.scenario.get('bench', {}) if isinstance(self.scenario, dict) else {}
        return (('the bag',  stored),) if isinstance(stored, dict) and stored else ()

    def stored(self, key: str) -> tuple[Any, str] | None:
        """The stored bench setting ``key`` and the bags holding it.

        The bench setting ``key`` stored with the method's bags and which bag(s) hold it,
        or None when none does.

        Raises:
            ConfigError: the bags store different values (naming the setting, the bags and
                the flag that decides), or the stored value is out of range.
        """
        found = [(src, bench[key]) for src, bench in self._benches()
                 if isinstance(bench, Mapping) and given(bench.get(key))]
        if not found:
            return None
        values = {repr(v) for _, v in found}
        if len(values) > 1:
            listing = ', '.join(f'{src} stores {v!r}' for src, v in found)
            spec = BENCH_SETTINGS.get(key)
            unit = f' {spec.unit}' if spec is not None and spec.unit else ''
            flag = spec.flag if spec is not None else STORED_ONLY_FLAGS.get(key)
            decide = (f'give {flag} (or calibrate the bags separately)' if flag is not None
                      else 'calibrate the bags separately')
            raise ConfigError(f'the bags store different bench settings {key}{unit} '
                              f'({listing}); {decide}.')
        where = ', '.join(src for src, _ in found)
        origin = f'the bench settings stored in {where}'
        value = found[0][1]
        if key in BENCH_SETTINGS:
            value = check_bench_setting(key, value, origin)
        return value, origin

    def method_settings(self, settings_cls: type, node_name: str, *,
                        parameters: str = 'ROS parameters') -> tuple[dict[str, Any], str]:
        """The method settings given, and where they came from.

        The node's parameters (:attr:`settings`), then the values of the method's config
        file (plain mapping or ROS 2 parameter file of ``node_name``), which win; and the
        source messages name: the config file, else ``parameters``. The fields of
        ``settings_cls`` are the method's settings (the bench settings and node-only
        parameters a config file may hold are left out, see :func:`read_method_file`).

        Raises:
            ConfigError: the config file cannot be read or parsed, or holds no mapping.
        """
        values = dict(self.settings)
        source = parameters
        if self.config_file is not None:
            values.update(read_method_file(self.config_file, node_name=node_name,
                                           fields=field_defaults(settings_cls))[0])
            source = str(self.config_file)
        return values, source

    def bench(self, key: str, default: Any) -> Any:
        """A bench setting stored with the method's bags, else ``default`` (see :meth:`stored`)."""
        got = self.stored(key)
        return default if got is None else got[0]

    def pick(self, given_value: Any, key: str, default: Any) -> Any:
        """The user's value if given, else the bag's stored bench setting, else ``default``."""
        return given_value if given(given_value) else self.bench(key, default)

    def setting_with_origin(self, name: str, default: Any = None) -> tuple[Any, str]:
        """A bench setting and where it came from.

        A bench setting and where it came from: flag or node parameter, else the config
        file, else the bench settings stored with the method's bags, else ``default``.
        """
        value = getattr(self, _OPTION_OF.get(name, name), None)
        if given(value):
            return check_bench_setting(name, value, self.origin_of_given(name)), \
                self.origin_of_given(name)
        if given(self.config_bench.get(name)):
            where = f'config file {self.config_file}'
            return check_bench_setting(name, self.config_bench[name], where), where
        got = self.stored(name)
        if got is not None:
            return got
        return default, 'default'

    def setting(self, name: str, default: Any = None) -> Any:
        """A bench setting's value (see :meth:`setting_with_origin`)."""
        return self.setting_with_origin(name, default)[0]

    def conflicts(self, names: Iterable[str]) -> list[str]:
        """Bench settings given that differ from the stored ones.

        One line per bench setting given (flag, parameter, config file) that differs from
        the bench settings stored with the bags (or published on /sim/scenario).
        """
        lines = []
        for name in names:
            value, origin = self.setting_with_origin(name)
            if origin == 'default' or origin.startswith('the bench settings') \
                    or not given(value):
                continue
            try:
                got = self.stored(name)
            except ConfigError:
                continue  # the bags disagree among themselves; the given value decides
            if got is None or got[0] == value:
                continue
            unit = BENCH_SETTINGS[name].unit
            unit = f' {unit}' if unit else ''
            lines.append(f'{name}: {origin} gives {value!r}{unit} but {got[1]} says '
                         f'{got[0]!r}{unit}; using {value!r}{unit} (check which is right).')
        return lines

    @property
    def latitude(self) -> float:
        """Latitude, ° (NaN when unknown)."""
        return float(self.setting('latitude_deg', math.nan))


STORED_ONLY_FLAGS = {'topic': '--topic'}
"""Stored bench settings outside :data:`BENCH_SETTINGS` and the flag that decides when the
bags store different values (noise's input topic)."""


@dataclass(frozen=True, slots=True)
class Progress:
    """A session's progress at a glance (a node's /diagnostics status).

    Attributes:
        level: 'OK' (everything measured), 'WARN' (something still missing), 'ERROR'
            (something is wrong: :meth:`MethodSession.problems`).
        message: one line: what is measured, then the first thing wrong or still needed.
        needs: quantity → what it still needs, roughly how much more data.
        problems: what is wrong, each a sentence.
    """

    level: str
    message: str
    needs: dict[str, str]
    problems: tuple[str, ...] = ()


class MethodSession(ABC):
    """A method's calibrator behind the shared front door (see the module docstring)."""

    name: str = ''
    """The method's registry name."""

    run_settings: Mapping[str, Any] = MappingProxyType({})
    """The settings the run was given (:func:`run_settings`; set by
    :meth:`gyro_calib.registry.Method.make_session`), written with its hand-off record."""

    live: bool = False
    """Set by a live node: the session may end the run by itself (:meth:`finished`)."""

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

    def finished(self) -> str:
        """'' while the run goes on; else why it is over (a live node then exits 0).

        A live session (:attr:`live`) whose calibration is complete by its own criterion
        says so here, once, and takes no more data; by default a run ends only when stopped.
        """
        return ''

    def notices(self) -> list[str]:
        """Stream events worth reporting (restarts, dropped samples)."""
        return []

    def late_input(self, late: Sequence[tuple[str, int]]) -> list[str]:
        """Samples a live node received after later stamps had been handed over; lines.

        ``late`` holds (topic, stamp) of each (:class:`~gyro_calib.streams.WatermarkMerge`:
        its reader lagged the others by more than the node's input hold). They were fed as
        out-of-order data. A method that knows which of its windows needs which stamps
        rejects those windows (FOG); by default one line says where the numbers may not be
        those of a recording of the run.
        """
        return [f'{late_summary(late)} arrived after later stamps had been calibrated (the '
                f'reader lagged more than the input hold): taken as out-of-order data; the '
                f'windows around them may differ from the offline numbers of a recording — '
                f'replay slower or give the node more CPU.']

    def needs(self) -> dict[str, str]:
        """What each quantity not yet measured still needs, roughly how much more data.

        By default the reason each is missing, once per distinct reason (the reasons name
        the counts the data gave and the counts needed); methods say it in amounts.
        """
        out: dict[str, str] = {}
        for key, why in self.missing().items():
            if why not in out.values():
                out[key] = why
        return out

    def problems(self) -> list[str]:
        """What is wrong rather than merely incomplete (a node reports it as ERROR).

        By default: data arrived and all of it was rejected.
        """
        rejections = self.rejections()
        if rejections and not self.results():
            return [f'nothing accepted yet; {len(rejections)} rejected, the last: '
                    f'{rejections[-1].reason}']
        return []

    def progress(self) -> Progress:
        """What is measured, what is still needed and how much more, and a level."""
        results, needs, problems = self.results(), self.needs(), self.problems()
        shown = [f'{k} n={e.n_used}' for k, e in results.items()]
        measured = (f'{len(results)} measured ({", ".join(shown[:3])}'
                    + (', …)' if len(shown) > 3 else ')') if results else 'nothing measured yet')
        if problems:
            return Progress('ERROR', f'{measured}; wrong: {problems[0]}', needs,
                            tuple(problems))
        if not needs:
            return Progress('OK', f'complete: {measured}', needs)
        return Progress('WARN', f'{measured}; still needed: {next(iter(needs.values()))}',
                        needs)

    def start_bag(self, index: int, path: Path) -> None:
        """The next batches come from bag ``index``.

        The next batches come from bag ``index`` at ``path`` (methods whose bags are
        separate runs: :attr:`gyro_calib.registry.Method.separate_bags`). No-op by default.
        """

    def handoff_values(self) -> dict[str, Any]:
        """The hand-off keys and values (``_std`` and ``_dof`` twins beside the uncertain ones)."""
        out: dict[str, Any] = {}
        for key, est in self.results().items():
            out[key] = est.value
            out[key + '_std'] = est.std_uncertainty
            out[key + '_dof'] = est.supported_dof
        return out

    def conditions(self) -> dict[str, Any]:
        """The bench settings the results rest on, by name.

        The bench settings the results rest on (latitude, heading, K used...), by name;
        written with the run in the hand-off file.
        """
        return {}

    def deviation_tables(self) -> dict[str, dict[str, Any]]:
        """Per-τ tables written with the run in the hand-off file, by axis (noise only).

        See :data:`gyro_calib.handoff.DEVIATION_FIELDS`; empty for a method without curves.
        """
        return {}

    def not_measurable(self) -> dict[str, str]:
        """Missing keys no run on such a bench could give, with why.

        Hand-off keys among :meth:`missing` that no run on such a bench could give (its
        streams lack what they need), with why; a file is complete without them.
        """
        return {}

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's hand-off record, or None when nothing was measured."""
        values = self.handoff_values()
        span = self.data_span_ns()
        if not values or span is None:
            return None
        missing = self.missing()
        cannot = {k: v for k, v in self.not_measurable().items() if k in missing}
        conditions = {k: v for k, v in self.conditions().items() if given(v)}
        return method_calibration(
            self.name, values,
            Provenance(source, span[0], span[1],
                       {k: v for k, v in missing.items() if k not in cannot},
                       conditions=conditions, not_measurable=cannot,
                       deviations=self.deviation_tables(), settings=dict(self.run_settings)),
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
