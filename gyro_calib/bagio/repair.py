"""A whole bag from the intact records of a damaged one (``gyro-calib repair``; issue 42).

As ``mcap recover`` and ``ros2 bag reindex`` do: the .mcap file is walked record by record
(:mod:`~gyro_calib.bagio.recovery`), and every message of its intact chunks is written,
bytes unchanged, in log-time order, to a new rosbag2 bag (``metadata.yaml`` and one
zstd-chunked .mcap with summary, chunk and message indexes, statistics), so rosbags, the
``mcap`` library's reader and ``ros2 bag`` read it. The stored scenario (``custom_data``)
is carried over. Written under a temporary name and renamed when complete.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from gyro_calib.bagio.errors import BagError, CorruptBagError
from gyro_calib.bagio.messages import typestore
from gyro_calib.bagio.metadata import store_custom_data
from gyro_calib.bagio.records import BagInfo
from gyro_calib.bagio.recovery import (
    intact_messages,
    recovered_info,
    storage_file,
    survey,
)
from gyro_calib.bagio.storage import checksum_chunks
from gyro_calib.bagio.writer import publish_directory


def _type_hashes(document: dict[str, Any] | None) -> dict[str, str]:
    """Topic → type_description_hash from a bag's metadata.yaml (when it has one)."""
    info = (document or {}).get('rosbag2_bagfile_information') or {}
    out = {}
    for t in info.get('topics_with_message_count') or []:
        meta = t.get('topic_metadata') if isinstance(t, dict) else None
        if isinstance(meta, dict) and meta.get('type_description_hash'):
            out[str(meta.get('name'))] = str(meta['type_description_hash'])
    return out


def repair_bag(path: str | Path, out: str | Path) -> BagInfo:
    """Write the intact messages of the bag at ``path`` as a whole new bag at ``out``.

    Returns the damaged bag's info (``damage`` says what was lost; None when it was whole).

    Raises:
        BagError: ``out`` exists; CorruptBagError when nothing of the bag can be read (no
            intact chunk, no channel), or a message type has neither a definition rosbags
            knows nor a hash in the bag's metadata.yaml.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    path, out = Path(path), Path(out)
    if out.exists():
        raise BagError(f'{out}: exists already; not overwriting it.')
    mcap, document = storage_file(path)
    got = survey(mcap)
    if not got.chunks or not got.channels:
        why = got.tail_reason or (got.skipped[0].reason if got.skipped else 'no chunk')
        raise CorruptBagError(f'{path}: nothing to repair from: no intact chunk (at byte '
                              f'{got.tail_from or 8}: {why}).')
    info = recovered_info(path, got)
    store = typestore()
    hashes = _type_hashes(document)
    info_doc = (document or {}).get('rosbag2_bagfile_information') or {}
    custom = {str(k): str(v) for k, v in (info_doc.get('custom_data') or got.custom_data
                                          ).items()}
    tmp = out.with_name(f'.{out.name}.partial-{os.getpid()}')
    if tmp.exists():
        shutil.rmtree(tmp)
    writer = Writer(tmp, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    for key, text in custom.items():
        writer.set_custom_data(key, text)
    connections: dict[int, Any] = {}
    try:
        with writer:
            checksum_chunks(writer)
            for cid, log_ns, payload in intact_messages(got):
                con = connections.get(cid)
                if con is None:
                    con = connections[cid] = _connection(writer, got, cid, store, hashes, path)
                writer.write(con, log_ns, payload)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    (tmp / f'{tmp.name}.mcap').rename(tmp / f'{out.name}.mcap')
    meta = tmp / 'metadata.yaml'
    meta.write_text(meta.read_text().replace(f'{tmp.name}.mcap', f'{out.name}.mcap'))
    for key, text in custom.items():  # unfolded: rosbags' folding can split an escape
        store_custom_data(tmp, key, text)
    publish_directory(tmp, out)
    return info


def _connection(writer: Any, got: Any, cid: int, store: Any, hashes: dict[str, str],
                path: Path) -> Any:
    """The new bag's connection for channel ``cid`` of the damaged one."""
    topic, schema_id, encoding, _ = got.channels[cid]
    msgtype = got.msgtype(cid)
    if msgtype in store.types:
        return writer.add_connection(topic, msgtype, typestore=store,
                                     serialization_format=encoding)
    schema = got.schemas.get(schema_id)
    if schema is None or topic not in hashes:
        raise CorruptBagError(f'{path}: topic {topic} ({msgtype or "no schema"}): its type is '
                              'not one rosbags knows and the bag gives no definition and '
                              'hash for it; cannot repair it.')
    return writer.add_connection(topic, msgtype, msgdef=schema[2].decode(),
                                 rihs01=hashes[topic], serialization_format=encoding)
