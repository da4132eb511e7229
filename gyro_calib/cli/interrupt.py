"""What a command has put in place, so that Ctrl-C reports it exactly.

Every writer is atomic (a file is whole or absent), so an interrupt leaves a set of
complete files. :func:`gyro_calib.cli.main` gives each command a :class:`Ledger`
(``args.ledger``); a command records the outputs it was asked for and each one once it is
in place. On ``KeyboardInterrupt`` the ledger's :meth:`Ledger.interrupted` line names what
was written and what was not:

- nothing written: ``interrupted; nothing written.``, exit 130;
- every output asked for written: ``interrupted after every file was written (…).``,
  exit as the command would have (0 when something was measured);
- some written: ``interrupted; written: …; not written: …``, exit 130.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from gyro_calib.cli.arguments import EXIT_INTERRUPTED, EXIT_OK


@dataclass
class _Output:
    flag: str  # '--out A.yaml'
    label: str  # 'hand-off', 'figure'
    path: Path
    before: dict[Path, tuple[int, int]]
    directory: bool
    done: bool = False

    def in_place(self) -> bool:
        """A file output replaced since it was watched, a directory output finished."""
        return self.done if self.directory else dict(_key(self.path)) != self.before


KEPT_AT_INTERRUPT: list[str] = []
"""What an interrupted command leaves that is not a file output (e.g. a certificate number
reserved in a laboratory's register, unused), said in its interrupt line."""


@dataclass
class Ledger:
    """The outputs a command was asked for and, at an interrupt, the complete files written.

    A file output is written when its file was replaced since :meth:`watch` (the writers
    rename a whole file into place); a directory's files are each whole, and the directory
    complete once the command calls :meth:`finished`.
    """

    outputs: list[_Output] = field(default_factory=list)
    status: int = EXIT_OK
    """The exit status of the command once every output is in place."""

    def watch(self, flag: str, path: Path, label: str, *, directory: bool = False) -> None:
        """An output asked for (``flag`` as given): note ``path``'s state before any write."""
        before = files_in(path) if directory else dict(_key(path))
        self.outputs.append(_Output(flag, label, path, before, directory))

    def finished(self, path: Path) -> None:
        """Every file of the directory output ``path`` is in place."""
        for out in self.outputs:
            if out.path == path:
                out.done = True

    def drop(self, path: Path) -> None:
        """The output ``path`` is not to be written after all (and says why elsewhere)."""
        self.outputs = [out for out in self.outputs if out.path != path]

    def written(self) -> list[str]:
        """Each complete file written since :meth:`watch`, as ``'LABEL /abs/path'``."""
        files = []
        for out in self.outputs:
            changed = (new_files(out.path, out.before) if out.directory else
                       [out.path.resolve()] if dict(_key(out.path)) != out.before else [])
            files += [f'{out.label} {path}' for path in changed]
        return files

    def complete(self) -> bool:
        """Every output asked for is in place."""
        return all(out.in_place() for out in self.outputs)

    def interrupted(self) -> tuple[str, int]:
        """The one line for an interrupt now, and the exit status."""
        line, status = self._interrupted()
        if KEPT_AT_INTERRUPT:
            line = f'{line[:-1]}; {"; ".join(KEPT_AT_INTERRUPT)}.'
        return line, status

    def _interrupted(self) -> tuple[str, int]:
        names = ', '.join(self.written())
        if self.outputs and self.complete():
            return (f'gyro-calib: interrupted after every file was written ({names}).',
                    self.status)
        if not names:
            return 'gyro-calib: interrupted; nothing written.', EXIT_INTERRUPTED
        missing = ', '.join(out.flag for out in self.outputs if not out.in_place())
        return (f'gyro-calib: interrupted; written (complete): {names}; not written: '
                f'{missing}.', EXIT_INTERRUPTED)


def _key(path: Path) -> list[tuple[Path, tuple[int, int]]]:
    try:
        stat = path.stat()
    except OSError:
        return []
    return [(path, (stat.st_ino, stat.st_mtime_ns))]


def files_in(directory: Path | None) -> dict[Path, tuple[int, int]]:
    """Each file under ``directory`` with its (inode, mtime) — compared after an interrupt."""
    if directory is None or not directory.is_dir():
        return {}
    return {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in sorted(directory.rglob('*'))
            if p.is_file() and not any(part.startswith('.')  # a writer's temporary
                                       for part in p.relative_to(directory).parts)}


def new_files(directory: Path | None, before: dict[Path, tuple[int, int]]) -> list[Path]:
    """The files under ``directory`` put in place since ``before`` was taken."""
    return [p.resolve() for p, key in files_in(directory).items() if before.get(p) != key]
