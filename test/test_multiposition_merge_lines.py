"""A multiposition run's hand-off lines name real replacements only, in its own words.

New-user walk: the live multiposition_calibration_node logged "replaced: imu.… = v — was v
(newer run)" for every value at each write of its hand-off, changed or not, and the CLI
announced the section as "M and b of the triad". The merge took the triad's provenance for
every imu: section, so a multiposition run was never recognised as the same run. Now:

- a live node rewriting its own run (same data, same settings) says nothing per value;
- a value given exactly as the file holds it (value and uncertainty) gets no line;
- a value that changes under another run is said, old and new ("newer run");
- the section is announced as the multiposition calibration's, its run named.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import Calibration, merge_lines, update_calibration
from gyro_calib.registry import handoff_schema

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'multiposition_hand_turned'


@pytest.fixture(scope='module')
def run() -> Calibration:
    session = calibrate_bags([BAG], methods=['multiposition']).sessions['multiposition']
    record = session.handoff(str(BAG))
    assert record is not None and record.imu is not None
    return record


def lines_of(path: Path, record: Calibration) -> list[str]:
    report: list[str] = []
    update_calibration(path, record, handoff_schema(), report=report)
    return report


def with_bias(record: Calibration, bias: np.ndarray, source: str | None = None) -> Calibration:
    assert record.imu is not None
    methods = dict(record.methods)
    if source is not None:
        methods['multiposition'] = dataclasses.replace(methods['multiposition'], source=source)
    return dataclasses.replace(record, imu=dataclasses.replace(record.imu, bias_rad_s=bias),
                               methods=methods)


def test_the_first_write_announces_the_multiposition_calibration(
        run: Calibration, tmp_path: Path) -> None:
    report = lines_of(tmp_path / 'h.yaml', run)
    assert 'imu: added (K, sense axes, M and b of the multiposition calibration).' in report
    assert not any('triad' in line for line in report)


def test_rewriting_the_same_run_with_the_same_values_says_no_replacement(
        run: Calibration, tmp_path: Path) -> None:
    lines_of(tmp_path / 'h.yaml', run)
    report = lines_of(tmp_path / 'h.yaml', run)
    assert not [line for line in report if line.startswith('replaced:')], report
    assert merge_lines(report) == [line for line in report if 'replaced:' not in line]


def test_a_live_rewrite_of_its_own_run_with_new_values_logs_nothing_per_value(
        run: Calibration, tmp_path: Path) -> None:
    assert run.imu is not None and run.imu.bias_rad_s is not None
    lines_of(tmp_path / 'h.yaml', run)
    moved = with_bias(run, np.asarray(run.imu.bias_rad_s) + 1e-6)
    report = lines_of(tmp_path / 'h.yaml', moved)
    assert [line for line in report if line.startswith('replaced:')]  # in the full report …
    assert not [line for line in merge_lines(report) if 'replaced:' in line]  # … not logged


def test_another_run_changing_one_value_names_that_value_only(
        run: Calibration, tmp_path: Path) -> None:
    assert run.imu is not None and run.imu.bias_rad_s is not None
    lines_of(tmp_path / 'h.yaml', run)
    bias = np.array(run.imu.bias_rad_s, dtype=float)
    bias[1] += 1e-6
    report = merge_lines(lines_of(tmp_path / 'h.yaml', with_bias(run, bias, 'another.bag')))
    replaced = [line for line in report if line.startswith('replaced:')]
    assert len(replaced) == 1 and replaced[0].startswith('replaced: imu.bias_rad_s[y] = ')
    assert replaced[0].endswith('(newer run).')
    assert any(f'imu section (run {BAG}' in line for line in report), report
