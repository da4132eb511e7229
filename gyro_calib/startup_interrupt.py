"""Ctrl-C while a command still loads its modules: one line, exit 130, no traceback.

Imports only the standard library, so a command installs it before its slow imports.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable

_INSTALLED: list[Callable[[int, object], None]] = []
"""The start-up handlers installed in this process."""


def quiet_interrupt_while_starting(command: str, script: str, nothing_done: str) -> None:
    """Until the command installs its own handler, Ctrl-C says ``nothing_done`` and exits 130.

    Only when this process is ``command`` starting (console script ``command``, ``python -m``,
    or the file ending in ``script``) and SIGINT still has Python's default handler.
    """
    start = os.path.basename(sys.argv[0]) if sys.argv else ''
    starting = start in (command, '-m') or (bool(sys.argv) and sys.argv[0].endswith(script))
    if not starting or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return

    def interrupted(signum: int, frame: object) -> None:
        sys.stderr.write(f'{command}: interrupted; {nothing_done}.\n')
        sys.stderr.flush()
        os._exit(130)  # not SystemExit: half-imported modules would raise on the way out

    _INSTALLED.append(interrupted)
    signal.signal(signal.SIGINT, interrupted)


def end_of_starting() -> None:
    """Give SIGINT back to Python's default handler if the start-up one still holds it."""
    if signal.getsignal(signal.SIGINT) in _INSTALLED:
        signal.signal(signal.SIGINT, signal.default_int_handler)
