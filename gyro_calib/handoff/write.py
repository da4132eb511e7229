"""Writing a hand-off file: whole and atomically, or with one run merged in.

:func:`write_calibration` replaces the file atomically (the old file or the new, never a mix;
the directory fsynced after the rename); :func:`update_calibration` merges a run into the
gyro's file (created if absent) and says each change in a line.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.handoff.calibration import Calibration
from gyro_calib.handoff.layout import calibration_to_yaml_dict
from gyro_calib.handoff.load import load_calibration
from gyro_calib.handoff.merge import _merged_imu, _with_std
from gyro_calib.handoff.scale_factor import scale_factor_findings
from gyro_calib.handoff.schema import TWIN_SUFFIXES, HandoffError, HandoffKey, _numbers, _schema
from gyro_calib.outputs import write_text_atomically


def calibration_text(calibration: Calibration,
                     schema: Mapping[str, HandoffKey] | None = None) -> str:
    """The hand-off file's text: the one layout every writer uses (``--out``, nodes, batch)."""
    return ('# gyro_calib INS hand-off calibration; layout: gyro_calib/handoff/ '
            '(docs/reference/handoff.md)\n'
            + yaml.dump(dict(calibration_to_yaml_dict(calibration, schema)), Dumper=_Dumper,
                        sort_keys=False, allow_unicode=True, width=100))


def write_calibration(path: str | Path, calibration: Calibration,
                      schema: Mapping[str, HandoffKey] | None = None) -> Path:
    """Write ``calibration`` to ``path`` atomically: the old file or the new, never a mix.

    A temporary file in the same directory is written, flushed and fsynced, renamed onto
    the target by ``os.replace`` (:func:`gyro_calib.outputs.write_text_atomically`, the one
    output writer) and the directory is fsynced. The file keeps the mode of
    the file it replaces (new files: 0666 & ~umask, :mod:`gyro_calib.outputs`). Symbolic
    links are followed: the link's target is replaced.

    Returns:
        The absolute path written.

    Raises:
        HandoffError: naming the path and the OS reason, if any step fails; no temporary
            file is left behind and an existing file is untouched (unless only the final
            directory fsync failed, as the message then says).
    """
    target = Path(path).resolve()
    try:
        write_text_atomically(target, calibration_text(calibration, schema))
    except OSError as exc:
        raise HandoffError(f'cannot write calibration file {target}: '
                           f'{exc.strerror or exc}.') from None
    try:
        _fsync_directory(target.parent)
    except OSError as exc:
        raise HandoffError(f'calibration file {target} was written but its directory could '
                           f'not be synced, so it may not survive a power loss: '
                           f'{exc.strerror or exc}.') from None
    return target


class _Dumper(yaml.SafeDumper):
    """The safe dumper, with a list of numbers on one line (a deviation table per τ)."""


def _represent_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flow = bool(data) and all(v is None or (_numbers(v) and not isinstance(v, bool))
                              for v in data)
    return dumper.represent_sequence('tag:yaml.org,2002:seq', data, flow_style=flow)


_Dumper.add_representer(list, _represent_list)


def update_calibration(path: str | Path, calibration: Calibration,
                       schema: Mapping[str, HandoffKey] | None = None, *,
                       replace: bool = False, report: list[str] | None = None) -> Path:
    """Merge one run's calibration into the gyro's file.

    Merge ``calibration`` (one run) into the gyro's file at ``path`` (created if absent),
    atomically, key by key (:meth:`Calibration.merged_into`): nothing measured is lost
    without a line in ``report`` saying so.

    Raises:
        HandoffError: the existing file is unreadable or invalid (it is left untouched: fix or
            move it), it belongs to another gyro, a value disagrees with the file's (without
            ``replace``), the result would be inconsistent, or the write fails.
    """
    sch = _schema(schema)
    target = Path(path)
    lines: list[str] = []
    if target.exists():
        calibration = calibration.merged_into(load_calibration(target, sch), sch,
                                              replace=replace, report=lines)
    else:
        findings = scale_factor_findings(calibration, sch, new_methods=calibration.methods)
        if findings.problem:
            raise HandoffError(findings.problem)
        lines += [f'added: {k} = {_with_std(v, calibration.values.get(k + "_std"))}.'
                  for k, v in calibration.values.items() if not k.endswith(TWIN_SUFFIXES)]
        if calibration.imu is not None:
            _merged_imu(calibration, Calibration({}, {}), lines)
        lines += findings.notes
    written = write_calibration(target, calibration, sch)
    if report is not None:
        report.extend(lines)
    return written


def _fsync_directory(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY | getattr(os, 'O_DIRECTORY', 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
