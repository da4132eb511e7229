"""``gyro-calib`` on bad input: one line on stderr, exit status 2, no output file touched.

The rule (gyro_calib/cli.py, "Exit status"): whatever is wrong with the input, the
offline command

* prints exactly ONE line on stderr, starting ``gyro-calib: error:``, that names the
  problem (the missing path, "not a rosbag2 bag", "truncated"/"damaged", the missing
  topic, the wrong message type, "no message"...) -- never a traceback;
* returns exit status 2 (bad input);
* writes no output file, and an output file that existed before is left byte for byte
  as it was (no temporary file left beside it either).

Bad inputs: a path that does not exist; a directory (or a plain file) that is not a
bag; the committed bag ``bags/k_tilde_bench`` with its .mcap cut in the middle, with
garbage written over the middle of a chunk's compressed data, or with a damaged
``metadata.yaml``; small synthetic bags that lack a required topic, record a contract
topic with another message type, or hold no message at all.

``gyro-calib calibrate BAG --out OUT.yaml`` and ``gyro-calib info BAG`` are checked on
every bad input; ``gyro-calib simulate`` on an unknown scenario and on an ``--out``
that exists already. ``main`` is called in-process; output is captured with capsys.
"""

from __future__ import annotations

import functools
import random
import re
import shutil
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from gyro_calib import topics
from gyro_calib.bagio import (
    CONTRACT_TYPES,
    HEADER,
    JOINT_STATE,
    BagMessage,
    ContractMessages,
    write_bag,
)
from gyro_calib.cli import main

COMMITTED_BAG = Path(__file__).resolve().parents[1] / 'bags' / 'k_tilde_bench'
EXIT_BAD_INPUT = 2
ERROR_PREFIX = 'gyro-calib: error:'
FLOAT64 = 'std_msgs/msg/Float64'
PREVIOUS_HANDOFF = (b'# gyro_calib INS hand-off calibration written by an earlier run\n'
                    b'k_tilde_arcsec_per_pulse: 0.8427948\n')
"""Content of an OUT.yaml that exists before the failing run and must survive it."""

CONTRACT_INPUTS = (topics.GYRO_PULSES, topics.RATE_TABLE_JOINT_STATES,
                   topics.RATE_TABLE_ZERO_INDEX)
"""The topics a bag must hold to be calibrated."""


# -- running the command ---------------------------------------------------------------------
@dataclass(frozen=True)
class Run:
    """What one ``gyro-calib`` invocation did."""

    code: int
    out: str
    err: str


def gyro_calib(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> Run:
    """``gyro-calib ARGV...`` in-process; an escaping exception is a failure of the rule."""
    capsys.readouterr()  # drop anything captured before
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors
        code = exc.code if isinstance(exc.code, int) else 1
    except Exception as exc:  # noqa: BLE001 -- a traceback is exactly what must not happen
        captured = capsys.readouterr()
        pytest.fail(f'gyro-calib {" ".join(map(str, argv))} raised {type(exc).__name__}: {exc}'
                    f' instead of printing one error line (stderr so far: {captured.err!r})')
    captured = capsys.readouterr()
    return Run(code, captured.out, captured.err)


def the_one_error_line(run: Run) -> str:
    """The single stderr line of a failed run (asserting that there is exactly one)."""
    lines = run.err.splitlines()
    assert len(lines) == 1, (f'stderr must be exactly one line, got {len(lines)}:\n'
                             f'{run.err}')
    line = lines[0]
    assert line.startswith(ERROR_PREFIX), f'stderr line must start with {ERROR_PREFIX!r}: {line!r}'
    return line


def assert_names(line: str, patterns: Sequence[str], path: Path | None = None) -> None:
    """Every regex of ``patterns`` occurs in ``line`` outside ``path``.

    Every regex of ``patterns`` occurs in ``line`` (case-insensitive) -- outside the
    text of ``path``, which the line must name, so that a directory called "truncated"
    cannot pass for the word.
    """
    problem = line
    if path is not None:
        assert str(path) in line, f'the error line should name the path {path}: {line!r}'
        problem = line.replace(str(path), '<PATH>')
    for pattern in patterns:
        assert re.search(pattern, problem, re.IGNORECASE), (
            f'the error line should match {pattern!r} to name the problem: {line!r}')


def listing(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


# -- bad inputs ------------------------------------------------------------------------------
@functools.cache
def _contract_messages() -> ContractMessages:
    return ContractMessages()  # one typestore for the module


def _cdr(msgtype: str, t_ns: int, label: str) -> bytes:
    """CDR bytes of a message of ``msgtype`` stamped ``t_ns``."""
    messages = _contract_messages()
    if msgtype == JOINT_STATE:
        return messages.joint_state(t_ns, label, position=t_ns * 1e-6, velocity=1.0)
    if msgtype == HEADER:
        return messages.header(t_ns, label)
    if msgtype == FLOAT64:
        store = messages.store
        return bytes(store.serialize_cdr(store.types[FLOAT64](data=t_ns * 1e-9), FLOAT64))
    raise AssertionError(f'no CDR recipe for {msgtype}')


def synthetic_bag(path: Path, present: Sequence[str],
                  types: dict[str, str] | None = None, samples: int = 50) -> Path:
    """A small bag with ``samples`` messages on each topic of ``present``.

    A small bag with ``samples`` messages (1 kHz) on each topic of ``present``;
    ``types`` overrides the contract type of a topic (the bytes follow the type).
    """
    types = types or {}
    msgs = [BagMessage(topic, t_ns, _cdr(types.get(topic, CONTRACT_TYPES[topic]), t_ns,
                                         topic.strip('/').split('/')[0]))
            for t_ns in range(1_000_000_000, 1_000_000_000 + samples * 1_000_000, 1_000_000)
            for topic in present]
    write_bag(path, msgs, types=types)
    return path


def committed_bag_copy(path: Path) -> Path:
    """A private copy of bags/k_tilde_bench (metadata.yaml + k_tilde_bench.mcap)."""
    shutil.copytree(COMMITTED_BAG, path)
    return path


def _mcap(bag: Path) -> Path:
    (mcap,) = bag.glob('*.mcap')
    return mcap


def chunk_data_spans(mcap: Path) -> list[tuple[int, int]]:
    """(offset, length) of the compressed records of every Chunk record of an MCAP file."""
    data = mcap.read_bytes()
    assert data[:8] == b'\x89MCAP0\r\n', f'{mcap} is not an MCAP file'
    spans, pos = [], 8
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from('<BQ', data, pos)
        body = pos + 9
        if opcode == 0x06:  # Chunk: start, end, uncompressed size, crc, compression, records
            (compression_len,) = struct.unpack_from('<I', data, body + 28)
            records_at = body + 32 + compression_len
            (records_len,) = struct.unpack_from('<Q', data, records_at)
            spans.append((records_at + 8, records_len))
        elif opcode == 0x0F:  # DataEnd: the summary follows
            break
        pos = body + length
    assert spans, f'{mcap} has no chunk'
    return spans


def overwrite(path: Path, offset: int, garbage: bytes) -> None:
    data = bytearray(path.read_bytes())
    assert 0 <= offset and offset + len(garbage) <= len(data)
    data[offset:offset + len(garbage)] = garbage
    path.write_bytes(bytes(data))


def _garbage(n: int, seed: int) -> bytes:
    rnd = random.Random(seed)
    return bytes(rnd.randrange(256) for _ in range(n))


def missing_path(tmp: Path) -> Path:
    return tmp / 'bag'


def directory_not_a_bag(tmp: Path) -> Path:
    (tmp / 'bag').mkdir()
    (tmp / 'bag' / 'notes.txt').write_text('holiday notes, not a bag\n')
    return tmp / 'bag'


def empty_directory(tmp: Path) -> Path:
    (tmp / 'bag').mkdir()
    return tmp / 'bag'


def plain_file(tmp: Path) -> Path:
    (tmp / 'bag').write_text('this is a text file, not a bag\n')
    return tmp / 'bag'


def mcap_cut_in_the_middle(tmp: Path) -> Path:
    bag = committed_bag_copy(tmp / 'bag')
    mcap = _mcap(bag)
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) // 2])
    return bag


def _chunk_garbage(chunk: Callable[[int], int]) -> Callable[[Path], Path]:
    """The committed bag with 16 random bytes over the middle of one chunk's data."""
    def make(tmp: Path) -> Path:
        bag = committed_bag_copy(tmp / 'bag')
        mcap = _mcap(bag)
        spans = chunk_data_spans(mcap)
        start, length = spans[chunk(len(spans))]
        overwrite(mcap, start + length // 2, _garbage(16, seed=7))
        return bag
    return make


def _metadata(damage: Callable[[bytes], bytes]) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        bag = committed_bag_copy(tmp / 'bag')
        meta = bag / 'metadata.yaml'
        meta.write_bytes(damage(meta.read_bytes()))
        return bag
    return make


def _over_middle(garbage: bytes) -> Callable[[bytes], bytes]:
    def damage(text: bytes) -> bytes:
        mid = len(text) // 2
        return text[:mid] + garbage + text[mid + len(garbage):]
    return damage


def _without(topic: str) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        return synthetic_bag(tmp / 'bag', [t for t in CONTRACT_INPUTS if t != topic])
    return make


def _retyped(topic: str, msgtype: str) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        return synthetic_bag(tmp / 'bag', CONTRACT_INPUTS, types={topic: msgtype})
    return make


def empty_bag(tmp: Path) -> Path:
    write_bag(tmp / 'bag', [])
    return tmp / 'bag'


@dataclass(frozen=True)
class BadInput:
    """A way to make a bad BAG argument, and what the error line must name."""

    make: Callable[[Path], Path]
    names: tuple[str, ...]


DAMAGED = r'truncated|damaged'
BAD_INPUTS: dict[str, BadInput] = {
    'path does not exist': BadInput(missing_path, (r'does not exist|no such file',)),
    'directory that is not a bag': BadInput(directory_not_a_bag, ('not a rosbag2 bag',)),
    'empty directory': BadInput(empty_directory, ('not a rosbag2 bag',)),
    'plain file': BadInput(plain_file, ('not a rosbag2 bag',)),
    'mcap cut in the middle': BadInput(mcap_cut_in_the_middle, (DAMAGED,)),
    'garbage in the middle of the middle chunk': BadInput(
        _chunk_garbage(lambda n: n // 2), (DAMAGED,)),
    # a damaged chunk must be reported, never decoded into other numbers (the calibrator
    # then merely rejects a window or two, or nothing at all, and exits 0)
    'garbage in the middle of the first chunk': BadInput(
        _chunk_garbage(lambda n: 0), (DAMAGED,)),
    'metadata.yaml with non-UTF-8 garbage': BadInput(
        _metadata(_over_middle(b'\xff' * 32)), (r'metadata\.yaml', DAMAGED)),
    'metadata.yaml with YAML-breaking garbage': BadInput(
        _metadata(_over_middle(b'\x00{[: garbage ]}\x00')),
        (r'metadata\.yaml', DAMAGED)),
    'metadata.yaml cut in the middle': BadInput(
        _metadata(lambda text: text[:len(text) // 2]),
        (r'metadata\.yaml', DAMAGED)),
    **{f'missing {topic}': BadInput(_without(topic), (re.escape(topic), 'missing'))
       for topic in CONTRACT_INPUTS},
    **{f'{topic} recorded as {msgtype}': BadInput(_retyped(topic, msgtype),
                                                  (re.escape(topic), re.escape(msgtype)))
       for topic, msgtype in ((topics.GYRO_PULSES, HEADER),
                              (topics.GYRO_PULSES, FLOAT64),
                              (topics.RATE_TABLE_JOINT_STATES, FLOAT64),
                              (topics.RATE_TABLE_ZERO_INDEX, JOINT_STATE))},
    'empty bag (no message)': BadInput(empty_bag, ('no message',)),
}


@pytest.fixture(scope='module')
def bad_bag(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """``make(case)``: the bad BAG of ``case``, built once per module (the CLI only reads it)."""
    built: dict[str, Path] = {}

    def make(case: str) -> Path:
        if case not in built:
            home = tmp_path_factory.mktemp('bad_input')  # neutral names: see assert_names
            built[case] = BAD_INPUTS[case].make(home)
        return built[case]
    return make


cases = pytest.mark.parametrize('case', list(BAD_INPUTS))


# -- the control: the undamaged copy is good input -------------------------------------------
def test_an_undamaged_copy_of_the_committed_bag_is_not_reported_as_bad_input(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = committed_bag_copy(tmp_path / 'k_tilde_bench')

    run = gyro_calib(capsys, 'calibrate', bag, '--out', tmp_path / 'out.yaml')

    # exit 0 or 1 (the bag has no θ phase, so the hand-off may be incomplete), never 2:
    # in the cases below the damage, not the copying, is what gets reported
    assert run.code in (0, 1) and ERROR_PREFIX not in run.err, run.err


def test_the_chunk_locator_finds_every_chunk_of_the_committed_bag() -> None:
    spans = chunk_data_spans(_mcap(COMMITTED_BAG))
    size = _mcap(COMMITTED_BAG).stat().st_size
    assert len(spans) > 2
    assert all(0 < start and start + length < size for start, length in spans)
    assert all(a[0] + a[1] <= b[0] for a, b in zip(spans, spans[1:]))


# -- calibrate ------------------------------------------------------------------------------
@cases
def test_calibrate_on_bad_input_prints_one_error_line_exits_2_and_writes_nothing(
        case: str, bad_bag: Callable[[str], Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    bag = bad_bag(case)
    out_dir = tmp_path / 'out'
    out_dir.mkdir()
    out = out_dir / 'calib.yaml'

    run = gyro_calib(capsys, 'calibrate', bag, '--out', out)

    line = the_one_error_line(run)
    assert_names(line, BAD_INPUTS[case].names, path=bag)
    assert run.code == EXIT_BAD_INPUT
    assert not out.exists(), f'{out} was written although the input is bad'
    assert listing(out_dir) == [], 'nothing (not even a temporary file) may be left behind'


@cases
def test_calibrate_on_bad_input_leaves_an_existing_output_file_byte_for_byte_unchanged(
        case: str, bad_bag: Callable[[str], Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    bag = bad_bag(case)
    out_dir = tmp_path / 'out'
    out_dir.mkdir()
    out = out_dir / 'calib.yaml'
    out.write_bytes(PREVIOUS_HANDOFF)
    before = out.stat()

    run = gyro_calib(capsys, 'calibrate', bag, '--out', out)

    the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT
    assert out.read_bytes() == PREVIOUS_HANDOFF
    assert out.stat().st_ino == before.st_ino, f'{out} was replaced (same bytes, new file)'
    assert listing(out_dir) == ['calib.yaml'], 'no temporary file may be left beside OUT'


# -- info ------------------------------------------------------------------------------------
DESCRIBABLE = [c for c in BAD_INPUTS
               if c.startswith('missing ') or ' recorded as ' in c or c.startswith('empty bag')]
"""Bags that are readable but no (or not every) method can use: info describes them."""


@pytest.mark.parametrize('case', [c for c in BAD_INPUTS if c not in DESCRIBABLE])
def test_info_on_bad_input_prints_one_error_line_and_exits_2(
        case: str, bad_bag: Callable[[str], Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    bag = bad_bag(case)

    run = gyro_calib(capsys, 'info', bag)

    line = the_one_error_line(run)
    assert_names(line, BAD_INPUTS[case].names, path=bag)
    assert run.code == EXIT_BAD_INPUT


@pytest.mark.parametrize('case', DESCRIBABLE)
def test_info_describes_a_readable_bag_no_method_can_use_and_says_what_each_lacks(
        case: str, bad_bag: Callable[[str], Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    bag = bad_bag(case)

    run = gyro_calib(capsys, 'info', bag)

    assert run.code == 0 and run.err == ''
    assert f'bag: {bag}' in run.out
    assert re.search(r'^  rbrlg +no +needs /', run.out, re.M), run.out


# -- simulate --------------------------------------------------------------------------------
def test_simulate_an_unknown_scenario_prints_one_error_line_naming_it_and_exits_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'new_bag'

    run = gyro_calib(capsys, 'simulate', 'no_such_scenario', '--out', out)

    line = the_one_error_line(run)
    assert_names(line, ('no_such_scenario', 'unknown'))
    assert run.code == EXIT_BAD_INPUT
    assert listing(tmp_path) == [], 'no bag (nor a partial one) may be created'


@pytest.mark.parametrize('existing', ['file', 'bag directory'])
def test_simulate_refuses_to_overwrite_an_existing_out_path(
        existing: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'precious'
    if existing == 'file':
        out.write_bytes(PREVIOUS_HANDOFF)
    else:
        out.mkdir()
        (out / 'metadata.yaml').write_bytes(PREVIOUS_HANDOFF)
    before = {p.relative_to(tmp_path): p.read_bytes()
              for p in tmp_path.rglob('*') if p.is_file()}

    run = gyro_calib(capsys, 'simulate', 'k_tilde_bench', '--out', out)

    line = the_one_error_line(run)
    assert_names(line, (r'exists',), path=out)
    assert run.code == EXIT_BAD_INPUT
    after = {p.relative_to(tmp_path): p.read_bytes()
             for p in tmp_path.rglob('*') if p.is_file()}
    assert after == before, 'the existing path (and its directory) must be left untouched'
    assert listing(tmp_path) == ['precious'], 'no partial bag may be left behind'
