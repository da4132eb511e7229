"""Specification of the parameter command lines the demo, tests and benchmarks give nodes.

rcl parses every ``-p name:=value`` value as YAML; what we pass must read back as the value
and type we meant.
"""

from __future__ import annotations

import pytest
import yaml

from gyro_calib.nodes.processes import ros_args


def _value_as_rcl_reads_it(args: list[str]) -> object:
    assert args[:2] == ['--ros-args', '-p']
    _, _, text = args[2].partition(':=')
    return yaml.safe_load(text)


@pytest.mark.parametrize('value', ['', 'true', 'no', '1.5', '42', 'a: b', "it's", '[1, 2]',
                                   'gyro_calibration.yaml', '/tmp/x y/calib.yaml', '~'])
def test_a_string_parameter_reads_back_as_the_same_string(value: str) -> None:
    assert _value_as_rcl_reads_it(ros_args({'output_file': value})) == value


def test_an_empty_string_is_passed_quoted_because_rcl_rejects_an_empty_override() -> None:
    assert ros_args({'output_file': ''}) == ['--ros-args', '-p', "output_file:=''"]


def test_a_plain_string_is_passed_as_it_is() -> None:
    assert ros_args({'bag': '/tmp/bags/k_tilde_bench'}) == [
        '--ros-args', '-p', 'bag:=/tmp/bags/k_tilde_bench']


@pytest.mark.parametrize('value', [1e-05, 2.0, 0.5, 1e20, -3.25])
def test_a_float_parameter_stays_a_float(value: float) -> None:
    got = _value_as_rcl_reads_it(ros_args({'x': value}))
    assert isinstance(got, float) and got == value


@pytest.mark.parametrize('value', [True, False])
def test_a_bool_parameter_stays_a_bool(value: bool) -> None:
    assert _value_as_rcl_reads_it(ros_args({'clock': value})) is value


def test_an_int_parameter_stays_an_int() -> None:
    got = _value_as_rcl_reads_it(ros_args({'seed': 7}))
    assert isinstance(got, int) and got == 7
