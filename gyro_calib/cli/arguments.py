"""What several ``gyro-calib`` subcommands share: flags, their checks, the one-line parser.

Their flags, the checks made on them before any work, and the parser that reports a
usage error in one line:

- :class:`Parser`: argparse with abbreviations off and a one-line error (exit 2);
- :func:`method_arguments`, :func:`namespace_argument`, :func:`strict_argument`,
  :func:`options_from_args`: the
  settings flags of every calibrating subcommand (calibrate, info, report) and the
  :class:`~gyro_calib.session.CalibrationOptions` they make;
- :func:`refuse_unused_flags`, :func:`check_calibration_file`: a flag no method run uses,
  a ``--calibration`` file, refused before any work;
- :func:`calibrate_arguments`, :func:`lab_arguments`, :func:`lab_and_customer`,
  :func:`check_output_dir`, :func:`load_spec_arg`: the certificate's flags (calibrate
  --report, report, batch).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from gyro_calib.errors import ConfigError
from gyro_calib.registry import METHODS, handoff_schema

if TYPE_CHECKING:
    from gyro_calib.report.lab import Lab
    from gyro_calib.report.spec import Spec
    from gyro_calib.session import CalibrationOptions

EXIT_OK, EXIT_NOT_CALIBRATED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
"""``gyro-calib``'s exit statuses: done; nothing (or not everything) calibrated; bad input
(one line on stderr); interrupted (Ctrl-C)."""


class Parser(argparse.ArgumentParser):
    """argparse with abbreviations off (``--lat`` is not silently ``--latitude-deg``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """As argparse's, with ``allow_abbrev=False`` whatever is passed."""
        kwargs['allow_abbrev'] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        """One line, as every other bad input (argparse prints its usage block), exit 2."""
        command = self.prog.removeprefix('gyro-calib').strip()
        where = f'{command}: ' if command else ''
        self.exit(EXIT_BAD_INPUT, f'gyro-calib: error: {where}{" ".join(message.split())}; '
                                  f'see {self.prog} --help.\n')


def topic_name(text: str) -> str:
    """A topic flag's argparse ``type``: a name, never empty.

    An empty ``--topic ""`` read as "not given" and the default input was used silently.
    """
    if not text.strip():
        raise argparse.ArgumentTypeError(f'{text!r} is empty: name a topic (e.g. /gyro/pulses), '
                                         'or leave the flag out for its default')
    return text


def output_file(example: str) -> Callable[[str], Path]:
    """A file output flag's argparse ``type``: a path that does not end in a separator.

    ``Path('out/')`` is ``out``: without this, ``--kalibr out/`` wrote a file named ``out``
    where the user meant a directory. A file output takes a file name (docs/howto/offline.md,
    "Outputs"; ``example`` is the name the refusal suggests); an existing directory is
    refused by :func:`gyro_calib.outputs.check_output_file`.
    """
    def file_path(text: str) -> Path:
        if text.endswith(('/', os.sep)):
            raise argparse.ArgumentTypeError(f'{text!r} ends in {text[-1]}, a directory; it '
                                             f'takes a file name (e.g. {text}{example})')
        return Path(text)

    return file_path


def finite_float(text: str) -> float:
    """A number flag's argparse ``type``: a finite float (``nan``, ``inf`` refused).

    NaN is how a node parameter says "not given": taken from a flag it would silently drop
    the setting (``--latitude-deg nan`` ran as if no latitude were given).
    """
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not a number') from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f'{text!r} is not a finite number') from None
    return value


FLAG_METHODS: dict[str, tuple[str, ...]] = {
    'latitude_deg': ('rbrlg', 'fog', 'thermal', 'triad', 'multiposition'),
    'heading_deg': ('rbrlg', 'triad'),
    'position_table_revolutions': ('rbrlg',),
    'scale_factor_rad_per_pulse': ('dither', 'thermal', 'noise'),
    'scale_factor_counts_per_rad': ('noise',),
    'calibration': ('rbrlg', 'dither', 'thermal', 'noise'),
    'sense_axis_elevation_deg': ('thermal',),
    'sense_axis_azimuth_deg': ('thermal',),
    'topic': ('noise', 'multiposition'),
}
"""Flag (argparse dest) → the methods that use it; a flag none of the methods run uses is
refused (:func:`refuse_unused_flags`). ``--config`` and ``--gyro-id`` serve every method."""


def _flag(dest: str) -> str:
    return '--' + dest.replace('_', '-')


def refuse_unused_flags(args: argparse.Namespace, methods: Sequence[str]) -> None:
    """Refuse a settings flag that none of ``methods`` uses.

    Raises:
        ConfigError: naming the flag, the methods run and the methods it applies to.
    """
    for dest, users in FLAG_METHODS.items():
        if getattr(args, dest, None) is None or any(m in users for m in methods):
            continue
        run = (f' to the method(s) run here ({", ".join(methods)})' if methods else
               ': no method runs on these bags')
        raise ConfigError(f'{_flag(dest)} does not apply{run}; it is used by '
                          f'{", ".join(users)}. Drop it, or choose the method with --method. '
                          'Nothing was read.')
    if not methods:  # the flags that serve every method serve none here
        for dest, flag in (('config', '--config'), ('gyro_id', '--gyro-id')):
            if getattr(args, dest, None):
                raise ConfigError(f'{flag} does not apply: no method runs on these bags. Drop '
                                  'it, or choose the method with --method. Nothing was read.')


def say_config_defaults(path: Path | None, methods: Sequence[str]) -> None:
    """Check ``--config`` before work; say on stderr each NaN / inf taken as its default.

    A parameter file dumped from a node holds ``.nan`` where a parameter is not given:
    taken so, with a line saying it; a non-finite number anywhere else is refused.

    Raises:
        ConfigError: the file cannot be read, or holds NaN / inf where it is not the key's
            documented default (one line naming the key).
    """
    if path is None:
        return
    from gyro_calib.config import config_file_notes

    said: list[str] = []
    for name in methods:
        method = METHODS[name]
        if method.node and method.settings:
            for line in config_file_notes(path, node_name=method.node,
                                          fields=method.settings_defaults()):
                if line not in said:
                    said.append(line)
    for line in said:
        print(f'gyro-calib: note: {line}', file=sys.stderr)


def check_calibration_file(path: Path | None) -> None:
    """Load a ``--calibration`` hand-off file before any work.

    Load a ``--calibration`` hand-off file before any work, whether or not the methods
    run use it, so a wrong file is never silently ignored.

    Raises:
        HandoffError: the file is missing, unreadable or invalid.
    """
    if path is None:
        return
    from gyro_calib.handoff import load_calibration

    load_calibration(path, handoff_schema())


def check_handoff_out(path: Path, gyro_id: str = '') -> None:
    """An ``--out`` hand-off file that this run can write or update, checked before any work.

    :func:`gyro_calib.handoff.load.check_handoff_output`, the check every front door that
    writes a hand-off file makes (the nodes' ``output_file`` and ``bench_demo --out`` too).

    Raises:
        ConfigError: the place cannot take a file, or the file is empty, not YAML, not a
            hand-off file, or (``gyro_id`` given) the hand-off file of another gyro; one line
            naming ``--out``.
    """
    from gyro_calib.handoff.load import check_handoff_output

    check_handoff_output(path, '--out', handoff_schema(), gyro_id=gyro_id)


def method_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags every calibrating subcommand shares (methods, settings, site, scale factors)."""
    parser.add_argument('--method', action='append', choices=list(METHODS), metavar='NAME',
                        help=f'run only these methods ({", ".join(METHODS)}); repeatable')
    parser.add_argument('--config', type=Path, help="the method's settings YAML (the node's "
                        'config_file: plain mapping or ROS 2 parameter file)')
    parser.add_argument('--latitude-deg', type=finite_float,
                        help='site latitude, ° (default: the bench settings stored in the '
                        'bag, else unknown: bias not separated from Earth rate)')
    parser.add_argument('--heading-deg', type=finite_float,
                        help='rbrlg: heading of the position-table base x axis, from East '
                        'towards North (0 = East, 90 = North; = 90 − an azimuth), °')
    parser.add_argument('--position-table-revolutions', type=int,
                        help='rbrlg: n, position-table revolutions each way per station')
    parser.add_argument('--scale-factor-rad-per-pulse', type=finite_float,
                        help="a pulse gyro's scale factor K, rad/pulse (dither, thermal, noise)")
    parser.add_argument('--scale-factor-counts-per-rad', type=finite_float,
                        help="a FOG's scale factor, counts/rad (noise)")
    parser.add_argument('--calibration', type=Path, metavar='FILE',
                        help='a hand-off file to take the scale factor (and gyro id) from')
    parser.add_argument('--sense-axis-elevation-deg', type=finite_float,
                        help='thermal: sense-axis elevation on the static base, ° (default 90: '
                        'vertical)')
    parser.add_argument('--sense-axis-azimuth-deg', type=finite_float,
                        help='thermal: sense-axis azimuth, from North towards East (0 = '
                        'North, 90 = East; = 90 − a heading), °')
    parser.add_argument('--topic', metavar='T', type=topic_name,
                        help='noise: the input to characterise (/gyro/pulses, /fog/output, '
                        '/imu/pulses or a sensor_msgs/Imu topic; default: the only one there); '
                        'multiposition: the sensor_msgs/Imu topic to calibrate (default '
                        '/imu/data)')
    parser.add_argument('--gyro-id', default='', help="the gyro's serial or name (hand-off)")
    namespace_argument(parser)
    strict_argument(parser)


def strict_argument(parser: argparse.ArgumentParser) -> None:
    """``--strict``: refuse a bag cut off or damaged instead of reading its intact part."""
    parser.add_argument('--strict', action='store_true',
                        help='refuse a bag that is cut off or has a damaged chunk (exit 2) '
                        'instead of reading the intact part (docs/recovery.md)')


def namespace_argument(parser: argparse.ArgumentParser) -> None:
    """``--namespace NS``: read the topics of the bench in namespace NS."""
    parser.add_argument('--namespace', metavar='NS',
                        help="read the method's topics under NS (e.g. /bench2, for a bag "
                        'recorded from several benches; default: the root, or the one '
                        'namespace the bag holds)')


def options_from_args(args: argparse.Namespace) -> CalibrationOptions:
    """The CalibrationOptions of the common flags (also used by method subcommands)."""
    from gyro_calib.session import CalibrationOptions

    return CalibrationOptions(
        latitude_deg=args.latitude_deg, heading_deg=args.heading_deg, config_file=args.config,
        position_table_revolutions=args.position_table_revolutions,
        scale_factor_rad_per_pulse=args.scale_factor_rad_per_pulse,
        scale_factor_counts_per_rad=args.scale_factor_counts_per_rad,
        calibration_file=args.calibration,
        sense_axis_elevation_deg=args.sense_axis_elevation_deg,
        sense_axis_azimuth_deg=args.sense_axis_azimuth_deg, gyro_id=args.gyro_id,
        topic=getattr(args, 'topic', None))


def lab_arguments(parser: argparse.ArgumentParser, where: str = '--out DIR') -> None:
    """``--lab`` and ``--customer``: who issues the certificate, and for whom."""
    parser.add_argument('--lab', type=Path, metavar='LAB',
                        help='the issuing laboratory (YAML: name, address, signatory, '
                        f'traceability, certificate_number); default: lab.yaml in {where}; '
                        'without one the certificate is a DRAFT')
    parser.add_argument('--customer', metavar='TEXT',
                        help='the customer the certificate names (name and contact)')


def lab_and_customer(args: argparse.Namespace, out_dir: Path, *,
                     per_gyro: bool = False) -> tuple[Lab | None, str]:
    """The issuing lab (``--lab``, else ``lab.yaml`` in ``out_dir``) and the customer.

    The customer: ``--customer``, else the lab file's. ``per_gyro`` (batch: a manifest may
    name each gyro's customer): a lab without a customer is left to the caller to refuse.

    Raises:
        ConfigError: a malformed lab file, an empty ``--customer``, or (not ``per_gyro``) a
            lab without a customer (one line).
    """
    from gyro_calib.report.lab import check_customer, find_lab

    lab = find_lab(args.lab, out_dir)
    customer = check_customer(args.customer, None if per_gyro else lab)
    return lab, customer or (lab.customer if lab is not None else '')


def calibrate_arguments(parser: argparse.ArgumentParser) -> None:
    """``--report DIR``, ``--spec`` and ``--pdf``/``--no-pdf`` for ``gyro-calib calibrate``."""
    parser.add_argument('--report', type=Path, metavar='DIR',
                        help='write the certificate (<gyro_id>.html and .pdf) into DIR')
    parser.add_argument('--spec', type=Path, metavar='SPEC',
                        help='with --report: acceptance limits and decision rule (YAML)')
    parser.add_argument('--pdf', action=argparse.BooleanOptionalAction, default=None,
                        help='with --report: write the PDF beside the HTML (default: yes)')
    lab_arguments(parser, '--report DIR')


CERTIFICATE_DIR_HOLDS = 'the certificate is written inside it as HTML and PDF'
"""What a certificate's directory (``calibrate --report``, ``report --out``) holds."""


def check_output_dir(path: Path, what: str = '--out', holds: str = CERTIFICATE_DIR_HOLDS,
                     example: str = '<gyro id>.html') -> Path:
    """The output directory, checked before any work.

    The output directory, checked before any work (the rule of :mod:`gyro_calib.outputs`:
    created when absent, in an existing parent; a file is refused, the line saying what the
    directory holds: ``holds``, e.g. ``example``).
    """
    from gyro_calib.outputs import check_plot_dir

    return check_plot_dir(path, what, holds, 'a file', example)


def load_spec_arg(path: Path | None) -> Spec | None:
    """The spec file of ``--spec`` (checked before any work), or None."""
    if path is None:
        return None
    from gyro_calib.report.spec import load_spec

    return load_spec(path)
