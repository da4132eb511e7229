"""One holder at a time for a file-system place: an advisory ``flock`` on a lock file.

The kernel releases the lock when its holder ends however it ends (a killed process leaves
no lock that blocks); the file names the holder, for the message a second process gets. A
holder that removes the file on release is told apart from one that died: a file found with
no live holder still names the dead one (:meth:`FileLock.acquire` returns that text).

Shared by the state directory of a live node (:class:`gyro_calib.state_record.StateLock`)
and, through :class:`DirectoryLock`, the output directory of a command that writes one:
``gyro-calib batch`` (``DIR/batch.lock``), ``report`` and ``calibrate --report``
(``DIR/.certificates.lock``, drafts and issued certificates alike). Pure core: no ROS import.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from pathlib import Path
from typing import TextIO

from gyro_calib.errors import ConfigError

BATCH_LOCK = 'batch.lock'
"""The lock file of a ``gyro-calib batch`` output directory (listed among the fleet files)."""
CERTIFICATES_LOCK = '.certificates.lock'
"""The lock file of a certificate directory (``report``, ``calibrate --report``): its name
starts with a dot, it is no output (an interrupt's list of the files written leaves it out)."""


class LockHeldError(Exception):
    """Another live process holds the lock; ``holder`` is what its lock file says."""

    def __init__(self, holder: str) -> None:
        """The holder's own description (pid, host, start time), or 'another process'."""
        super().__init__(holder)
        self.holder = holder


class FileLock:
    """An exclusive, non-blocking ``flock`` on ``path`` (not taken until :meth:`acquire`)."""

    def __init__(self, path: Path) -> None:
        """A lock on the file ``path`` (created when taken)."""
        self.path = path
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        """True while this process holds the lock."""
        return self._fd is not None

    def acquire(self, holder: str) -> str:
        """Take the lock and write ``holder`` into the file; what a dead holder left there.

        Raises:
            LockHeldError: another live process holds it.
            OSError: the lock file cannot be created.
        """
        import fcntl

        if self._fd is not None:
            return ''
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                held_by = _read(fd) or 'another process'
                os.close(fd)
                raise LockHeldError(held_by) from None
            try:  # the holder before us may have removed the file while we opened it
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        left = _read(fd)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f'{holder}\n'.encode(), 0)
        self._fd = fd
        return left

    def release(self, *, remove: bool = False) -> None:
        """Let another process take the lock; ``remove`` the file first (a clean end)."""
        if self._fd is None:
            return
        if remove:
            self.path.unlink(missing_ok=True)
        os.close(self._fd)
        self._fd = None


def _read(fd: int) -> str:
    return ' '.join(os.pread(fd, 300, 0).decode(errors='replace').split())


class DirectoryLock:
    """One writer of an output directory at a time: a :class:`FileLock` on a file in it.

    ``command`` (``'batch'``, ``'report'``, ``'calibrate --report'``) names this run to a
    second one, in the lock file (``gyro-calib COMMAND, pid P on HOST, started T``); ``name``
    is the lock file's name in the directory. A second run is refused in one line naming the
    holder; a lock file left by a run that died is taken over with one line. Not taken
    until :meth:`acquire`.
    """

    def __init__(self, out_dir: Path, command: str, *, name: str, flag: str = '--out',
                 writer: str = '', wait_note: str = '', refused_note: str = '') -> None:
        """A lock on ``out_dir`` (named ``flag DIR`` in messages) for ``gyro-calib command``.

        ``writer`` names the runs this lock keeps apart in the refusal (default ``gyro-calib
        COMMAND``); ``wait_note`` follows its 'wait for it to end', ``refused_note`` its
        'nothing was written'.
        """
        self.out_dir = Path(out_dir)
        self.command = command
        self.flag = flag
        self.path = self.out_dir / name
        self.writer = writer or f'gyro-calib {command}'
        self.wait_note = wait_note
        self.refused_note = refused_note
        self._lock = FileLock(self.path)
        self._created_dir = False

    @property
    def held(self) -> bool:
        """True while this run holds the directory."""
        return self._lock.held

    def acquire(self, stream: TextIO | None = None) -> None:
        """Take the directory (created in its existing parent when absent).

        A lock file left by a run that died is taken over with one line on ``stream``
        (stderr by default).

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
            left = self._lock.acquire(f'gyro-calib {self.command}, pid {os.getpid()} on '
                                      f'{socket.gethostname()}, started {started}')
        except LockHeldError as exc:
            self._undo_dir()
            raise ConfigError(
                f'{self.flag} {self.out_dir} is being written by another {self.writer} '
                f'({exc.holder}): wait for it to end{self.wait_note} or give another '
                f'{self.flag} DIR; nothing was written{self.refused_note}.') from None
        except OSError as exc:
            self._undo_dir()
            raise ConfigError(f'{self.flag} {self.out_dir} cannot be written ({exc.strerror}): '
                              'give a writable directory.') from None
        if left:
            print(f'gyro-calib: {self.flag} {self.out_dir}: taking over the lock left by {left}, '
                  'a run that ended without releasing it.', file=stream or sys.stderr)

    def release(self) -> None:
        """Remove the lock file; remove the directory too if this run created it, still empty."""
        self._lock.release(remove=True)
        self._undo_dir()

    def _undo_dir(self) -> None:
        if self._created_dir:
            try:
                self.out_dir.rmdir()
            except OSError:
                pass  # it holds what the run wrote (or anything else): it stays
            self._created_dir = False
