"""Opening bags with rosbags, every failure turned into a named :class:`BagError`."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.bagio.errors import BagNotFoundError, CorruptBagError, NotABagError


def one_line(exc: BaseException) -> str:
    """The exception's message on one line."""
    return ' '.join(str(exc).split())


def checksum_chunks(writer: Any) -> None:
    """Make rosbags' MCAP writer add a zstd content checksum to every chunk.

    rosbags writes the MCAP chunk CRC as 0, so damaged chunk data would otherwise decode
    into wrong numbers unnoticed; its reader verifies zstd checksums. (rosbags 0.11.9:
    ``writer.storage.compressor``; other versions keep the default compressor.)
    """
    import functools
    import sys

    if sys.version_info >= (3, 14):
        from compression import zstd
    else:
        from backports import zstd
    storage = getattr(writer, 'storage', None)
    if storage is not None and getattr(storage, 'compression', '') == 'zstd':
        storage.compressor = functools.partial(
            zstd.compress, options={zstd.CompressionParameter.checksum_flag: 1})


def usable_metadata(meta: Path) -> bool:
    """True when ``meta`` is a readable rosbag2 metadata.yaml.

    True when ``meta`` is a readable rosbag2 metadata.yaml (a mapping with
    ``rosbag2_bagfile_information``).
    """
    try:
        document = yaml.safe_load(meta.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(document, dict) and isinstance(
        document.get('rosbag2_bagfile_information'), dict)


def open_lone_mcap(path: Path) -> Any:
    """Rosbags' Reader on a .mcap file without metadata.yaml.

    rosbags' Reader on a .mcap file without its bag's metadata.yaml (counts and span
    from the file's own summary).
    """
    from rosbags.rosbag2 import Reader

    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 -- rosbags raises many kinds on a damaged file
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as an MCAP file '
                              f'({type(exc).__name__}: {one_line(exc)}).') from exc
    return reader


def lone_mcap_custom_data(path: Path) -> dict[str, str]:
    """custom_data of the rosbag2 metadata record a .mcap file carries ({} if none)."""
    try:
        from mcap.reader import make_reader

        with open(path, 'rb') as f:
            for record in make_reader(f).iter_metadata():
                if record.name == 'rosbag2':
                    meta = yaml.safe_load(record.metadata.get('serialized_metadata', ''))
                    info = meta.get('rosbag2_bagfile_information', meta)
                    custom = info.get('custom_data') if isinstance(info, dict) else None
                    return dict(custom) if isinstance(custom, dict) else {}
    except Exception:  # noqa: BLE001 -- the stored scenario is optional
        return {}
    return {}


def lone_mcap_in(path: Path) -> Path | None:
    """The one .mcap file of a directory without metadata.yaml (a recording never closed).

    None when ``path`` is not such a directory (it has metadata.yaml, or not exactly one
    .mcap file).
    """
    if not path.is_dir() or (path / 'metadata.yaml').exists():
        return None
    found = sorted(path.glob('*.mcap'))
    return found[0] if len(found) == 1 and found[0].is_file() else None


def open_reader(path: Path) -> Any:
    """An opened rosbags Reader, with every failure turned into a named BagError."""
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    if not path.exists():
        raise BagNotFoundError(f'{path}: no such file or directory.')
    if path.is_file() and path.suffix == '.bag':
        raise NotABagError(f'{path}: a ROS 1 bag; convert it first with `rosbags-convert '
                           f'--src {path} --dst {path.with_suffix("")}` (installed with '
                           'rosbags), then pass the rosbag2 directory it writes.')
    if path.is_file() and path.suffix == '.mcap':
        if not usable_metadata(path.parent / 'metadata.yaml'):
            return open_lone_mcap(path)
        path = path.parent
    lone = lone_mcap_in(path)
    if lone is not None:
        return open_lone_mcap(lone)
    if not path.is_dir() or not (path / 'metadata.yaml').is_file():
        raise NotABagError(f'{path}: not a rosbag2 bag (a directory with metadata.yaml and '
                           'the .mcap file, or a lone .mcap file).')
    meta = path / 'metadata.yaml'
    try:
        document = yaml.safe_load(meta.read_text(encoding='utf-8'))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise CorruptBagError(f'{meta}: damaged or truncated, not valid YAML '
                              f'({one_line(exc)}).') from exc
    except OSError as exc:
        raise CorruptBagError(f'{meta}: cannot be read ({exc.strerror or exc}).') from exc
    if not isinstance(document, dict) or not isinstance(
            document.get('rosbag2_bagfile_information'), dict):
        what = 'the file is empty' if document is None else 'no rosbag2_bagfile_information'
        raise CorruptBagError(f'{meta}: damaged or truncated ({what}): the recording was '
                              'not closed properly; `ros2 bag reindex` rebuilds it, or pass '
                              'the .mcap file itself (read with its own summary).')
    try:
        reader = Reader(path)
        reader.open()
    except ReaderError as exc:
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as a rosbag2 '
                              f'MCAP bag ({one_line(exc)}).') from exc
    except (OSError, ValueError, KeyError, IndexError, EOFError, MemoryError, OverflowError,
            struct.error) as exc:
        raise CorruptBagError(f'{path}: damaged or truncated ({type(exc).__name__}: '
                              f'{one_line(exc)}).') from exc
    return reader
