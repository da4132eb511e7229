"""One ``gyro-calib batch`` per output directory: an advisory ``flock`` on ``DIR/batch.lock``.

As :class:`gyro_calib.state_record.StateLock`: the kernel releases the lock when the holder
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

LOCK_NAME = 'batch.lock'


class BatchLock:
    """The output directory of one batch run (not taken until :meth:`acquire`)."""

    def __init__(self, out_dir: Path) -> None:
        """A lock for the output directory ``out_dir``."""
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / LOCK_NAME
        self._fd: int | None = None
        self._created_dir = False

    def acquire(self, stream: TextIO | None = None) -> None:
        """Take the directory (created in its existing parent when absent).

        A lock file left by a run that died is taken over with one line on ``stream``
        (stderr by default).

        Raises:
            ConfigError: another live run holds it, or it cannot be written.
        """
        import fcntl

        if self._fd is not None:
            return
        try:
            self.out_dir.mkdir()
            self._created_dir = True
        except FileExistsError:
            pass
        except OSError as exc:
            raise ConfigError(f'--out {self.out_dir} cannot be created ({exc.strerror}): give '
                              'a directory in an existing, writable place.') from None
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                self._undo_dir()
                raise ConfigError(f'--out {self.out_dir} cannot be written ({exc.strerror}): '
                                  'give a writable directory.') from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = _read(fd) or 'another process'
                os.close(fd)
                raise ConfigError(
                    f'--out {self.out_dir} is being written by another gyro-calib batch '
                    f'({holder}): wait for it to end or give another --out.') from None
            try:  # the holder before us may have removed the file while we opened it
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        left = _read(fd)
        if left:
            print(f'gyro-calib: --out {self.out_dir}: taking over the lock left by {left}, '
                  'a run that ended without releasing it.', file=stream or sys.stderr)
        started = time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())
        os.ftruncate(fd, 0)
        os.pwrite(fd, f'pid {os.getpid()} on {socket.gethostname()}, started {started}\n'
                  .encode(), 0)
        self._fd = fd

    def release(self) -> None:
        """Remove the lock file and let another run take the directory."""
        if self._fd is None:
            return
        self.path.unlink(missing_ok=True)
        os.close(self._fd)
        self._fd = None

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


def _read(fd: int) -> str:
    return ' '.join(os.pread(fd, 300, 0).decode(errors='replace').split())
