"""Which existing files an export may replace: its own earlier export, never a user's file.

``gyro-calib export --out``, ``noise --kalibr`` and noise_node's ``kalibr_file`` write a
consumer's file; an existing one is replaced only when this tool wrote it for the same
format, and never when it is one of the records a user keeps (a bag, a hand-off file).
"""

from __future__ import annotations

from pathlib import Path

from gyro_calib.errors import ConfigError
from gyro_calib.export.names import export_mark


def refuse_to_replace_a_foreign_file(out: Path, fmt: str, flag: str, *,
                                     other_marks: tuple[str, ...] = ()) -> None:
    """An existing ``out`` is replaced only when it is this tool's file of the same format.

    Ours: its leading comment block (after an OpenCV ``%YAML:1.0`` and ``---``) carries
    :func:`~gyro_calib.export.names.export_mark` of ``fmt`` or one of ``other_marks`` (for
    Kalibr, the first line ``noise --kalibr`` writes). Any other file (a user's config,
    notes, another format's export) is kept.

    Raises:
        ConfigError: ``out`` exists and is not ours (one line; nothing written).
    """
    from gyro_calib.export.merge import MERGEABLE

    if not out.is_file():
        return
    marks = [export_mark(fmt), *other_marks]
    if any(mark in line for line in leading_comments(out) for mark in marks):
        return
    what = "Kalibr imu.yaml" if fmt == 'kalibr' else f'--format {fmt} export'
    keep = (f', or use gyro-calib export --merge-into {out} to keep its keys'
            if fmt in MERGEABLE else '')
    raise ConfigError(f'{flag} {out} exists and is not a {what} gyro-calib wrote (its first '
                      f'comment lines do not say so); it is not replaced: give a new path, '
                      f'remove it{keep}. Nothing was written.')


def leading_comments(path: Path) -> list[str]:
    """The comment lines a file starts with (after ``%YAML:1.0``, ``---`` and blanks)."""
    try:
        with path.open('rb') as f:
            head = f.read(65536).decode('utf-8', errors='replace')
    except OSError:
        return []
    out: list[str] = []
    for line in head.split('\n'):
        text = line.strip()
        if not out and (not text or text.startswith('%YAML') or text == '---'):
            continue
        if not text.startswith('#'):
            break
        out.append(text)
    return out


def refuse_to_overwrite_records(out: Path, flag: str, what_writes: str) -> None:
    """A bag file, a bag's metadata or a hand-off file is never replaced by a consumer's file.

    ``export --out`` and ``noise --kalibr`` write a consumer's file; ``out`` must not be one of
    the records the user keeps.

    Raises:
        ConfigError: ``out`` is one of those (one line; nothing written).
    """
    if not out.is_file():
        return
    what = ''
    if out.suffix.lower() in ('.mcap', '.db3'):
        what = 'a recorded bag file'
    elif out.name == 'metadata.yaml' and any(out.parent.glob('*.mcap')):
        what = "a bag's metadata"
    elif out.suffix.lower() in ('.yaml', '.yml'):
        try:
            head = out.read_text(encoding='utf-8', errors='replace')[:4096]
        except OSError:
            head = ''
        if 'format_version:' in head and ('\ngyro:' in head or '\nmethods:' in head
                                          or '\nimu:' in head):
            what = 'a gyro_calib hand-off file'
    if what:
        raise ConfigError(f'{flag} {out} is {what}; {what_writes} never replaces it: give '
                          'another file. Nothing was written.')
