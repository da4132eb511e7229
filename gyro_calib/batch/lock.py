"""One ``gyro-calib batch`` per output directory: an advisory ``flock`` on ``DIR/batch.lock``.

The shared :class:`gyro_calib.file_lock.FileLock`: the kernel releases the lock when the holder
ends however it ends, so a killed run leaves no lock that blocks; the file names the holder
(pid, host, start time) for the message a second run gets. A clean run removes the file, so
a file found with no holder was left by a run that died: it is taken over with one line.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from pathlib import Path
from typing import TextIO

from gyro_calib.errors import ConfigError
from gyro_calib.file_lock import FileLock, LockHeldError

LOCK_NAME = 'batch.lock'


class BatchLock:
    """The output directory of one batch run (not taken until :meth:`acquire`)."""

    def __init__(self, out_dir: Path) -> None:
        """A lock for the output directory ``out_dir``."""
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / LOCK_NAME
        self._lock = FileLock(self.path)
        self._created_dir = False

    def acquire(self, stream: TextIO | None = None) -> None:
        """Take the directory (created in its existing parent when absent).

        A lock file left by a run that died is taken over with one line on ``stream``
        (stderr by default).

        Raises:
            ConfigError: another live run holds it, or it cannot be written.
        """
        if self._lock.held:
            return
        try:
            self.out_dir.mkdir()
            self._created_dir = True
        except FileExistsError:
            pass
        except OSError as exc:
            raise ConfigError(f'--out {self.out_dir} cannot be created ({exc.strerror}): give '
                              'a directory in an existing, writable place.') from None
        started = time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())
        try:
            left = self._lock.acquire(f'pid {os.getpid()} on {socket.gethostname()}, '
                                      f'started {started}')
        except LockHeldError as exc:
            raise ConfigError(
                f'--out {self.out_dir} is being written by another gyro-calib batch '
                f'({exc.holder}): wait for it to end or give another --out.') from None
        except OSError as exc:
            self._undo_dir()
            raise ConfigError(f'--out {self.out_dir} cannot be written ({exc.strerror}): '
                              'give a writable directory.') from None
        if left:
            print(f'gyro-calib: --out {self.out_dir}: taking over the lock left by {left}, '
                  'a run that ended without releasing it.', file=stream or sys.stderr)

    def release(self) -> None:
        """Remove the lock file and let another run take the directory."""
        self._lock.release(remove=True)

    def abandon(self) -> None:
        """Release, and remove the directory too if :meth:`acquire` created it and it is empty.

        For a run refused after the lock was taken: nothing is left behind.
        """
        self.release()
        self._undo_dir()

    def _undo_dir(self) -> None:
        if self._created_dir:
            try:
                self.out_dir.rmdir()
            except OSError:
                pass
            self._created_dir = False

