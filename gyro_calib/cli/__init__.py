"""``gyro-calib``: calibrate, inspect and simulate bags offline (no ROS graph needed).

    gyro-calib calibrate BAG [BAG ...] [--method NAME ...] [--out FILE] [--json] [--plot DIR]
    gyro-calib info BAG [BAG ...] [--method NAME ...] [--json]
    gyro-calib simulate SCENARIO --out BAG [--seed N] [--duration-s S] [--sample-rate-hz HZ]
    gyro-calib methods | --version
    gyro-calib report HANDOFF [BAG ...] --out DIR [--spec SPEC]   (certificate, HTML + PDF)
    gyro-calib batch MANIFEST --out DIR [--workers N | --scheduler URL] [--spec SPEC]
    gyro-calib export HANDOFF --format F --out FILE   (a navigation stack's own keys)
    gyro-calib repair BAG --out DIR   (a whole bag from the intact part of a damaged one)

BAG is a rosbag2 directory, the .mcap file inside one or a lone .mcap file (read with its
own summary), or a CSV/text table of a static record (:mod:`gyro_calib.bagio.tables`). Every
output path is checked before any work (:mod:`gyro_calib.outputs`). Abbreviated flags are
not accepted (``--lat`` is an error, not ``--latitude-deg``). A flag that no method run
uses is refused (exit 2), naming the methods it applies to.

Without ``--method``, every method whose topics the bags hold runs (see ``gyro-calib
methods``). Several bags are taken together in stamp order.

Exit status: 0 done (at least one quantity measured; with ``--out`` the hand-off written,
listing what is still missing); 1 nothing could be calibrated; 2 bad input (path, bag, topic,
type, configuration, an output path that cannot be written), reported in one line. On any
failure no output file is written or overwritten — except an output that fails while being
written (disk full): one line then names it and what was written before it, each whole.
Ctrl-C names the files already written, each whole, and those not written (exit 130), or
says every file was written and exits as done (:mod:`gyro_calib.cli.interrupt`).

The front door, one module per subcommand (each ``add_commands(subparsers)`` and its
``run_*``): :mod:`~gyro_calib.cli.calibrate`, :mod:`~gyro_calib.cli.info`,
:mod:`~gyro_calib.cli.methods`, :mod:`~gyro_calib.cli.compensate`,
:mod:`~gyro_calib.cli.noise`, :mod:`~gyro_calib.cli.report`, :mod:`~gyro_calib.cli.batch`,
:mod:`~gyro_calib.cli.export`, :mod:`~gyro_calib.cli.simulate`,
:mod:`~gyro_calib.cli.repair`; what several share (flags,
their checks, the one-line usage-error parser) is :mod:`~gyro_calib.cli.arguments`. The
methods below them expose plain functions and data, never argparse.
"""

from __future__ import annotations

import os
import signal
import sys

from gyro_calib.startup_interrupt import end_of_starting, quiet_interrupt_while_starting

quiet_interrupt_while_starting('gyro-calib', os.path.join('gyro_calib', 'cli', '__main__.py'),
                               'nothing written')

import argparse  # noqa: E402  (after the interrupt handler: the imports below take seconds)
import importlib  # noqa: E402
from collections.abc import Sequence  # noqa: E402

from gyro_calib.cli import (  # noqa: E402
    batch,
    calibrate,
    compensate,
    export,
    info,
    methods,
    noise,
    repair,
    report,
    simulate,
)
from gyro_calib.cli.arguments import EXIT_BAD_INPUT, EXIT_INTERRUPTED, Parser  # noqa: E402
from gyro_calib.cli.calibrate import summary_text  # noqa: E402
from gyro_calib.cli.interrupt import Ledger  # noqa: E402
from gyro_calib.errors import GyroCalibError  # noqa: E402

__all__ = ['console_main', 'main', 'summary_text']

COMMANDS = (calibrate, info, methods, compensate, noise, report, batch, export, simulate,
            repair)
"""The subcommands, in the order ``gyro-calib --help`` lists them."""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gyro-calib`` console script; returns the exit status.

    A Ctrl-C before the command runs (while the modules load: those of the package, then
    the command's own, its ``PRELOAD``, once the command line is parsed — ``--help`` needs
    none of them) ends it with ``interrupted; nothing written.`` (exit 130), as one once it
    runs and has written nothing.
    """
    try:
        args = _parser().parse_args(argv)
        for module in sys.modules[args.run.__module__].PRELOAD:  # as the start-up's: on a
            importlib.import_module(module)  # Ctrl-C meanwhile, nothing was done
        args.ledger = Ledger()  # what the command writes, for the interrupt line
    except KeyboardInterrupt:
        print('gyro-calib: interrupted; nothing written.', file=sys.stderr)
        return EXIT_INTERRUPTED
    end_of_starting()  # the ledger's turn
    try:
        return int(args.run(args))
    except GyroCalibError as exc:
        print(f'gyro-calib: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # e.g. the disk filled while an output was written: one line
        from gyro_calib.outputs import os_error_text

        print(f'gyro-calib: error: {" ".join(os_error_text(exc).split())}; stopped there.',
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # every writer is atomic: name the complete files, and the rest
        line, status = args.ledger.interrupted()
        print(line, file=sys.stderr)
        return int(status)


def _parser() -> argparse.ArgumentParser:
    from gyro_calib import __version__

    parser = Parser(
        prog='gyro-calib', description='Offline optical-gyro calibration from MCAP bags.')
    parser.add_argument('--version', action='version', version=f'gyro-calib {__version__}')
    sub = parser.add_subparsers(required=True, metavar='COMMAND', parser_class=Parser)
    for command in COMMANDS:
        command.add_commands(sub)
    return parser


def console_main() -> None:
    """Console-script wrapper for setuptools.

    Once :func:`main` has returned every output is out: a Ctrl-C then is ignored. (Python
    gives SIGINT back to the default action while the interpreter shuts down, so a late
    Ctrl-C would otherwise kill a finished command with 130, silently.)
    """
    status = main()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.exit(status)
