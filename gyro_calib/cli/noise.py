"""``gyro-calib noise``: Allan deviation, IEEE Std 952 noise terms and Kalibr ``imu.yaml``.

    gyro-calib noise BAG [BAG ...] [--topic T]
        [--scale-factor-rad-per-pulse K | --scale-factor-counts-per-rad S | --calibration FILE]
        [--config FILE] [--json] [--kalibr imu.yaml] [--plot DIR] [--out handoff.yaml]
        [--outliers keep|remove] [--outlier-sigma K] [--gyro-id ID] [--replace]
        [--progress | --no-progress]

The input is ``/gyro/pulses`` (with K), ``/fog/output`` (with counts/rad) or any
``sensor_msgs/Imu`` topic (``--topic``; without it the one input the bag holds). The bags
stream through the shared bag calibration (columnar decoding, several bags in stamp order)
into :class:`gyro_calib.noise.session.NoiseSession`.

Exit status: 0 terms measured (files written); 1 Allan deviations but no term resolved
(the curves and each term's reason were measured: ``--json`` prints them, ``--plot`` draws
them, ``--out`` gets the curves alone unless the file holds noise terms; no Kalibr file;
the last line names a ``--taus`` list too short for a fit); 2 bad input in one line — a
``--taus`` that is no grid, or that lists fewer distinct τ than a fit needs while none of
``--json``, ``--plot``, ``--out`` asks for the curves (refused before any bag is read), a
path that is not a bag, an ``--outliers`` other than keep or remove, an ``--outlier-sigma``
that is not a positive number, a topic absent or
of another type (the line lists the topics present with their types), a pulse or FOG
stream without a scale factor, a channel that is constant or all NaN, a record too short
for any term, an output path that cannot be written (checked before any work, writability
included), an existing ``--out`` file this run cannot update (empty, not a hand-off file, or
another ``--gyro-id``'s: checked after the bag, topic and scale factor, before any work),
and, once the terms are measured, an ``--out`` file of another sensor (a triad's, an IMU's,
another sample rate: one sensor per file) or holding a value more than 5 combined standard
uncertainties from this run's (the same bag under other settings included) without
``--replace``. Every change to ``--out`` is printed under its ``hand-off written:`` line
(added, replaced with the old value, kept, dropped).
On any failure no file is written or overwritten; a disk that fills while writing ends in
one line naming the output and what was written before it.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import sys
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import (
    EXIT_NOT_CALIBRATED,
    EXIT_OK,
    check_calibration_file,
    check_handoff_out,
    finite_float,
    namespace_argument,
    options_from_args,
    output_file,
    say_config_defaults,
    strict_argument,
    topic_name,
)
from gyro_calib.cli.calibrate import json_default, summary_text
from gyro_calib.cli.interrupt import Ledger
from gyro_calib.cli.progress import progress_bar

PRELOAD: tuple[str, ...] = (
    'gyro_calib.bag_calibration',
    'gyro_calib.bagio.reader',
    'gyro_calib.handoff.load',
    'gyro_calib.handoff.write',
    'gyro_calib.outputs',
    'gyro_calib.session',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(subparsers: Any) -> None:
    """Add ``noise`` to ``gyro-calib``'s subcommands."""
    p = subparsers.add_parser(
        'noise', help='noise characterisation: Allan deviation, IEEE 952 terms, Kalibr imu.yaml',
        description='Overlapping Allan deviation (IEEE Std 952/647) of a gyro or IMU and its '
        'noise terms Q, N, B, K, R by a joint weighted fit, with uncertainties.')
    p.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                   help='rosbag2 MCAP bag (directory, the .mcap file inside it, a lone .mcap '
                   'file) or a CSV/text table; several are taken together in stamp order')
    p.add_argument('--topic', type=topic_name,
                   help='the input: a sensor_msgs/Imu topic, /gyro/pulses or /fog/output '
                   '(default: the one input the bag holds)')
    scale = p.add_mutually_exclusive_group()
    scale.add_argument('--scale-factor-rad-per-pulse', type=finite_float, metavar='K',
                       help="/gyro/pulses: the RLG's scale factor, rad/pulse")
    scale.add_argument('--scale-factor-counts-per-rad', type=finite_float, metavar='S',
                       help="/fog/output: the FOG's scale factor, counts/rad")
    scale.add_argument('--calibration', type=Path, metavar='FILE',
                       help='a hand-off file to take the scale factor from '
                       '(scale_factor_rad_per_pulse or k_tilde_rad_per_pulse; '
                       'fog_scale_factor_counts_per_rad)')
    namespace_argument(p)
    strict_argument(p)
    p.add_argument('--config', type=Path, metavar='FILE',
                   help='NoiseSettings YAML (plain mapping or ROS 2 parameter file of '
                   'noise_node): taus_per_octave, overlap, fit_min_tau_s, ...')
    p.add_argument('--json', action='store_true', help='print one JSON document on stdout '
                   '(the human summary goes to stderr)')
    p.add_argument('--kalibr', type=output_file('imu.yaml'), metavar='IMU_YAML',
                   help="write Kalibr's imu.yaml (IMU input only)")
    p.add_argument('--plot', type=Path, metavar='DIR',
                   help='write the log-log ADEV figure (a panel per axis) as noise_adev.png '
                   'into DIR (created if absent, in an existing directory)')
    p.add_argument('--out', type=output_file('handoff.yaml'), metavar='HANDOFF_YAML',
                   help='write (or update) the INS hand-off file of this sensor')
    p.add_argument('--replace', action='store_true',
                   help="--out: take this run's values where they differ from the file's by "
                   'more than 5 combined standard uncertainties (a changed gyro, a wrong '
                   'setting corrected); without it such a run is refused')
    p.add_argument('--taus', metavar='GRID',
                   help="the τ grid: default (octaves and decades), octave, decade, all, or "
                   "averaging times in s, e.g. '1,10,100' (setting taus)")
    p.add_argument('--outliers', metavar='keep|remove',
                   help='spikes (median ± k·1.4826·MAD): keep the record as recorded and '
                   'report what removing them changes (default), or remove them (setting '
                   'outliers)')
    p.add_argument('--outlier-sigma', metavar='K',
                   help='k of the spike test, robust standard deviations (default 8; setting '
                   'outlier_sigma)')
    p.add_argument('--gyro-id', default='', help="the sensor's serial or name (hand-off)")
    p.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                   help='progress bar on stderr (default: when stderr is a terminal)')
    p.set_defaults(run=run_noise, method=['noise'], latitude_deg=None, heading_deg=None,
                   position_table_revolutions=None, sense_axis_elevation_deg=None,
                   sense_axis_azimuth_deg=None)


TAUS_ALL_MAX_SAMPLES = 5_000
"""The longest record ``--taus all`` takes. Every m from 1 to N/4 is one pass (and more) of
the N samples: the time grows at least as N² — 20 000 samples took 11 CPU minutes here, so
the 280 s ``noise_rlg_static`` (139 000 samples) would take hours."""
TAUS_ALL_MEASURED = (20_000, 11.0)
"""(samples, CPU minutes) of one measured ``--taus all`` run, for the cost the refusal says."""


def _refuse_a_taus_that_cannot_serve(args: argparse.Namespace) -> None:
    """A ``--taus`` that is not a grid, or that no record can fit terms on, refused at once.

    A list of fewer distinct τ than a term fit needs (:data:`MIN_FIT_POINTS`) gives no term
    on any record: refused before the bag is read, unless the run asks for the curves alone
    (``--json``, ``--plot`` or ``--out`` carry them; exit 1 then, as documented above).

    Raises:
        ConfigError: naming the list, what is wrong with it and what to give instead.
    """
    if args.taus is None:
        return
    from gyro_calib.errors import ConfigError
    from gyro_calib.noise.allan import parse_taus
    from gyro_calib.noise.run import MIN_FIT_POINTS

    try:
        spec = parse_taus(args.taus)
    except ValueError as exc:
        raise ConfigError(f'--taus: {exc}. Nothing was read.') from None
    if not isinstance(spec, tuple) or len(set(spec)) >= MIN_FIT_POINTS:
        return
    if args.json or args.plot is not None or args.out is not None:
        return  # the Allan deviation at the τ listed is what is asked for
    distinct = len(set(spec))
    raise ConfigError(
        f'--taus {args.taus} lists {distinct} distinct averaging time(s), fewer than the '
        f'{MIN_FIT_POINTS} a noise-term fit needs, so no record can give a term: list at least '
        f'{MIN_FIT_POINTS} τ or leave --taus out (the default grid); for the Allan deviation '
        'at these τ alone add --json or --plot DIR. Nothing was read.')


def _refuse_a_slow_taus_all(samples: int, topic: str) -> None:
    """``--taus all`` on a long record: its cost said, and refused before any work.

    Raises:
        ConfigError: more than :data:`TAUS_ALL_MAX_SAMPLES` samples on the input.
    """
    if samples <= TAUS_ALL_MAX_SAMPLES:
        return
    from gyro_calib.errors import ConfigError

    n, minutes = TAUS_ALL_MEASURED
    raise ConfigError(f'--taus all on {topic}\'s {samples} samples would compute every '
                      f'averaging factor m = 1 … {samples // 4}, one pass of the record each: '
                      f'the time grows at least as the square of the record ({n} samples took '
                      f'{minutes:g} CPU minutes; this one would take about '
                      f'{minutes * (samples / n) ** 2:.0f} CPU minutes or more), so at most '
                      f'{TAUS_ALL_MAX_SAMPLES} samples are taken. Give --taus default (octaves '
                      'and decades), octave, decade or a list of τ; or set taus: all in a '
                      '--config file to run it anyway. Nothing was read.')


def run_noise(args: argparse.Namespace) -> int:
    """Check the input, calibrate the bags, print, write the files asked for."""
    from gyro_calib.bag_calibration import (
        bag_infos,
        calibrate_bags,
        json_document,
        merged_topics,
        stored_benches,
        topic_counts,
    )
    from gyro_calib.bagio import topics_present
    from gyro_calib.noise.outputs import (
        resolve_targets,
        write_outputs,
        written_line,
        written_name,
    )
    from gyro_calib.noise.run import (
        holds_noise_terms,
        outlier_settings,
        refuse_scale_flag_of_another_input,
        why_no_term,
    )
    from gyro_calib.noise.session import (
        FIGURE_NAME,
        NoiseSession,
        check_scale_factor,
        input_kind,
        select_input,
    )
    from gyro_calib.outputs import check_plot_dir, make_plot_dir
    from gyro_calib.registry import handoff_schema

    _refuse_a_taus_that_cannot_serve(args)  # before any path or bag is looked at
    targets = resolve_targets(args.kalibr, None, args.out, names=('--kalibr', '--plot', '--out'))
    if targets.kalibr is not None:
        from gyro_calib.cli.export import refuse_to_replace_a_foreign_file
        from gyro_calib.export.ownership import refuse_to_overwrite_records

        refuse_to_overwrite_records(targets.kalibr, 'noise: --kalibr', "Kalibr's imu.yaml")
        refuse_to_replace_a_foreign_file(targets.kalibr, 'kalibr', 'noise: --kalibr')
    plot_dir = check_plot_dir(args.plot) if args.plot is not None else None
    check_calibration_file(args.calibration)
    infos, _ = bag_infos(args.bags, args.namespace, strict=args.strict)
    present = merged_topics(infos)
    counts = topic_counts(infos)
    where = ' + '.join(str(i.path) for i in infos)
    listing = topics_present(dataclasses.replace(
        infos[0], topics={k: dataclasses.replace(v, count=counts[k])
                          for i in infos for k, v in i.topics.items()}))
    options = options_from_args(args)
    if args.taus is not None:
        options = dataclasses.replace(options, settings={**options.settings, 'taus': args.taus})
    given = outlier_settings(args.outliers, args.outlier_sigma)
    if given:
        options = dataclasses.replace(options, settings={**options.settings, **given})
    # the input topic a bag stores (bench.topic) may come from any bag; every other stored
    # bench setting from the bags that hold the input read, never from another bag
    options = dataclasses.replace(options, topic=args.topic, scenario=next(
        (i.scenario for i in infos if i.scenario), {}), stored_benches=stored_benches(infos))
    topic = select_input({t: (m, counts.get(t, 0)) for t, m in present.items()}, options,
                         where=where, listing=listing)
    own = [i for i in infos if topic in i.topics and i.topics[topic].count > 0]
    options = dataclasses.replace(options, topic=topic, stored_benches=stored_benches(own),
                                  scenario=next((i.scenario for i in own if i.scenario), {}))
    if args.taus is not None and args.taus.strip() == 'all':
        _refuse_a_slow_taus_all(counts.get(topic, 0), topic)
    refuse_scale_flag_of_another_input(
        input_kind(topic), topic, scale_factor_rad_per_pulse=args.scale_factor_rad_per_pulse,
        scale_factor_counts_per_rad=args.scale_factor_counts_per_rad)
    check_scale_factor(options)
    if targets.kalibr is not None and input_kind(topic) != 'imu':
        from gyro_calib.errors import ConfigError

        raise ConfigError(f"--kalibr: Kalibr's imu.yaml describes an IMU; {topic} is a "
                          'single-axis gyro (use --out or --json). Nothing was read.')
    if targets.handoff is not None:  # after the bag, topic and scale-factor checks: before work
        check_handoff_out(args.out, args.gyro_id)
    say_config_defaults(args.config, ['noise'])  # a NaN / inf of the file: said, or refused

    with progress_bar(args.progress, 'noise') as progress:
        outcome = calibrate_bags(args.bags, methods=['noise'], options=options,
                                 progress=progress, namespace=args.namespace,
                                 strict=args.strict)
    session = outcome.sessions['noise']
    assert isinstance(session, NoiseSession)
    session.check_measurable()
    # the human text and the document go out only once the files are written: a command
    # that fails writing them prints one line on stderr and nothing on stdout
    human = io.StringIO()
    print(summary_text(outcome), file=human)
    document = (json.dumps(json_document(outcome, 'noise'), indent=1, allow_nan=False,
                           default=json_default) if args.json else None)
    resolved = bool(session.results())
    kept = ''
    if not resolved:  # the curves were measured: written (--out, --plot), not Kalibr's terms
        targets = dataclasses.replace(targets, kalibr=None)
        if targets.handoff is not None and holds_noise_terms(targets.handoff, handoff_schema()):
            kept = f'; {targets.handoff} keeps its noise terms (not replaced by curves alone)'
            targets = dataclasses.replace(targets, handoff=None)
    created = plot_dir is not None and not plot_dir.exists()
    if plot_dir is not None:
        targets = dataclasses.replace(targets, plot=make_plot_dir(plot_dir) / FIGURE_NAME)
    written: list[tuple[str, Path]] = []
    ledger = args.ledger if hasattr(args, 'ledger') else Ledger()  # main() gives one
    for flag, given, path, label in (('--kalibr', args.kalibr, targets.kalibr, 'Kalibr imu.yaml'),
                                     ('--plot', args.plot, targets.plot, 'figure'),
                                     ('--out', args.out, targets.handoff, 'hand-off')):
        if path is not None:
            ledger.watch(f'{flag} {given}', path, label)
    ledger.status = EXIT_OK if resolved else EXIT_NOT_CALIBRATED
    flushed, printed = False, 0
    merge: list[str] = []
    try:
        write_outputs(session, targets, source=outcome.source, schema=handoff_schema(),
                      gyro_id=args.gyro_id, progress=written, curves_only=not resolved,
                      replace=args.replace, merge_report=merge)
        for what, path in written:
            print(written_line(what, path), file=human)
            printed += 1
            if path == targets.handoff:  # every change to the file: added, replaced (new —
                for line in merge:  # was old), kept, dropped, as calibrate prints them
                    if line not in what:  # a note the written line gives already
                        print(f'  {line}', file=human)
        flushed = True  # from here on the text may be part printed: not printed again
        _flush(human, document, args.json)
    except KeyboardInterrupt:  # main() names the files written, each whole, and the others
        if not flushed:  # what was measured and written; the document once every file is
            for what, path in written[printed:]:
                print(written_line(what, path), file=human)
            _flush(human, document if ledger.complete() else None, args.json)
        raise
    except OSError as exc:
        from gyro_calib.outputs import write_failed

        named = Path(str(exc.filename or ''))
        failed = (('--kalibr', args.kalibr) if named == targets.kalibr else
                  ('--plot', args.plot) if targets.plot is not None
                  and named.parent == targets.plot.parent else ('--out', args.out))
        raise write_failed(exc, *failed, [written_name(what, path) for what, path in written]
                           ) from None
    finally:
        if created and plot_dir is not None and not any(plot_dir.iterdir()):
            plot_dir.rmdir()  # the run made it and wrote nothing into it
    if not resolved:
        print(f'gyro-calib: no noise term is resolved ({why_no_term(session, args.taus)}); '
              + (f'the curves are written ({", ".join(written_name(w, p) for w, p in written)})'
                 if written else 'nothing written')
              + kept + ('; no Kalibr file without a term' if args.kalibr is not None else '')
              + '.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    return EXIT_OK


def _flush(human: io.StringIO, document: str | None, json_asked: bool) -> None:
    """Print the human summary (stderr with ``--json``) and then the document."""
    (sys.stderr if json_asked else sys.stdout).write(human.getvalue())
    if document is not None:
        print(document)
