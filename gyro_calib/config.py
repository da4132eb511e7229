"""Settings shared by every method: ROS 2 parameter files and dataclass field descriptions.

Each method has its own frozen settings dataclass (e.g. :class:`gyro_calib.rbrlg.config.
KTildeConfig`), validated once in ``__post_init__``; the attribute docstring after each field
is the single source of the parameter description its node declares.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import yaml

from gyro_calib.errors import ConfigError


def read_parameter_file(path: str | Path, *, node_name: str) -> dict[str, Any]:
    """The settings in a YAML file.

    The settings in a YAML file: a plain mapping, or a ROS 2 parameter file
    (``<node_name>:`` or ``/**:`` → ``ros__parameters:``).

    Raises:
        ConfigError: if the file cannot be read or parsed, or holds no mapping.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding='utf-8'))
    except OSError as exc:
        raise ConfigError(f'cannot read config file {path}: {exc.strerror}.') from None
    except yaml.YAMLError as exc:
        raise ConfigError(f'config file {path} is not valid YAML: {exc}.') from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f'config file {path} must hold a mapping of fields.')
    for key in (node_name, '/**'):
        if isinstance(data.get(key), dict) and 'ros__parameters' in data[key]:
            data = data[key]['ros__parameters']
            break
    return dict(data)


def field_descriptions(cls: type) -> dict[str, str]:
    """Attribute docstrings of a dataclass (the string right after each field), by field name.

    They are the single source of the parameter descriptions the nodes declare. Fields a
    dataclass inherits (e.g. :class:`gyro_calib.windows.WindowFields`) are described where
    they are declared, base classes first.
    """
    import ast
    import inspect
    import textwrap

    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if '__dataclass_fields__' not in vars(klass):
            continue
        tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        body = tree.body[0].body  # type: ignore[attr-defined]
        for node, after in zip(body, body[1:]):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                    and isinstance(after.value.value, str)):
                out[node.target.id] = ' '.join(after.value.value.split())
    return out


SettingsT = TypeVar('SettingsT')


def settings_from_mapping(cls: type[SettingsT], values: Mapping[str, Any], *, source: str,
                          check_types: bool = False,
                          known_sorted: bool = True) -> SettingsT:
    """A method's settings dataclass from a mapping (YAML, ROS parameters), rejecting unknown keys.

    An integer is taken for a field whose default is a float (YAML ``block_s: 2``). With
    ``check_types`` every value must also be of its default's kind (a string, an integer, a
    number), else ConfigError naming the field. The unknown-key message lists the known
    fields, sorted (``known_sorted``) or in declaration order.

    Raises:
        ConfigError: an unknown field or an invalid value, naming the field and ``source``.
    """
    import dataclasses

    names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
    unknown = sorted(set(values) - set(names))
    if unknown:
        known = sorted(names) if known_sorted else names
        raise ConfigError(f'unknown field(s) {", ".join(unknown)} in {source}; '
                          f'known fields: {", ".join(known)}.')
    defaults = cls()
    kwargs: dict[str, Any] = {}
    for name, value in values.items():
        default = getattr(defaults, name)
        if check_types:
            _check_kind(name, value, default, source)
        if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        raise ConfigError(f'{exc} (in {source})') from None


def _check_kind(name: str, value: Any, default: Any, source: str) -> None:
    """ConfigError unless ``value`` is of the kind of ``default`` (string, integer, number)."""
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f'field {name} in {source} must be a string, got {value!r}.')
    elif isinstance(default, int) and not isinstance(default, bool):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f'field {name} in {source} must be an integer, got {value!r}.')
    elif isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f'field {name} in {source} must be a number, got {value!r}.')


# ---------------------------------------------------------------------------------------
# The bench settings every front door shares (one schema, one validation)


@dataclass(frozen=True, slots=True)
class BenchSetting:
    """A setting of the bench (site, mounting, gyro) that several front doors give.

    The same setting arrives as a CLI flag, a ``--config``/``config_file`` field, a node
    parameter, or a bench setting a simulated bag stores (``scenario.bench``); every one is
    checked by :meth:`check`, so the message names its unit and range wherever it came from.

    Attributes:
        name: field / parameter / stored-bench name, unit in the name.
        unit: the unit shown in messages ('' for counts and text).
        description: what it is, its convention and default (the parameter description).
        kind: float, int or str.
        low, high: the accepted closed range (``low_open``: ``low`` itself excluded).
    """

    name: str
    unit: str
    description: str
    kind: type = float
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False

    @property
    def flag(self) -> str:
        """The CLI flag that sets it."""
        return '--' + FLAG_NAMES.get(self.name, self.name).replace('_', '-')

    def expected(self) -> str:
        """The accepted values, with the unit."""
        unit = f' {self.unit}' if self.unit else ''
        if self.kind is str:
            return 'a string'
        what = 'an integer' if self.kind is int else 'a number'
        if math.isinf(self.low) and math.isinf(self.high):
            return f'{what} (finite){unit}'
        if self.low_open and self.low == 0:
            what = 'a positive integer' if self.kind is int else 'a positive number'
            return what + (f', at most {self.high:g}{unit}' if math.isfinite(self.high)
                           else f' of{unit}')
        if math.isinf(self.high):
            rel = 'above' if self.low_open else 'at least'
            return f'{what} {rel} {self.low:g}{unit}'
        if self.low_open:
            return f'{what} above {self.low:g} and at most {self.high:g}{unit}'
        return f'{what} between {self.low:g} and {self.high:g}{unit}'

    def check(self, value: Any, where: str) -> Any:
        """``value`` checked against the setting's kind and range.

        ``value`` as ``kind`` if it is valid, else ConfigError naming the setting, where it
        came from (``where``: a flag, a file, a bag), its unit and its range.
        """
        ok = True
        if self.kind is str:
            ok = isinstance(value, str)
        elif isinstance(value, bool) or not isinstance(
                value, int if self.kind is int else (int, float)):
            ok = False
        else:
            number = float(value)
            ok = (math.isfinite(number) and number <= self.high
                  and (number > self.low if self.low_open else number >= self.low))
        if not ok:
            unit = f' {self.unit}' if self.unit and self.kind is not str else ''
            raise ConfigError(f'{self.name} = {value!r}{unit} ({where}) is invalid: it must be '
                              f'{self.expected()}.')
        return self.kind(value)


FLAG_NAMES = {'fog_scale_factor_counts_per_rad': 'scale_factor_counts_per_rad'}
"""Bench settings whose CLI flag is named differently from the field."""

_EARTH = 'ω sin φ (Up) and ω cos φ (North)'

BENCH_SETTINGS: dict[str, BenchSetting] = {s.name: s for s in (
    BenchSetting('latitude_deg', '°', 'Site latitude φ, positive North, °; the Earth rate '
                 f'{_EARTH} is removed from the bias with it (NaN / not given: the bias is '
                 'reported with the Earth rate in it).', low=-90.0, high=90.0),
    BenchSetting('heading_deg', '°', 'RBRLG: heading of the position-table base x axis, '
                 'measured from East towards North (counter-clockwise seen from above: 0 = '
                 'East, 90 = North; = 90° − the azimuth from North), °. Default 0.',
                 low=-360.0, high=360.0),
    BenchSetting('sense_axis_elevation_deg', '°', 'Thermal (static base): sense-axis elevation '
                 'above the horizon, ° (90 = vertical, the default).', low=-90.0, high=90.0),
    BenchSetting('sense_axis_azimuth_deg', '°', "Thermal (static base): azimuth of the sense "
                 "axis' horizontal part, measured from North towards East (clockwise seen from "
                 'above: 0 = North, 90 = East; = 90° − a heading from East), °. Default 0.',
                 low=-360.0, high=360.0),
    BenchSetting('position_table_revolutions', '', 'RBRLG: n, position-table revolutions each '
                 'way per θ station. Default 1.', kind=int, low=1.0, high=1000.0),
    BenchSetting('scale_factor_rad_per_pulse', 'rad/pulse', "A pulse gyro's scale factor K "
                 '(angle = K·count), rad/pulse.', low=0.0, high=1e-2, low_open=True),
    BenchSetting('fog_scale_factor_counts_per_rad', 'counts/rad', "A FOG's scale factor "
                 '(angle = count / SF), counts/rad.', low=0.0, low_open=True),
    BenchSetting('gyro_id', '', "The gyro's serial or name (hand-off identity).", kind=str),
    BenchSetting('tilt_deg', '°', 'Triad: nominal tilt α between the rate-table axis and the '
                 '(vertical) position-table axis, ° (METHODS §F.1); needed for station pairs.',
                 low=0.0, high=90.0, low_open=True),
    BenchSetting('tilt_std_arcsec', '″', 'Triad: stated standard uncertainty of the tilt α, ″ '
                 '(the prior of its fit). Default 60.', low=0.0, high=36000.0, low_open=True),
    BenchSetting('station_offset_deg', '°', 'Triad: ψ₀, the rate-table encoder zero from the '
                 'tilt plane (β = ψ + ψ₀), °. Default 0.', low=-360.0, high=360.0),
    BenchSetting('mount_axis', '', 'Triad, single-axis table (one bag per mount): the body axis '
                 'along the table axis, pointing up: +x, -x, +y, -y, +z or -z.', kind=str),
)}
"""Every bench setting, by name: the one range check of flags, config files, node parameters
and the bench settings stored in bags."""


def check_bench_setting(name: str, value: Any, where: str) -> Any:
    """``value`` checked against :data:`BENCH_SETTINGS` (see :meth:`BenchSetting.check`)."""
    return BENCH_SETTINGS[name].check(value, where)


def given(value: Any) -> bool:
    """False for None, NaN and '' (a setting not given)."""
    return value is not None and value != '' and not (
        isinstance(value, float) and math.isnan(value))


NODE_ONLY_PARAMETERS = ('config_file', 'output_file', 'process_period_s', 'fit_after_idle_s',
                        'state_dir', 'keep_state', 'resume', 'resume_max_gap_s',
                        'bench_max_rate_deg_s', 'topic',
                        'calibration_file', 'kalibr_file',
                        'plot_file', 'best_effort', 'results_period_s', 'managed',
                        'use_sim_time', 'start_type_description_service')
"""Node parameters a shared config file may hold that the offline front door does not use
(``gyro-calib`` has its own flags for the input topic, the calibration file and the outputs;
rclpy's own parameters, as ``ros2 param dump`` writes them, too)."""


NOT_GIVEN_DEFAULTS: dict[str, float] = {
    'latitude_deg': math.nan, 'scale_factor_rad_per_pulse': math.nan,
    'fog_scale_factor_counts_per_rad': math.nan, 'resume_max_gap_s': math.nan,
    'bench_max_rate_deg_s': math.nan}
"""Node parameters beside a method's settings fields whose documented default is NaN (not
given): a parameter file dumped from a node holds ``.nan`` for them."""


def field_defaults(cls: type) -> dict[str, Any]:
    """Each field of a settings dataclass with its default (the node parameter's default)."""
    import dataclasses

    defaults = cls()
    return {f.name: getattr(defaults, f.name) for f in dataclasses.fields(cls)}


def _non_finite(value: Any) -> bool:
    """A number (or a list of numbers holding one) that is NaN or ±inf."""
    items = value if isinstance(value, (list, tuple)) else [value]
    return any(isinstance(v, float) and not math.isfinite(v) for v in items)


def _is_its_default(value: Any, default: Any) -> bool:
    """``value``'s non-finite numbers are where ``default`` holds the same ones (NaN, ±inf)."""
    if isinstance(value, (list, tuple)):
        return (isinstance(default, (list, tuple)) and len(value) == len(default)
                and all(_is_its_default(v, d) for v, d in zip(value, default)))
    if not (isinstance(value, float) and not math.isfinite(value)):
        return True
    if not isinstance(default, float):
        return False
    return (math.isnan(value) and math.isnan(default)) or value == default


def _shown(value: Any) -> str:
    """A value as YAML writes it (``.nan``, ``.inf``, ``[1.0, .nan]``)."""
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix('...').strip()


def non_finite_defaults(values: Mapping[str, Any], fields: Mapping[str, Any],
                        source: str) -> list[str]:
    """The keys of a parameter file holding NaN or ±inf where that is their documented default.

    NaN (or inf) is a parameter's "not given" (or "no limit") marker only where it is its
    documented default — a settings field's (``fields``: name → default) or a node
    parameter's (:data:`NOT_GIVEN_DEFAULTS`; ``ros2 param dump`` writes them). Anywhere else a
    non-finite number is refused, naming the key. Keys the method does not know are left to
    its unknown-field check.

    Raises:
        ConfigError: a non-finite number where it is not the key's default (one line).
    """
    known = {**dict.fromkeys(BENCH_SETTINGS), **dict.fromkeys(NODE_ONLY_PARAMETERS),
             **NOT_GIVEN_DEFAULTS, **fields}
    taken = []
    for key, value in values.items():
        if key not in known or not _non_finite(value):
            continue
        if not _is_its_default(value, known[key]):
            what = ('is not a finite number' if not isinstance(value, (list, tuple))
                    else 'holds a number that is not finite')
            default = known[key]
            its = (f' (its default is {_shown(default)})' if default is not None
                   and not isinstance(default, str) else '')
            raise ConfigError(f'{source}: {key} = {_shown(value)} {what}{its}; give a '
                              'number, or leave the key out for its default.')
        taken.append(key)
    return taken


def read_method_file(path: str | Path, *, node_name: str,
                     fields: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """A method's config file: (method settings, bench settings).

    A method's config file (``--config``, a node's ``config_file`` or ``--params-file``
    parameter file): (its method settings, its bench settings).

    The file may hold every parameter of the method's node: the settings fields
    (``fields``: name → documented default, :func:`field_defaults`), the bench settings
    (:data:`BENCH_SETTINGS`, returned apart and also kept among the settings when they are
    fields too) and the node-only parameters (dropped). Anything else is refused by the
    method's own mapping reader, which lists the fields. NaN or ±inf is taken only where it
    is the key's documented default (:func:`non_finite_defaults`; then it means the default,
    e.g. "not given"), and refused anywhere else.

    Raises:
        ConfigError: the file cannot be read or parsed, holds no mapping, or a non-finite
            number where it is not the key's default.
    """
    values = read_parameter_file(path, node_name=node_name)
    non_finite_defaults(values, fields, f'config file {path}')
    names = set(fields)
    bench = {k: v for k, v in values.items() if k in BENCH_SETTINGS}
    settings = {k: v for k, v in values.items()
                if k in names or (k not in BENCH_SETTINGS and k not in NODE_ONLY_PARAMETERS
                                  and not k.startswith('qos_overrides'))}
    return settings, bench


def config_file_notes(path: str | Path, *, node_name: str,
                      fields: Mapping[str, Any]) -> list[str]:
    """The lines a front door says of a config file's NaN / inf defaults, checked before work.

    One line per key holding its documented non-finite default (a dumped parameter file):
    it is taken as not given (NaN) or as its default (inf), never silently.

    Raises:
        ConfigError: as :func:`read_method_file`.
    """
    values = read_parameter_file(path, node_name=node_name)
    lines = []
    for key in non_finite_defaults(values, fields, f'config file {path}'):
        value = values[key]
        meaning = 'taken as not given' if 'nan' in _shown(value) else 'the default is used'
        lines.append(f'config file {path}: {key} = {_shown(value)} is its documented default: '
                     f'{meaning} (give a number to set it).')
    return lines


# ---------------------------------------------------------------------------------------
# Range checks of every method's settings (one code, unit and range in every message)

_UNIT_SUFFIXES = (
    ('_rad_per_pulse', 'rad/pulse'), ('_counts_per_rad', 'counts/rad'),
    ('_deg_sqrt_h', '°/√h'), ('_deg_s2', '°/s²'), ('_deg_s', '°/s'), ('_deg_h', '°/h'),
    ('_rad_s', 'rad/s'), ('_arcsec_per_arcmin', '″/′'), ('_arcsec', '″'), ('_arcmin', '′'),
    ('_deg', '°'), ('_rad', 'rad'), ('_hz', 'Hz'), ('_ppm', 'ppm'), ('_pulses', 'pulses'),
    ('_counts', 'counts'), ('_c_per_min', '°C/min'), ('_c', '°C'), ('_s', 's'))
"""Unit of a setting by the suffix of its name (the house naming rule: unit in the name)."""


def unit_of(name: str) -> str:
    """The unit a setting's name carries ('' for plain numbers, counts and text)."""
    return next((unit for suffix, unit in _UNIT_SUFFIXES if name.endswith(suffix)), '')


RangeCheck = tuple[str, 'bool | Callable[[], bool]', str]
"""``(field, ok, expected)``: ``ok`` a bool, or a callable evaluated only after every earlier
check passed (for a check that divides by, or takes the log of, a field checked before it)."""


def check_ranges(settings: Any, checks: Iterable[RangeCheck]) -> None:
    """The one range check of a method's settings dataclass (called by its __post_init__).

    The bench settings among its fields (:data:`BENCH_SETTINGS`: latitude, sense axis, scale
    factors) are checked as the flags, node parameters and stored bench settings are; then
    each ``(field, ok, expected)`` of ``checks``, in order. A callable ``ok`` runs only once
    the checks before it passed, and an arithmetic error in it (a division by zero, the log
    of a negative, a NaN rounded) counts as the field being invalid — never a bare exception.
    The message names the field, its value with its unit, and what it must be.

    Raises:
        ConfigError: for the first field out of range.
    """
    import dataclasses

    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if f.name in BENCH_SETTINGS and given(value):
            check_bench_setting(f.name, value, 'settings')
    for name, check, expected in checks:
        if callable(check):
            try:
                ok = bool(check())
            except (ArithmeticError, ValueError):
                ok = False
        else:
            ok = check
        if not ok:
            unit = unit_of(name)
            value = getattr(settings, name)
            shown = f'{value!r} {unit}' if unit and not isinstance(value, str) else repr(value)
            raise ConfigError(f'{name} = {shown} is invalid: it must be {expected}.')
