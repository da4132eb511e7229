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
(:mod:`~gyro_calib.bagio.repair`), bags given together that hold the same data
(:mod:`~gyro_calib.bagio.duplicates`) and reading (:mod:`~gyro_calib.bagio.reader`). It never
imports the method registry, the sessions or the methods: the layers above hand it the
topics they want (issue 19 §5; ``test/test_layers.py`` keeps it so).

This package re-exports the public names of its modules. (The old import paths
``gyro_calib.bag``, ``gyro_calib.mcap_columns`` and ``gyro_calib.table_input`` are gone.)
"""

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as the type checker sees them; at run time, on first use
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

_WHERE = {
    'BagError': 'gyro_calib.bagio.errors',
    'BagNotFoundError': 'gyro_calib.bagio.errors',
    'CorruptBagError': 'gyro_calib.bagio.errors',
    'EmptyBagError': 'gyro_calib.bagio.errors',
    'MissingTopicError': 'gyro_calib.bagio.errors',
    'NotABagError': 'gyro_calib.bagio.errors',
    'WrongMessageTypeError': 'gyro_calib.bagio.errors',
    'CONTRACT_TYPES': 'gyro_calib.bagio.messages',
    'HEADER': 'gyro_calib.bagio.messages',
    'IMU': 'gyro_calib.bagio.messages',
    'JOINT_STATE': 'gyro_calib.bagio.messages',
    'TEMPERATURE': 'gyro_calib.bagio.messages',
    'topic_sort_key': 'gyro_calib.bagio.messages',
    'typestore': 'gyro_calib.bagio.messages',
    'SCENARIO_KEY': 'gyro_calib.bagio.metadata',
    'parse_scenario_text': 'gyro_calib.bagio.metadata',
    'scenario_key': 'gyro_calib.bagio.metadata',
    'scenario_text': 'gyro_calib.bagio.metadata',
    'store_custom_data': 'gyro_calib.bagio.metadata',
    'bag_info': 'gyro_calib.bagio.reader',
    'check_topics': 'gyro_calib.bagio.reader',
    'header_stamp_spans': 'gyro_calib.bagio.reader',
    'iter_bags': 'gyro_calib.bagio.reader',
    'iter_raw_messages': 'gyro_calib.bagio.reader',
    'iter_sample_batches': 'gyro_calib.bagio.reader',
    'topics_present': 'gyro_calib.bagio.reader',
    'BagInfo': 'gyro_calib.bagio.records',
    'Damage': 'gyro_calib.bagio.records',
    'SampleBatch': 'gyro_calib.bagio.records',
    'SkippedChunk': 'gyro_calib.bagio.records',
    'TopicInfo': 'gyro_calib.bagio.records',
    'repair_bag': 'gyro_calib.bagio.repair',
    'checksum_chunks': 'gyro_calib.bagio.storage',
    'open_reader': 'gyro_calib.bagio.storage',
    'BagMessage': 'gyro_calib.bagio.writer',
    'ContractMessages': 'gyro_calib.bagio.writer',
    'write_bag': 'gyro_calib.bagio.writer',
}
"""Each re-exported name → the module defining it, imported on first use (:func:`__getattr__`)."""


def __getattr__(name: str) -> Any:
    """A re-exported name, its module imported on first use (PEP 562).

    ``import gyro_calib.bagio`` alone imports none of its modules: the registry reads the
    message type names (:mod:`~gyro_calib.bagio.messages`) without the reader, NumPy or
    rosbags, so ``gyro-calib --help`` loads none of them. A submodule's name
    (``bagio.reader``) imports that submodule.
    """
    from gyro_calib.lazy_names import resolve

    return resolve(__name__, _WHERE, name, globals())


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
