"""``--merge-into THEIR_FILE``: the user's own config with only our keys' values replaced.

What users do by hand today (issue 36 §8): open their VINS-Fusion, FAST-LIO, LIO-SAM, Kalibr
or Autoware config and type in the noise numbers. Here their text is kept line for line —
order, other keys, comments, blank lines, OpenCV's ``%YAML:1.0`` header — and only the lines
of the keys the export writes change: the value, and the line's comment becomes ours (the
hand-off key, its SI value, the conversion). A key is found by its path below
``ros__parameters`` (or the file's root), matched at the end of the path in their file, so
``mapping.gyr_cov`` is found under ``/**: ros__parameters:`` or a ROS 1 ``laserMapping:``
alike. A key they do not have is added at the end of its parent block; a parent block they
do not have, or a key found twice, is refused in one line.

Only block mappings of scalars are merged (the formats whose keys are all scalars); the
line-based reading below is the subset of YAML those configs use.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from gyro_calib.export.source import ExportError

MERGEABLE = ('kalibr', 'vins-fusion', 'fast-lio', 'lio-sam', 'autoware')
"""Formats whose keys are all scalars (the others hold lists or matrices: use the file)."""

_KEY_LINE = re.compile(r'^(?P<indent> *)(?P<key>[^\s#:][^:#]*?|"[^"]*"|\'[^\']*\'):'
                       r'(?P<rest>(?:\s.*)?)$')


@dataclass(frozen=True, slots=True)
class _Line:
    index: int
    indent: int
    path: tuple[str, ...]
    value: str  # the scalar text, '' for a block's parent key
    comment: str


def _split_value(rest: str) -> tuple[str, str]:
    """``value  # comment`` → (value, comment); quotes protect a ``#``."""
    text = rest.strip()
    if text.startswith(('"', "'")):
        end = text.find(text[0], 1)
        if end > 0:
            value, after = text[:end + 1], text[end + 1:]
            c = after.find('#')
            return value, after[c:].strip() if c >= 0 else ''
    m = re.search(r'(^|\s)#', text)
    if m is None:
        return text, ''
    return text[:m.start()].strip(), text[m.start():].strip()


def _key_lines(text: str) -> list[_Line]:
    """Every ``key: value`` or ``key:`` line of a block-mapping text, with its full path."""
    out: list[_Line] = []
    stack: list[tuple[int, str]] = []
    for i, line in enumerate(text.split('\n')):
        if not line.strip() or line.lstrip().startswith(('#', '%', '---', '- ')):
            continue
        m = _KEY_LINE.match(line)
        if m is None:
            continue
        indent = len(m.group('indent'))
        key = m.group('key').strip().strip('"\'')
        while stack and stack[-1][0] >= indent:
            stack.pop()
        value, comment = _split_value(m.group('rest'))
        path = tuple(k for _, k in stack) + (key,)
        out.append(_Line(i, indent, path, value, comment))
        if not value:
            stack.append((indent, key))
    return out


def _tail(path: tuple[str, ...]) -> tuple[str, ...]:
    """The part of a path below ``ros__parameters`` (the whole path if there is none)."""
    return path[path.index('ros__parameters') + 1:] if 'ros__parameters' in path else path


def merge_into(theirs: str, ours: str, fmt: str, their_name: str) -> str:
    """Their text with each of our scalar keys' value (and comment) put in (module docstring).

    Raises:
        ExportError: the format holds lists or matrices, a key is in their file twice, or
            the block a missing key belongs to is not in their file (one line each).
    """
    if fmt not in MERGEABLE:
        raise ExportError(f'export --merge-into: --format {fmt} holds lists or matrices; '
                          f'merge is for {", ".join(MERGEABLE)}: use the file it writes. '
                          'Nothing was written.')
    lines = theirs.split('\n')
    theirs_keys = _key_lines(theirs)
    inserts: dict[int, list[str]] = {}
    for mine in _key_lines(ours):
        if not mine.value:
            continue
        tail = _tail(mine.path)
        hits = [t for t in theirs_keys if t.value and t.path[-len(tail):] == tail]
        new_text = f'{mine.value}  {mine.comment}'.rstrip()
        if len(hits) > 1:
            raise ExportError(f'export --merge-into: {".".join(tail)} is in {their_name} '
                              f'{len(hits)} times (lines '
                              f'{", ".join(str(h.index + 1) for h in hits)}); keep one. '
                              'Nothing was written.')
        if hits:
            h = hits[0]
            key_text = lines[h.index].split(':', 1)[0]
            lines[h.index] = f'{key_text}: {new_text}'
            continue
        parent = tail[:-1]
        if not parent and 'ros__parameters' in mine.path:
            parent = ('ros__parameters',)
        blocks = [t for t in theirs_keys if not t.value and parent
                  and t.path[-len(parent):] == parent]
        if parent and len(blocks) != 1:
            raise ExportError(f'export --merge-into: {their_name} has '
                              f'{"no" if not blocks else "more than one"} '
                              f'{".".join(parent)}: block for {".".join(tail)}; add it, or use '
                              'the fragment --out writes without --merge-into. Nothing was '
                              'written.')
        if parent:
            block = blocks[0]
            inside = [t for t in theirs_keys if t.index > block.index
                      and t.path[:len(block.path)] == block.path and t.path != block.path]
            indent = inside[0].indent if inside else block.indent + 2
            after = max([block.index] + [t.index for t in inside])
        else:
            top = [t for t in theirs_keys if t.indent == (theirs_keys[0].indent
                                                          if theirs_keys else 0)]
            indent = top[0].indent if top else 0
            after = max((t.index for t in theirs_keys), default=len(lines) - 1)
        inserts.setdefault(after, []).append(f'{" " * indent}{tail[-1]}: {new_text}')
    out: list[str] = []
    for i, line in enumerate(lines):
        out.append(line)
        out += inserts.get(i, [])
    return '\n'.join(out)
