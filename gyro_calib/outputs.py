"""Output paths of every front door (``gyro-calib`` commands and the nodes): one rule each.

- **Checked before any work**: a command checks every output path it was given before it
  reads a bag (:func:`check_output_file`, :func:`check_plot_dir`), so a wrong path costs a
  one-line error, not a calibration run.
- **Parent directories are never created**: the directory an output file goes into must
  exist. A ``--plot DIR`` (every command) is itself created when absent, in an existing
  parent; a ``--out BAG`` of ``compensate`` likewise (a bag is a directory).
- **``--plot`` names a directory** for every command; each method names its figures inside
  (``noise_adev.png``, ``fog_*.png``, ...). A path that is an existing file, or that ends in
  an image suffix (``fig.png``), is refused: it would otherwise become a directory.
- **Files are created with the user's umask** (mode 0666 & ~umask, as ``open()`` gives); a
  file replaced keeps its mode. Every text file is written atomically: a temporary file
  beside the target, fsync, rename.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from gyro_calib.errors import ConfigError

IMAGE_SUFFIXES = frozenset({'.png', '.pdf', '.svg', '.jpg', '.jpeg', '.eps', '.ps', '.tif',
                            '.tiff'})
"""Suffixes that mark a path as a figure file, refused where a directory is expected."""


def current_umask() -> int:
    """The process umask (read without changing it for longer than one call)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def new_file_mode(target: Path) -> int:
    """The mode a file written at ``target`` gets.

    The mode a file written at ``target`` gets: the mode of the file it replaces, else
    0666 & ~umask (what ``open()`` would create).
    """
    try:
        return os.stat(target).st_mode & 0o7777
    except FileNotFoundError:
        return 0o666 & ~current_umask()


def check_output_file(path: str | Path, what: str) -> Path:
    """An output file's absolute path, checked before any work.

    Raises:
        ConfigError: ``path`` is a directory, or its directory does not exist (it is not
            created), naming ``what`` (e.g. ``--out``).
    """
    p = Path(path)
    if p.is_dir():
        raise ConfigError(f'{what} {p} is a directory; give a file name. Nothing was read.')
    parent = p.absolute().parent
    if not parent.is_dir():
        raise ConfigError(f'{what} {p}: the directory {parent} does not exist (create it first; '
                          'gyro-calib does not create parent directories). Nothing was read.')
    return p.absolute()


def check_new_directory(path: str | Path, what: str) -> Path:
    """A directory output that must not exist yet (a bag), checked before any work.

    Raises:
        ConfigError: ``path`` exists, or its parent directory does not.
    """
    p = Path(path)
    if p.exists():
        raise ConfigError(f'{what} {p}: exists already; not overwriting it. Nothing was read.')
    parent = p.absolute().parent
    if not parent.is_dir():
        raise ConfigError(f'{what} {p}: the directory {parent} does not exist (create it first; '
                          'gyro-calib does not create parent directories). Nothing was read.')
    return p.absolute()


def check_plot_dir(path: str | Path, what: str = '--plot') -> Path:
    """The figure directory's absolute path, checked before any work.

    The figure directory's absolute path, checked before any work (created later, by
    :func:`make_plot_dir`, when the figures are drawn).

    Raises:
        ConfigError: ``path`` is an existing file, names a figure file (``fig.png``), or its
            parent directory does not exist.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ConfigError(f'{what} {p} is a file; {what} takes a directory (the figures are '
                          'named by method inside it). Nothing was read.')
    if not p.exists() and p.suffix.lower() in IMAGE_SUFFIXES:
        raise ConfigError(f'{what} {p} names a figure file; {what} takes a directory (the '
                          'figures are named by method inside it, e.g. noise_adev.png). '
                          'Nothing was read.')
    parent = p.absolute().parent
    if not p.exists() and not parent.is_dir():
        raise ConfigError(f'{what} {p}: the directory {parent} does not exist (create it first; '
                          'gyro-calib does not create parent directories). Nothing was read.')
    return p.absolute()


def make_plot_dir(path: Path) -> Path:
    """Create the checked figure directory (not its parents) if absent; return it."""
    path.mkdir(exist_ok=True)
    return path


def write_text_atomically(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically with the mode of :func:`new_file_mode`.

    Raises:
        OSError: the file cannot be written (the target is then untouched).
    """
    target = Path(path).absolute()
    mode = new_file_mode(target)
    fd, tmp = tempfile.mkstemp(prefix=f'.{target.name}.', suffix='.tmp', dir=target.parent)
    try:
        with os.fdopen(fd, 'w', encoding='utf-8') as f:
            f.write(text)
            f.flush()
            os.fchmod(f.fileno(), mode)
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def temporary_beside(target: Path, suffix: str = '') -> Path:
    """An empty temporary file beside ``target``.

    An empty temporary file beside ``target`` with the mode ``target`` will get (for
    writers that need a path, e.g. matplotlib); the caller renames or removes it.
    """
    fd, name = tempfile.mkstemp(prefix=f'.{target.stem}.', suffix=suffix or target.suffix,
                                dir=target.parent)
    try:
        os.fchmod(fd, new_file_mode(target))
    finally:
        os.close(fd)
    return Path(name)
