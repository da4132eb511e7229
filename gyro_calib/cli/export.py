"""``gyro-calib export HANDOFF --format F --out FILE`` (thin: the writers are the core).

    gyro-calib export HANDOFF --format {kalibr,openvins,gtsam,lio-sam,fast-lio,vins-fusion,
                      autoware,robot-localization} --out FILE [--rate-hz HZ]
                      [--topic TOPIC] [--stream {compensated,raw}]
                      [--raw-scale-rad-per-pulse K0] [--accel-topic TOPIC]
                      [--merge-into THEIR_FILE]

The output path is checked before the hand-off is read; on any refusal (one line, exit 2)
nothing is written and an existing FILE is left as it was. An existing FILE is replaced
(atomically, as ``noise --kalibr`` replaces its imu.yaml) only when it is an export of the
same format this tool wrote, or the --merge-into file itself; any other file is refused.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import output_file, topic_name
from gyro_calib.errors import ConfigError
from gyro_calib.export.ownership import refuse_to_overwrite_records

PRELOAD: tuple[str, ...] = (
    'gyro_calib.export.common',
    'gyro_calib.export.source',
    'gyro_calib.outputs',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not a number') from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f'{text!r} must be a positive number')
    return value


def add_commands(sub: Any) -> None:
    """Add ``export`` to the ``gyro-calib`` subcommands."""
    from gyro_calib.export.names import FORMAT_NAMES, STREAMS

    p = sub.add_parser('export', help="write the hand-off in a navigation stack's own keys "
                       'and units (Kalibr, OpenVINS, GTSAM, LIO-SAM, FAST-LIO, VINS-Fusion, '
                       'Autoware, robot_localization)')
    p.add_argument('handoff', type=Path, metavar='HANDOFF', help='the hand-off YAML file')
    p.add_argument('--format', required=True, choices=FORMAT_NAMES, help='the consumer')
    p.add_argument('--out', type=output_file('params.yaml'), required=True, metavar='FILE',
                   help='the file to write; an existing one is replaced (atomically) only '
                   'if it is an export of this --format gyro-calib wrote')
    p.add_argument('--rate-hz', type=_positive, metavar='HZ',
                   help='IMU sample rate the consumer receives (kalibr/openvins update_rate; '
                   'fast-lio, autoware, robot-localization per-sample covariances); default: '
                   'the noise run\'s sample rate, where the hand-off keeps its curves')
    p.add_argument('--topic', type=topic_name,
                   help='sensor_msgs/Imu topic the consumer subscribes to (default: the one '
                   'imu_corrector publishes for this hand-off, /gyro/imu for a single gyro, '
                   '/imu/data for a triad or IMU)')
    p.add_argument('--accel-topic', type=topic_name, metavar='TOPIC',
                   help='the IMU driver\'s sensor_msgs/Imu topic imu_corrector passes the '
                   'accelerometers from (its accel_input); consumers that need accelerometers '
                   'refuse a single-gyro or triad stream without it')
    p.add_argument('--accel-from', type=Path, metavar='IMU_HANDOFF',
                   help="take the accelerometer's noise terms from this hand-off file (a "
                   "gyro-calib noise run on the IMU driver's sensor_msgs/Imu topic, in a file "
                   "of its own: one sensor per file); the gyro's from HANDOFF")
    p.add_argument('--merge-into', type=Path, metavar='THEIR_FILE',
                   help='your own config (kalibr, vins-fusion, fast-lio, lio-sam, autoware): '
                   'written to --out with only the keys the export writes replaced (order, '
                   'other keys and comments kept); --out may be THEIR_FILE itself')
    p.add_argument('--stream', choices=STREAMS, default='compensated',
                   help='compensated (default): the consumer reads imu_corrector\'s output '
                   '(scale factor, axes, bias, thermal applied upstream); raw: the driver\'s '
                   'stream (refused where the consumer cannot represent the calibration)')
    p.add_argument('--raw-scale-rad-per-pulse', type=_positive, metavar='K0',
                   help='--stream raw, openvins, triad: the common scale factor the driver '
                   'publishes each channel with (ω_i = K0·Δn_i/Δt)')
    p.set_defaults(run=run_export)


def run_export(args: argparse.Namespace) -> int:
    """Check --out, read the hand-off, write the consumer's file; exit status."""
    from gyro_calib.export import ExportOptions, export_text
    from gyro_calib.outputs import check_output_file, write_text_atomically

    if args.raw_scale_rad_per_pulse is not None and (args.stream != 'raw'
                                                     or args.format != 'openvins'):
        raise ConfigError('export: --raw-scale-rad-per-pulse applies to --format openvins '
                          '--stream raw only; remove it. Nothing was written.')
    out = check_output_file(args.out, '--out')
    if args.handoff.absolute() == out:
        raise ConfigError('export: --out is the hand-off file itself; give another file. '
                          'Nothing was written.')
    refuse_to_overwrite_records(out, 'export: --out', 'an export')
    if args.merge_into is None or args.merge_into.absolute() != out:  # theirs: kept, merged
        refuse_to_replace_a_foreign_file(out, args.format, 'export: --out')
    options = ExportOptions(rate_hz=args.rate_hz, topic=args.topic or '', stream=args.stream,
                            raw_scale_rad_per_pulse=args.raw_scale_rad_per_pulse,
                            accel_topic=args.accel_topic or '',
                            accel_from=str(args.accel_from or ''))
    theirs = _their_text(args.merge_into) if args.merge_into is not None else None
    started_empty = theirs is not None and _their_mapping(theirs, args.merge_into) is None
    text = export_text(args.handoff, args.format, options)
    if theirs is not None:
        from gyro_calib.export.merge import merge_into

        text = merge_into(theirs, text, args.format, str(args.merge_into))
        if not isinstance(_their_mapping(text, args.merge_into), dict):
            raise ConfigError(f'export: --merge-into {args.merge_into}: the merged text is not '
                              'a YAML mapping; use the file --out writes without --merge-into '
                              'and copy its keys by hand. Nothing was written.')
    write_text_atomically(out, text)
    if started_empty:
        print(f'export: --merge-into {args.merge_into} holds no key (empty): started from '
              "nothing, the file written holds only the export's keys.", file=sys.stderr)
    print(f'wrote {out} ({args.format}).', file=sys.stderr)
    return 0


def _load_any_tags(text: str) -> Any:
    """``text`` read by PyYAML's safe loader, a tagged node (``!!opencv-matrix``) untagged.

    Raises:
        yaml.YAMLError: not YAML.
    """
    import yaml

    class AnyTagLoader(yaml.SafeLoader):
        pass

    def untagged(loader: yaml.SafeLoader, _suffix: str, node: yaml.Node) -> Any:
        if isinstance(node, yaml.MappingNode):
            return loader.construct_mapping(node)
        if isinstance(node, yaml.SequenceNode):
            return loader.construct_sequence(node)
        return loader.construct_scalar(node)  # type: ignore[arg-type]

    AnyTagLoader.add_multi_constructor('', untagged)
    return yaml.load(text, Loader=AnyTagLoader)  # noqa: S506 - a SafeLoader subclass


def _their_mapping(text: str, path: Path) -> dict[Any, Any] | None:
    """The mapping of the --merge-into text, ``None`` when it holds no key (empty, comments).

    An OpenCV ``%YAML:1.0`` first line is skipped (PyYAML rejects it; OpenCV needs it).

    Raises:
        ConfigError: the text does not parse as YAML, or is not a mapping (one line; nothing
            written).
    """
    first, _, rest = text.partition('\n')
    body = rest if first.strip().startswith('%YAML:') else text
    keep = ('give your own config file (a YAML mapping of keys), or drop --merge-into to '
            'write the export alone. Nothing was written.')
    import yaml

    try:
        data = _load_any_tags(body)
    except yaml.YAMLError as exc:
        mark = getattr(exc, 'problem_mark', None)
        where = f' (line {mark.line + 1 + (body is rest)})' if mark is not None else ''
        raise ConfigError(f'export: --merge-into {path} is not YAML{where}: '
                          f'{getattr(exc, "problem", None) or "cannot be parsed"}; '
                          + keep) from None
    if data is None:
        return None
    if not isinstance(data, dict):
        raise ConfigError(f'export: --merge-into {path} is not a YAML mapping (it holds a '
                          f'{type(data).__name__}, not keys); ' + keep)
    return data


def _their_text(path: Path) -> str:
    """The user's config for --merge-into (one-line refusal if it cannot be read)."""
    try:
        return path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ConfigError(f'export: --merge-into {path}: no such file; give your own config '
                          'file. Nothing was written.') from None
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else 'not UTF-8 text'
        raise ConfigError(f'export: --merge-into {path}: cannot be read ({why}). Nothing was '
                          'written.') from None


def refuse_to_replace_a_foreign_file(out: Path, fmt: str, flag: str) -> None:
    """An existing ``out`` is replaced only when it is this tool's file of the same format.

    :func:`gyro_calib.export.ownership.refuse_to_replace_a_foreign_file`; for Kalibr the first
    line of ``noise --kalibr`` (:data:`~gyro_calib.noise.kalibr.KALIBR_MARK`) is ours too —
    both write the same Kalibr imu.yaml.

    Raises:
        ConfigError: ``out`` exists and is not ours (one line; nothing written).
    """
    from gyro_calib.export.ownership import refuse_to_replace_a_foreign_file as refuse

    other: tuple[str, ...] = ()
    if fmt == 'kalibr':
        from gyro_calib.noise.kalibr import KALIBR_MARK

        other = (KALIBR_MARK,)
    refuse(out, fmt, flag, other_marks=other)


