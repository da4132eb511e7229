"""Output paths of every front door (``gyro-calib`` commands and the nodes): one rule each.

- **Checked before any work**: a command checks every output path it was given before it
  reads a bag (:func:`check_output_file`, :func:`check_plot_dir`, :func:`check_new_directory`),
  so a wrong path costs a one-line error, not a calibration run. Writability included: a
  temporary file (a temporary directory, for a directory still to be created) is made where
  the output will go and removed again, so a read-only directory, a read-only file system or
  a path under a regular file is refused then, not after the run.
- **Parent directories are never created** (a path whose parent is missing is refused,
  for every output): the directory an output goes into must exist. A ``--plot DIR`` (every
  command), ``report``/``batch --out DIR`` and ``calibrate --report DIR`` are themselves
  created when absent, in an existing parent; a bag (``simulate``/``compensate --out``)
  likewise.
- **``--plot`` names a directory** for every command; each method names its figures inside
  (``noise_adev.png``, ``fog_*.png``, ...). A path that is an existing file, or that ends in
  an image suffix (``fig.png``), is refused: it would otherwise become a directory.
- **Failing at write time** (disk full, a directory made read-only during the run): the
  command ends with one line naming the file and the system's reason (``gyro-calib``'s
  ``main`` turns the :class:`OSError` into it), never a traceback.
- **Files are created with the user's umask** (mode 0666 & ~umask, as ``open()`` gives); a
  file replaced keeps its mode. Every text file is written atomically: a temporary file
  beside the target, fsync, rename.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Sequence
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


def _missing_parent(p: Path, what: str) -> ConfigError | None:
    """The refusal of an output whose parent directory is absent or a file, else None."""
    parent = p.absolute().parent
    if parent.is_dir():
        return None
    if parent.exists():
        return ConfigError(f'{what} {p}: {parent} is a file, not a directory. Nothing was '
                           'read.')
    return ConfigError(f'{what} {p}: the directory {parent} does not exist (create it first; '
                       'gyro-calib does not create parent directories). Nothing was read.')


def _cannot_write(p: Path, what: str, where: Path, exc: OSError) -> ConfigError:
    reason = exc.strerror or str(exc)
    return ConfigError(f'{what} {p}: cannot write in {where} ({reason}); choose a directory '
                       'you can write in. Nothing was read.')


def probe_writable(directory: Path, what: str, path: Path, *, new_directory: bool = False) -> None:
    """Create a temporary file (``new_directory``: a directory) in ``directory``, remove it.

    Raises:
        ConfigError: it cannot be created (read-only directory or file system, no
            permission), naming ``what``, ``path`` and the system's reason.
    """
    try:
        if new_directory:
            os.rmdir(tempfile.mkdtemp(prefix='.gyro-calib-probe.', dir=directory))
        else:
            fd, name = tempfile.mkstemp(prefix='.gyro-calib-probe.', dir=directory)
            os.close(fd)
            os.unlink(name)
    except OSError as exc:
        raise _cannot_write(path, what, directory, exc) from None


def check_output_file(path: str | Path, what: str, *, follow_links: bool = False) -> Path:
    """An output file's absolute path, checked before any work (writability included).

    ``follow_links``: the writer replaces a symbolic link's target (the hand-off file), so
    the target's directory must be writable too.

    Raises:
        ConfigError: ``path`` is a directory or another non-regular file (a device, a
            pipe), its directory does not exist (it is not created) or is a file, or no file
            can be created there; naming ``what`` (e.g. ``--out``) and ``path``.
    """
    p = Path(path)
    if p.is_dir():
        raise ConfigError(f'{what} {p} is a directory; give a file name. Nothing was read.')
    if p.exists() and not p.is_file():
        raise ConfigError(f'{what} {p} is not a regular file (a device, pipe or socket); give '
                          'a file name. Nothing was read.')
    refusal = _missing_parent(p, what)
    if refusal is not None:
        raise refusal
    probe_writable(p.absolute().parent, what, p)
    if follow_links and p.is_symlink() and p.resolve().parent != p.absolute().parent:
        probe_writable(p.resolve().parent, what, p)
    return p.absolute()


def check_new_directory(path: str | Path, what: str) -> Path:
    """A directory output that must not exist yet (a bag), checked before any work.

    Raises:
        ConfigError: ``path`` exists, its parent directory does not (or is a file), or no
            directory can be created there.
    """
    p = Path(path)
    if p.exists():
        raise ConfigError(f'{what} {p}: exists already; not overwriting it. Nothing was read.')
    refusal = _missing_parent(p, what)
    if refusal is not None:
        raise refusal
    probe_writable(p.absolute().parent, what, p, new_directory=True)
    return p.absolute()


PLOT_DIR_HOLDS = 'the figures are named by method inside it'
"""What a ``--plot DIR`` holds, for the line refusing a file there."""


def check_plot_dir(path: str | Path, what: str = '--plot', holds: str = PLOT_DIR_HOLDS,
                   file_kind: str = 'a figure file', example: str = 'noise_adev.png') -> Path:
    """The figure (or other output) directory's absolute path, checked before any work.

    The figure directory's absolute path, checked before any work (created later, by
    :func:`make_plot_dir`, when the figures are drawn): a file can be created in it, or,
    when it is absent, a directory beside it. Other output directories (a certificate's,
    a batch's) pass what they hold (``holds``, ``file_kind``, ``example``) for the lines.

    Raises:
        ConfigError: ``path`` is an existing file, names a figure file (``fig.png``), its
            parent directory does not exist, or nothing can be written there.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ConfigError(f'{what} {p} is a file; {what} takes a directory ({holds}). '
                          'Nothing was read.')
    if not p.exists() and p.suffix.lower() in IMAGE_SUFFIXES:
        raise ConfigError(f'{what} {p} names {file_kind}; {what} takes a directory ({holds}, '
                          f'e.g. {example}). Nothing was read.')
    if p.is_dir():
        probe_writable(p.absolute(), what, p)
        return p.absolute()
    refusal = _missing_parent(p, what)
    if refusal is not None:
        raise refusal
    probe_writable(p.absolute().parent, what, p, new_directory=True)
    return p.absolute()


def make_plot_dir(path: Path) -> Path:
    """Create the checked figure directory (not its parents) if absent; return it."""
    path.mkdir(exist_ok=True)
    return path


def write_text_atomically(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically, as UTF-8 (:func:`write_bytes_atomically`).

    Raises:
        OSError: the file cannot be written (the target is then untouched).
    """
    return write_bytes_atomically(path, text.encode('utf-8'))


def write_bytes_atomically(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically with the mode of :func:`new_file_mode`.

    The one writer of every output file: a temporary file beside the target, written,
    flushed and fsynced, then renamed onto it (``os.replace``), so a reader sees the old
    file or the new one, never half of one. A failure (or an interrupt) removes the
    temporary file.

    Returns:
        The absolute path written.

    Raises:
        OSError: the file cannot be written (the target is then untouched), naming it.
    """
    target = Path(path).absolute()
    tmp = _staged(target, data)
    try:
        os.replace(tmp, target)
    except OSError as exc:
        _remove_quietly(tmp)
        raise with_filename(exc, target) from None
    except BaseException:
        _remove_quietly(tmp)
        raise
    return target


def write_all_or_none(documents: Sequence[tuple[Path, bytes]]) -> list[Path]:
    """Write several files that belong together: all of them, or none (issue 35 §3).

    Each is first written whole to a temporary file beside it (flushed, fsynced); only
    when every one is there are they renamed into place, in order. A failure while they
    are written (a disk that fills at the second) removes the temporaries and leaves every
    target as it was; a rename that fails (rare: no space is needed) removes the files
    this call had already put where none was.

    Returns:
        The absolute paths written.

    Raises:
        OSError: naming the file that could not be written.
    """
    targets = [Path(path).absolute() for path, _ in documents]
    staged: list[str] = []
    try:
        for target, (_, data) in zip(targets, documents, strict=True):
            staged.append(_staged(target, data))
    except BaseException:
        for tmp in staged:
            _remove_quietly(tmp)
        raise
    placed: list[Path] = []
    try:
        for target, tmp in zip(targets, staged, strict=True):
            existed = target.exists()
            try:
                os.replace(tmp, target)
            except OSError as exc:
                raise with_filename(exc, target) from None
            if not existed:
                placed.append(target)
    except BaseException:
        for tmp in staged:
            _remove_quietly(tmp)
        for target in placed:
            _remove_quietly(str(target))
        raise
    return targets


def _staged(target: Path, data: bytes) -> str:
    """``data`` written whole to a temporary file beside ``target`` (its mode, fsynced).

    Raises:
        OSError: naming ``target`` (the temporary file is then gone).
    """
    mode = new_file_mode(target)
    fd, tmp = tempfile.mkstemp(prefix=f'.{target.name}.', suffix='.tmp', dir=target.parent)
    try:
        with os.fdopen(fd, 'wb') as stream:
            stream.write(data)
            stream.flush()
            os.fchmod(stream.fileno(), mode)
            os.fsync(stream.fileno())
    except OSError as exc:
        _remove_quietly(tmp)
        raise with_filename(exc, target) from None
    except BaseException:
        _remove_quietly(tmp)
        raise
    return tmp


def _remove_quietly(path: str) -> None:
    """Remove a temporary file left by a failed write (a failure to do so is not the news)."""
    try:
        os.unlink(path)
    except OSError:
        pass


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


def os_error_text(exc: OSError) -> str:
    """``PATH: reason`` of an OS error (both paths of a rename), for a one-line message."""
    reason = exc.strerror or str(exc)
    paths = [str(f) for f in (exc.filename, exc.filename2) if f is not None]
    return f'{" → ".join(paths)}: {reason}' if paths else reason


def write_failed(exc: OSError, flag: str, path: Path | str | None,
                 written: Sequence[str] = ()) -> ConfigError:
    """The one-line error of an output that failed while being written (disk full, ...).

    Names the output (its ``flag`` and ``path``), the file when another (a figure in the
    directory), the system's reason, and what was written before it (each output is
    written whole or not at all: the one that failed was not).
    """
    done = (f'written before it: {", ".join(written)}' if written else
            'nothing was written')
    files = [str(f) for f in (exc.filename, exc.filename2)
             if f is not None and str(f) != str(path)]
    inside = f' ({" → ".join(files)})' if files else ''
    return ConfigError(f'cannot write {flag} {path}{inside}: {exc.strerror or exc}; {done}.')


def with_filename(exc: OSError, path: Path) -> OSError:
    """``exc`` naming ``path`` when it names no file (a failed ``write`` names none)."""
    if exc.filename is not None:
        return exc
    return type(exc)(exc.errno, exc.strerror or str(exc), str(path))


def write_figures(plot_dir: Path, draw: Callable[[Path], Iterable[Path]]) -> list[Path]:
    """Draw figures into ``plot_dir`` (created if absent), none of them half written.

    ``draw(directory)`` draws into a temporary directory inside ``plot_dir`` and returns
    the files; each is then renamed into ``plot_dir``. On any error (a disk that fills
    while a figure is saved) the temporary directory goes, and ``plot_dir`` too when this
    call created it and nothing is in it; the figures moved before the error stay, whole.

    Returns:
        The figures' paths in ``plot_dir``.
    """
    created = not plot_dir.exists()
    plot_dir.mkdir(exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix='.gyro-calib-figures.', dir=plot_dir))
    try:
        out = []
        for drawn in list(draw(stage)):
            target = plot_dir / drawn.relative_to(stage)
            os.replace(drawn, target)
            out.append(target)
        return out
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        if created and not any(plot_dir.iterdir()):
            plot_dir.rmdir()
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
