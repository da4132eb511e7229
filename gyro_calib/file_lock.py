"""One holder at a time for a file-system place: an advisory ``flock`` on a lock file.

The kernel releases the lock when its holder ends however it ends (a killed process leaves
no lock that blocks); the file names the holder, for the message a second process gets. A
holder that removes the file on release is told apart from one that died: a file found with
no live holder still names the dead one (:meth:`FileLock.acquire` returns that text).

Shared by the state directory of a live node (:class:`gyro_calib.state_record.StateLock`)
and the output directory of a fleet run (:class:`gyro_calib.batch.lock.BatchLock`). Pure
core: no ROS import.
"""

from __future__ import annotations

import os
from pathlib import Path


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
