"""The bag layer: rosbag2 MCAP bags and tables of the topic contract, and nothing above them.

It knows bags and message layouts only, in one direction (each module imports only those
before it): its named errors (:mod:`~gyro_calib.bagio.errors`), the message types and the
contract's topic → type table (:mod:`~gyro_calib.bagio.messages`), the scenario stored in a
bag (:mod:`~gyro_calib.bagio.metadata`), opening bags (:mod:`~gyro_calib.bagio.storage`),
the columnar MCAP decoder (its steps :mod:`~gyro_calib.bagio.layouts`,
:mod:`~gyro_calib.bagio.plan`, :mod:`~gyro_calib.bagio.chunks`,
:mod:`~gyro_calib.bagio.payloads`, and the reader :mod:`~gyro_calib.bagio.columns`), what a
bag holds and the decoded batches (:mod:`~gyro_calib.bagio.records`), what is intact of a
bag cut off or damaged (:mod:`~gyro_calib.bagio.recovery`), CSV/text tables read
wherever a bag is (:mod:`~gyro_calib.bagio.tables`), writing
(:mod:`~gyro_calib.bagio.writer`), a whole bag from a damaged one
(:mod:`~gyro_calib.bagio.repair`) and reading (:mod:`~gyro_calib.bagio.reader`). It never
imports the method registry, the sessions or the methods: the layers above hand it the
topics they want (issue 19 §5; ``test/test_layers.py`` keeps it so).

This package re-exports the public names of its modules. (The old import paths
``gyro_calib.bag``, ``gyro_calib.mcap_columns`` and ``gyro_calib.table_input`` are gone.)
"""

from gyro_calib.bagio.errors import (
    BagError,
    BagNotFoundError,
    CorruptBagError,
    EmptyBagError,
    MissingTopicError,
    NotABagError,
    WrongMessageTypeError,
)
from gyro_calib.bagio.messages import (
    CONTRACT_TYPES,
    HEADER,
    IMU,
    JOINT_STATE,
    TEMPERATURE,
    topic_sort_key,
    typestore,
)
from gyro_calib.bagio.metadata import (
    SCENARIO_KEY,
    parse_scenario_text,
    scenario_key,
    scenario_text,
    store_custom_data,
)
from gyro_calib.bagio.reader import (
    bag_info,
    check_topics,
    header_stamp_spans,
    iter_bags,
    iter_raw_messages,
    iter_sample_batches,
    topics_present,
)
from gyro_calib.bagio.records import BagInfo, Damage, SampleBatch, SkippedChunk, TopicInfo
from gyro_calib.bagio.repair import repair_bag
from gyro_calib.bagio.storage import checksum_chunks, open_reader
from gyro_calib.bagio.writer import BagMessage, ContractMessages, write_bag

__all__ = [
    'CONTRACT_TYPES', 'HEADER', 'IMU', 'JOINT_STATE', 'SCENARIO_KEY', 'TEMPERATURE',
    'BagError', 'BagInfo', 'BagMessage', 'BagNotFoundError', 'ContractMessages',
    'CorruptBagError', 'Damage', 'EmptyBagError', 'MissingTopicError', 'NotABagError',
    'SampleBatch', 'SkippedChunk', 'TopicInfo', 'WrongMessageTypeError', 'bag_info',
    'check_topics', 'checksum_chunks', 'header_stamp_spans', 'iter_bags', 'iter_raw_messages',
    'iter_sample_batches', 'open_reader', 'parse_scenario_text', 'repair_bag', 'scenario_key',
    'scenario_text', 'store_custom_data', 'topic_sort_key', 'topics_present', 'typestore',
    'write_bag',
]
