"""One certificate writer per output directory: a ``flock`` on ``DIR/.certificates.lock``.

``gyro-calib report --out DIR`` and ``calibrate --report DIR`` hold the directory from their
first look at it (is an issued certificate there?) until the certificate is in place, as
``gyro-calib batch`` holds its ``DIR/batch.lock`` (:mod:`gyro_calib.batch.lock`). A second
writer of the same directory is refused in one line before it reserves a certificate
number, so two runs at once can no more both say "certificate written" while one issued
certificate replaces the other (issue 35 §3).

The shared :class:`gyro_calib.file_lock.FileLock`: the kernel releases the lock when its
holder ends however it ends; a clean end removes the file, so a file found with no holder was
left by a run that died and is taken over with one line. The file's name starts with a dot:
it is no output (an interrupt's list of the files written leaves it out).
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

LOCK_NAME = '.certificates.lock'


class CertificateDirectoryLock:
    """The output directory of one certificate writer (not taken until :meth:`acquire`)."""

    def __init__(self, out_dir: Path, flag: str = '--out') -> None:
        """A lock for ``out_dir``, named in messages as ``flag DIR``."""
        self.out_dir = Path(out_dir)
        self.flag = flag
        self._lock = FileLock(self.out_dir / LOCK_NAME)
        self._created_dir = False

    def acquire(self, command: str, stream: TextIO | None = None) -> None:
        """Take the directory (created in its existing parent when absent).

        ``command`` ('report', 'calibrate --report') names this run to a second one. A
        lock file left by a run that died is taken over with one line on ``stream``.

        Raises:
            ConfigError: another live run holds the directory, or it cannot be written.
        """
        if self._lock.held:
            return
        try:
            self.out_dir.mkdir()
            self._created_dir = True
        except FileExistsError:
            pass
        except OSError as exc:
            raise ConfigError(f'{self.flag} {self.out_dir} cannot be created ({exc.strerror}): '
                              'give a directory in an existing, writable place.') from None
        started = time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())
        try:
            left = self._lock.acquire(f'gyro-calib {command}, pid {os.getpid()} on '
                                      f'{socket.gethostname()}, started {started}')
        except LockHeldError as exc:
            self._undo_dir()
            raise ConfigError(
                f'{self.flag} {self.out_dir} is being written by another certificate run '
                f'({exc.holder}): wait for it to end (then see whether its certificate is the '
                f'one you want) or give another {self.flag} DIR; nothing was written and no '
                'certificate number was reserved.') from None
        except OSError as exc:
            self._undo_dir()
            raise ConfigError(f'{self.flag} {self.out_dir} cannot be written ({exc.strerror}): '
                              'give a writable directory.') from None
        if left:
            print(f'gyro-calib: {self.flag} {self.out_dir}: taking over the lock left by {left}, '
                  'a run that ended without releasing it.', file=stream or sys.stderr)

    def release(self) -> None:
        """Remove the lock file and the directory if this run created it and left it empty."""
        self._lock.release(remove=True)
        self._undo_dir()

    def _undo_dir(self) -> None:
        if self._created_dir:
            try:
                self.out_dir.rmdir()
            except OSError:
                pass  # it holds the certificate (or anything else): it stays
            self._created_dir = False
