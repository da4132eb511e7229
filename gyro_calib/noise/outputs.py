"""Files of a noise run: Kalibr ``imu.yaml``, the ADEV figure, the INS hand-off file.

Shared by ``gyro-calib noise`` and ``noise_node`` (on shutdown). Everything is prepared
first — the Kalibr text, the hand-off record merged with the file already there, the
figure rendered into a temporary file beside its target — and only then put in place, each
by an atomic rename. Any error while preparing (no term to write, a hand-off file of
another gyro, a directory that does not exist) leaves every target as it was.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gyro_calib.errors import ConfigError, InsufficientDataError

if TYPE_CHECKING:
    from gyro_calib.handoff import Calibration, HandoffKey
    from gyro_calib.noise.session import NoiseSession


@dataclass(frozen=True, slots=True)
class OutputTargets:
    """Where to write (None: not asked for).

    Attributes:
        kalibr: Kalibr ``imu.yaml`` path.
        plot: the figure's path (PNG unless another extension is given).
        handoff: the INS hand-off file (merged with what other methods wrote there).
    """

    kalibr: Path | None = None
    plot: Path | None = None
    handoff: Path | None = None


OUTPUT_NAMES = ('the Kalibr file', 'the figure', 'the hand-off file')
"""How :func:`resolve_targets` names the three outputs by default (``noise_node``)."""


def resolve_targets(kalibr: str | Path | None, plot: str | Path | None,
                    handoff: str | Path | None, *,
                    names: tuple[str, str, str] = OUTPUT_NAMES) -> OutputTargets:
    """Check the output targets before any work.

    Check the targets before any work: files that can be written in existing directories,
    not directories themselves (a directory given for the figure gets ``noise_adev.png``
    inside); ``names`` names them in a refusal (``gyro-calib noise``: its flags).

    Raises:
        ConfigError: a target is a directory, or its directory does not exist or cannot be
            written in, or two targets are the same file (the Kalibr file written over the
            hand-off file).
    """
    from gyro_calib.noise.session import FIGURE_NAME
    from gyro_calib.outputs import check_output_file

    def check(path: str | Path | None, what: str, *, directory_ok: bool = False,
              follow_links: bool = False) -> Path | None:
        if path is None or str(path) == '':
            return None
        p = Path(path)
        if p.is_dir() and directory_ok:
            return (p / FIGURE_NAME).absolute()
        return check_output_file(p, what, follow_links=follow_links)

    targets = OutputTargets(check(kalibr, names[0]), check(plot, names[1], directory_ok=True),
                            check(handoff, names[2], follow_links=True))
    named = [(what, p) for what, p in zip(names, (targets.kalibr, targets.plot, targets.handoff))
             if p is not None]
    for i, (what, path) in enumerate(named):
        for other, other_path in named[i + 1:]:
            if path.resolve() == other_path.resolve():
                raise ConfigError(f'{what} and {other} are the same file {path}: one would '
                                  'overwrite the other; give each its own name (e.g. --kalibr '
                                  'imu.yaml --out handoff.yaml). Nothing was read.')
    return targets


def curves_record(session: NoiseSession, source: str, gyro_id: str = '') -> Calibration | None:
    """A hand-off record of the curves alone (no term resolved), or None without curves.

    The run's per-τ tables (``methods.noise.deviations``) with every term missing and its
    reason, as :meth:`NoiseSession.handoff` writes them beside the terms.
    """
    from gyro_calib.config import given
    from gyro_calib.handoff import Provenance, method_calibration

    span, tables = session.data_span_ns(), session.deviation_tables()
    if span is None or not tables:
        return None
    # a triad's reasons are per channel (imu.noise.<channel>.<key>), not top-level keys
    missing = session.missing() if session.kind != 'triad' else {}
    cannot = {k: v for k, v in session.not_measurable().items() if k in missing}
    return method_calibration(
        session.name, {},
        Provenance(source, span[0], span[1], {k: v for k, v in missing.items() if k not in cannot},
                   conditions={k: v for k, v in session.conditions().items() if given(v)},
                   not_measurable=cannot, deviations=tables),
        gyro_id=gyro_id)


def write_outputs(session: NoiseSession, targets: OutputTargets, *, source: str,
                  schema: Mapping[str, HandoffKey], gyro_id: str = '',
                  progress: list[tuple[str, Path]] | None = None,
                  curves_only: bool = False, replace: bool = False) -> list[tuple[str, Path]]:
    """Prepare every file asked for, then put them in place; return (what, absolute path).

    Args:
        session: a finished (flushed) or snapshot noise session.
        targets: from :func:`resolve_targets`.
        source: the provenance of the hand-off values ('live' or the bag paths).
        schema: every method's hand-off keys (the front door passes
            ``gyro_calib.registry.handoff_schema()``: a method room does not read the registry).
        gyro_id: the sensor's serial or name (hand-off identity).
        progress: filled with each file as it is put in place (so a caller interrupted
            while writing knows what was written).
        curves_only: no term was resolved: the hand-off file gets the curves alone
            (:func:`curves_record`).
        replace: take this run's terms where the file's are more precise or disagree
            (``--replace``; :func:`~gyro_calib.handoff.update_calibration`).

    Raises:
        ConfigError: Kalibr asked for a single-axis gyro.
        KalibrExportError: a Kalibr key has neither a term nor an upper bound.
        InsufficientDataError: a hand-off file asked for and no term was measured.
        HandoffError: the hand-off file there is invalid or of another gyro.
        OSError: a file cannot be written (the ones before it are in place).
    """
    from gyro_calib.handoff import SCALE_FACTOR_NOTE, load_calibration, update_calibration
    from gyro_calib.outputs import temporary_beside, with_filename, write_text_atomically

    kalibr_text = session.kalibr_text() if targets.kalibr is not None else None
    record = None
    if targets.handoff is not None:
        record = session.handoff(source, gyro_id=gyro_id)
        if record is None and curves_only:
            record = curves_record(session, source, gyro_id)
        if record is None:
            raise InsufficientDataError(f'no noise term was measured: the hand-off file '
                                        f'{targets.handoff} is not written.')
        if targets.handoff.exists():  # refuse before writing anything (other gyro, invalid)
            record.merged_into(load_calibration(targets.handoff, schema), schema,
                               replace=replace)
    figure_tmp = None
    if targets.plot is not None:
        view = session.view
        if view is None or not view.axes():
            raise ConfigError('no sample was analysed: no figure to draw.')
        from gyro_calib.noise.plots import plot_noise_figure

        figure_tmp = temporary_beside(targets.plot, targets.plot.suffix or '.png')
        try:
            plot_noise_figure(view, figure_tmp)
        except OSError as exc:  # a disk that fills: the error names the figure
            figure_tmp.unlink(missing_ok=True)
            raise with_filename(exc, targets.plot) from None
        except BaseException:
            figure_tmp.unlink(missing_ok=True)
            raise
    written: list[tuple[str, Path]] = progress if progress is not None else []
    try:
        if kalibr_text is not None and targets.kalibr is not None:
            write_text_atomically(targets.kalibr, kalibr_text)
            left = session.kalibr_left_out()
            written.append(('Kalibr imu.yaml' + (f' ({"; ".join(left)})' if left else ''),
                            targets.kalibr))
        if figure_tmp is not None and targets.plot is not None:
            os.replace(figure_tmp, targets.plot)
            figure_tmp = None
            written.append(('figure', targets.plot))
        if record is not None and targets.handoff is not None:
            report: list[str] = []
            path = update_calibration(targets.handoff, record, schema, replace=replace,
                                      report=report)
            notes = [line for line in report  # and what became of a triad's imu: section
                     if line.startswith((SCALE_FACTOR_NOTE, 'imu:'))]
            written.append(('hand-off' + (f' ({"; ".join(notes)})' if notes else ''), path))
    finally:
        if figure_tmp is not None:
            figure_tmp.unlink(missing_ok=True)
    return written


def written_name(what: str, path: Path) -> str:
    """One entry of :func:`write_outputs` as ``'hand-off PATH (its notes)'``."""
    label, sep, notes = what.partition(' (')
    return f'{label} {path}' + (f' ({notes}' if sep else '')


def written_line(what: str, path: Path) -> str:
    """One entry of :func:`write_outputs` as ``'hand-off written: PATH (its notes)'``."""
    label, sep, notes = what.partition(' (')
    return f'{label} written: {path}' + (f' ({notes}' if sep else '')
