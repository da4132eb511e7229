"""Property: every method's settings refuse a bad number with ConfigError, never a crash.

Issue 17 §2 (leftover): ``ThermalSettings(averaging_interval_s=0.0)`` raised a bare
ZeroDivisionError (a division in a range check evaluated before the interval itself was
checked), which the CLI shows as a traceback instead of one line and exit 2. Each numeric
field of each method's settings dataclass is set, alone or with others, to the edge values a
user can type — 0, −0, negative, tiny, huge, NaN, ±inf — and the constructor must either
accept the settings or raise ConfigError; nothing else. NaN is also refused wherever it does
not mean "not given" (only fields whose default is NaN accept it).

Derandomized with a small example count; ``GYRO_CALIB_STRESS=1`` raises it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib.cli import main as gyro_calib
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.errors import ConfigError
from gyro_calib.fog.settings import FogSettings
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.rbrlg.config import KTildeConfig
from gyro_calib.thermal.settings import ThermalSettings

BAGS = Path(__file__).resolve().parents[1] / 'bags'
STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
CLASSES = (KTildeConfig, FogSettings, DitherSettings, ThermalSettings, NoiseSettings)

EDGE_FLOATS = (0.0, -0.0, -1.0, -1e-300, 1e-300, 5e-324, 1e300, -1e300,
               math.nan, math.inf, -math.inf)
EDGE_INTS = (0, -1, 1, 2, 3, -(2 ** 31), 2 ** 62)


def _numeric_fields(cls: type) -> list[dataclasses.Field[Any]]:
    return [f for f in dataclasses.fields(cls) if str(f.type) in ('float', 'int')]


def _edge(kind: str) -> st.SearchStrategy[Any]:
    if kind == 'int':
        return st.sampled_from(EDGE_INTS) | st.integers()
    return st.sampled_from(EDGE_FLOATS) | st.floats(allow_nan=True, allow_infinity=True)


@st.composite
def edge_settings(draw: st.DrawFn, cls: type) -> dict[str, Any]:
    """One to three numeric fields of ``cls`` set to an edge value of their type."""
    fields = _numeric_fields(cls)
    chosen = draw(st.lists(st.sampled_from(fields), min_size=1, max_size=3,
                           unique_by=lambda f: f.name), label='fields')
    return {f.name: draw(_edge(str(f.type)), label=f.name) for f in chosen}


@pytest.mark.parametrize('cls', CLASSES, ids=lambda c: c.__name__)
def test_edge_values_give_config_error_or_valid_settings(cls: type) -> None:
    @settings(max_examples=2000 if STRESS else 150, deadline=None, derandomize=True,
              database=None)
    @given(edge_settings(cls))
    def check(values: dict[str, Any]) -> None:
        try:
            cls(**values)
        except ConfigError as exc:
            assert str(exc).strip(), 'an empty message'
            assert '\n' not in str(exc).strip(), 'one line'
    check()


@pytest.mark.parametrize('cls', CLASSES, ids=lambda c: c.__name__)
def test_each_field_alone_at_each_edge(cls: type) -> None:
    """Exhaustive over the fixed edge values: one field at a time."""
    for f in _numeric_fields(cls):
        for value in EDGE_INTS if str(f.type) == 'int' else EDGE_FLOATS:
            try:
                cls(**{f.name: value})
            except ConfigError:
                pass
            except Exception as exc:  # noqa: BLE001 - the point of the test
                pytest.fail(f'{cls.__name__}({f.name}={value!r}) raised '
                            f'{type(exc).__name__}: {exc}')


@pytest.mark.parametrize('cls', CLASSES, ids=lambda c: c.__name__)
def test_nan_is_refused_unless_it_means_not_given(cls: type) -> None:
    defaults = cls()
    for f in _numeric_fields(cls):
        if str(f.type) != 'float':
            continue
        default = getattr(defaults, f.name)
        if isinstance(default, float) and math.isnan(default):
            cls(**{f.name: math.nan})  # NaN is this field's "not given"
            continue
        with pytest.raises(ConfigError, match=f.name):
            cls(**{f.name: math.nan})


@pytest.mark.parametrize('value', ['0.0', '.nan', '-1.0'])
def test_cli_refuses_a_zero_averaging_interval_in_one_line(
        value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A zero or NaN averaging interval is one line, exit 2.

    The reported case end to end: `--config` with averaging_interval_s 0 (or NaN) was a
    ZeroDivisionError traceback; now one line naming the field, exit 2, nothing on stdout.
    """
    config = tmp_path / 'thermal.yaml'
    config.write_text(f'averaging_interval_s: {value}\n')
    out_file = tmp_path / 'h.yaml'
    assert gyro_calib(['calibrate', str(BAGS / 'thermal_calibration'), '--method', 'thermal',
                       '--config', str(config), '--out', str(out_file),
                       '--no-progress']) == 2
    out, err = capsys.readouterr()
    assert out == '' and err.count('\n') == 1 and 'averaging_interval_s' in err
    assert not out_file.exists()
