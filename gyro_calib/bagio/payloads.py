"""Step 3 of the columnar decoder: one channel's payloads of a chunk into NumPy columns.

The CDR payloads are gathered as rows of equal length and checked against a layout
(:mod:`~gyro_calib.bagio.layouts`) derived from one of them: the encapsulation header must
be CDR little-endian (representation identifier 0x0001; anything else goes to rosbags);
the counts and string lengths (frame_id, JointState's name count and name length, array
lengths) and string terminators must be those of the layout, and the payload may end with
at most 3 bytes of padding after the last field (the bound rosbags accepts). Rows that
match are decoded by NumPy views; any other row goes to rosbags' ``deserialize_cdr`` on its
own (an error there raises :class:`~gyro_calib.bagio.errors.MessageDecodeError`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gyro_calib.bagio.chunks import _Records
from gyro_calib.bagio.errors import MessageDecodeError
from gyro_calib.bagio.layouts import _NS_PER_S, _Codec, _Layout, _NotNarrow, codec_for
from gyro_calib.bagio.messages import typestore

if TYPE_CHECKING:
    import numpy.typing as npt

MAX_LAYOUTS = 8
"""Layouts tried per payload length in one chunk before the rest goes to rosbags."""


@functools.cache
def _store() -> Any:
    """One rosbags typestore (each new one compiles its (de)serialisers again on first use)."""
    return typestore()


def _deserialize(payload: bytes, msgtype: str) -> Any:
    """The CDR deserialiser of rosbags (its typestore loads on the first message that needs it)."""
    return _store().deserialize_cdr(payload, msgtype)



class _Categories:
    """The distinct frame_ids of one topic, in order of first appearance."""

    def __init__(self) -> None:
        self.codes: dict[str, int] = {}
        self.names: list[str] = []

    def code(self, name: str) -> int:
        code = self.codes.get(name)
        if code is None:
            code = self.codes[name] = len(self.names)
            self.names.append(name)
        return code

    def code_of(self, raw: bytes) -> int:
        """The code of a frame_id's bytes, -1 when they are not UTF-8 (rosbags would fail)."""
        try:
            return self.code(raw.decode())
        except UnicodeDecodeError:
            return -1


def _distinct(chars: npt.NDArray[np.uint8]) -> tuple[npt.NDArray[np.intp], list[bytes]]:
    """Rows of equal-length strings → (code per row, distinct strings), no per-row loop."""
    n, k = chars.shape
    if k == 0 or (chars == chars[0]).all():
        return np.zeros(n, dtype=np.intp), [chars[0].tobytes()]
    keys = np.ascontiguousarray(chars).view(f'V{k}')[:, 0]
    uniq, codes = np.unique(keys, return_inverse=True)
    return codes.reshape(-1), [u.tobytes() for u in uniq]


def _utf8(raw: bytes) -> bool:
    try:
        raw.decode()
    except UnicodeDecodeError:
        return False
    return True


_Checks = tuple[tuple[int, int, int], ...]
"""(word index, mask, value): uint32 words of a payload that must equal value under mask."""


def _checks(layout: _Layout, template: bytes) -> tuple[_Checks, _Checks]:
    """Word checks for rows of a layout.

    Word checks for rows of ``layout``: of the layout alone (CDR little-endian, counts,
    string lengths, terminators), and of the layout with the strings of ``template``.

    Counts sit on 4-aligned body offsets, so on whole words of the payload; string bytes
    and terminators are masked bytes of their words; padding bytes are never checked
    (rosbags ignores them).
    """
    shape: dict[int, list[int]] = {0: [0x0000FFFF, 0x00000100]}  # identifier 0x0001 (LE)

    def add(into: dict[int, list[int]], at: int, mask: int, value: int) -> None:
        word = into.setdefault(at // 4, [0, 0])
        word[0] |= mask << 8 * (at % 4)
        word[1] |= value << 8 * (at % 4)

    for at, value in layout.words:
        add(shape, at, 0xFFFFFFFF, value)
    for at in layout.terminators:
        add(shape, at, 0xFF, 0)
    full = {j: list(mv) for j, mv in shape.items()}
    for start, stop in layout.strings:
        for at in range(start, stop):
            add(full, at, 0xFF, template[at])

    def frozen(words: dict[int, list[int]]) -> _Checks:
        return tuple((j, m, v) for j, (m, v) in sorted(words.items()))
    return frozen(shape), frozen(full)


def _match(words: npt.NDArray[np.uint32], checks: _Checks) -> npt.NDArray[np.bool_]:
    """Rows whose words pass every check (one vectorised compare per checked word)."""
    ok = np.ones(len(words), dtype=np.bool_)
    for j, mask, value in checks:
        column = words[:, j]
        ok &= (column == value) if mask == 0xFFFFFFFF else ((column & mask) == value)
    return ok


@dataclass(slots=True)
class _Piece:
    """Decoded messages of one channel in one chunk, in record-index order."""

    log_time: npt.NDArray[np.int64]
    offset: npt.NDArray[np.int64]
    stamp: npt.NDArray[np.int64]
    codes: npt.NDArray[np.int32]
    values: dict[str, npt.NDArray[np.float64]]
    fallback: int


def _decode_channel(raw: bytes, data: npt.NDArray[np.uint8], rec: _Records, msgtype: str,
                    cats: _Categories, deserialize: Callable[[bytes, str], Any],
                    where: str, topic: str = '') -> _Piece:
    """Decode one channel's messages of a chunk: fixed layouts by NumPy, others by rosbags."""
    codec = codec_for(topic, msgtype)
    n = len(rec.payload_start)
    piece = _Piece(rec.log_time, rec.offset, np.zeros(n, dtype=np.int64),
                   np.zeros(n, dtype=np.int32),
                   {name: np.full((n, w) if w > 1 else n, np.nan) for name, w in codec.values},
                   0)
    lengths = rec.payload_length
    if n and (lengths == lengths[0]).all():
        by_length = [(int(lengths[0]), np.arange(n))]
    else:
        by_length = [(int(L), np.flatnonzero(lengths == L)) for L in np.unique(lengths)]
    fallback = [_decode_rows(data, rec.payload_start[idx], length, idx, n, codec, cats, piece)
                for length, idx in by_length]
    rest = np.concatenate(fallback) if fallback else np.zeros(0, dtype=np.intp)
    for i in rest:
        start = int(rec.payload_start[i])
        try:
            msg = deserialize(raw[start:start + int(lengths[i])], msgtype)
        except Exception as exc:  # noqa: BLE001 -- rosbags raises SerdeError and others
            raise MessageDecodeError(
                f'{where}: damaged: the {msgtype} message logged at '
                f'{int(rec.log_time[i])} ns cannot be decoded by rosbags either '
                f'({type(exc).__name__}: {" ".join(str(exc).split())}).') from exc
        stamp, frame_id, values = codec.from_message(msg)
        piece.stamp[i] = stamp
        piece.codes[i] = cats.code(frame_id)
        for (name, _), value in zip(codec.values, values, strict=True):
            piece.values[name][i] = value
    piece.fallback = len(rest)
    return piece


def _decode_rows(data: npt.NDArray[np.uint8], starts: npt.NDArray[np.int64], length: int,
                 idx: npt.NDArray[np.intp], n: int, codec: _Codec, cats: _Categories,
                 piece: _Piece) -> npt.NDArray[np.intp]:
    """Decode the payloads of one length.

    Decode the payloads of one length (messages ``idx`` of the ``n`` in ``piece``);
    return the indices left to rosbags (not a fixed layout, or beyond MAX_LAYOUTS).

    Rows are gathered in whole words; a layout is taken from the first row left and
    every row is checked against it: rows with its strings too take its frame_id code,
    rows with other strings are coded by their distinct values.
    """
    rows = sliding_window_view(data, -(-length // 4) * 4)[starts]
    words = rows.view('<u4')
    todo = np.arange(len(idx))
    fallback: list[npt.NDArray[np.intp]] = []
    for _ in range(MAX_LAYOUTS):
        if not len(todo):
            break
        template = rows[todo[0], :length].tobytes()
        try:
            layout = codec.layout(template)
        except _NotNarrow:
            fallback.append(idx[todo[:1]])
            todo = todo[1:]
            continue
        shape, full = _checks(layout, template)
        whole = len(todo) == len(rows)
        sub = words if whole else words[todo]
        same = _match(sub, full)
        code = cats.code_of(template[slice(*layout.strings[0])])
        if code >= 0 and all(_utf8(template[a:b]) for a, b in layout.strings[1:]):
            every = whole and len(idx) == n and bool(same.all())
            _extract(rows if every else rows[todo[same]], layout,
                     slice(None) if every else idx[todo[same]], code, piece)
        else:
            fallback.append(idx[todo[same]])
        done = same
        like = ~same
        if like.any():
            like &= _match(sub, shape)
        if like.any():
            like_rows = rows[todo[like]]
            codes, valid = _strings(like_rows, layout, cats)
            like_idx = idx[todo[like]]
            if valid.any():
                _extract(like_rows[valid], layout, like_idx[valid], codes[valid], piece)
            fallback.append(like_idx[~valid])
            done = same | like
        todo = todo[~done]
    fallback.append(idx[todo])
    return np.concatenate(fallback)


def _strings(rows: npt.NDArray[np.uint8], layout: _Layout, cats: _Categories
             ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.bool_]]:
    """frame_id code of each row, and whether all its strings are UTF-8 (as rosbags needs)."""
    (start, stop), *others = layout.strings
    local, names = _distinct(rows[:, start:stop])
    codes = np.asarray([cats.code_of(b) for b in names], dtype=np.int32)[local]
    valid = codes >= 0
    for start, stop in others:
        local, names = _distinct(rows[:, start:stop])
        valid &= np.asarray([_utf8(b) for b in names])[local]
    return codes, valid


def _extract(rows: npt.NDArray[np.uint8], layout: _Layout,
             dest: npt.NDArray[np.intp] | slice, codes: npt.NDArray[np.int32] | int,
             piece: _Piece) -> None:
    """Stamp, frame code and float64 fields of rows of one layout.

    Stamp (int32 sec, uint32 nanosec at payload 4 and 8), frame code and float64 fields
    of rows of one layout into ``piece`` at ``dest``.
    """
    sec = rows[:, 4:8].view('<i4')[:, 0].astype(np.int64)
    piece.stamp[dest] = sec * _NS_PER_S + rows[:, 8:12].view('<u4')[:, 0]
    piece.codes[dest] = codes
    for name, at, width in layout.fields:
        if at is not None:
            column = rows[:, at:at + 8 * width].view('<f8')
            piece.values[name][dest] = column[:, 0] if width == 1 else column
