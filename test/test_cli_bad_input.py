"""``gyro-calib`` on bad input: one line on stderr, exit status 2, no output file touched.

The rule (gyro_calib/cli/__init__.py, "Exit status"): whatever is wrong with the input, the
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

Output paths: every output flag of every subcommand is checked before any work, writability
included — a read-only directory (as root too), sysfs, a path under a regular file, a
missing parent (refused, never created), the wrong kind of path — in one line naming the
flag and the path, nothing written; and a disk that fills while an output is written
(RLIMIT_FSIZE) ends in one line, no partial file left.
"""

from __future__ import annotations

import contextlib
import functools
import random
import re
import resource
import shutil
import signal
import struct
import subprocess
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
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
    flags: tuple[str, ...] = ()
    """What makes it bad input: a cut or damaged bag is read up to its damage unless
    ``--strict`` (docs/recovery.md; test_bag_recovery.py)."""


DAMAGED = r'truncated|damaged'
BAD_INPUTS: dict[str, BadInput] = {
    'path does not exist': BadInput(missing_path, (r'does not exist|no such file',)),
    'directory that is not a bag': BadInput(directory_not_a_bag, ('not a rosbag2 bag',)),
    'empty directory': BadInput(empty_directory, ('not a rosbag2 bag',)),
    'plain file': BadInput(plain_file, ('not a rosbag2 bag',)),
    'mcap cut in the middle': BadInput(mcap_cut_in_the_middle, (DAMAGED,), ('--strict',)),
    'garbage in the middle of the middle chunk': BadInput(
        _chunk_garbage(lambda n: n // 2), (DAMAGED,), ('--strict',)),
    # a damaged chunk must be reported, never decoded into other numbers (without --strict
    # it is skipped with a line and the calibrator rejects the windows spanning it)
    'garbage in the middle of the first chunk': BadInput(
        _chunk_garbage(lambda n: 0), (DAMAGED,), ('--strict',)),
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

    run = gyro_calib(capsys, 'calibrate', bag, '--out', out, *BAD_INPUTS[case].flags)

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

    run = gyro_calib(capsys, 'calibrate', bag, '--out', out, *BAD_INPUTS[case].flags)

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

    run = gyro_calib(capsys, 'info', bag, *BAD_INPUTS[case].flags)

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


# -- output paths: checked before any work, writability included ----------------------------
@dataclass(frozen=True)
class OutputFlag:
    """One output flag of one subcommand.

    ``kind``: 'file' (a file written in an existing directory), 'dir' (a directory created
    when absent) or 'bag' (a new directory that must not exist); ``handoff``: a hand-off
    file (its writer replaces a symbolic link's target). :meth:`argv` is the
    command (``head``) with the flag set to ``out`` and the command's other output flags
    (``siblings``: flag → name) pointed into the writable directory ``spare``; its inputs
    do not exist, so a command that read anything before checking its outputs would report
    the input, not the flag.
    """

    command: str
    flag: str
    kind: str
    head: tuple[str | Path, ...]
    siblings: tuple[tuple[str, str], ...] = ()
    handoff: bool = False

    def argv(self, out: Path, spare: Path) -> list[str | Path]:
        others = [a for flag, name in self.siblings if flag != self.flag
                  for a in (flag, spare / name)]
        return [*self.head, self.flag, out, *others]


NO_INPUT = Path('/nonexistent-gyro-calib-input')
"""An input path that does not exist: reading it would be the error reported."""
_CALIBRATE = (('--out', 'c.yaml'), ('--plot', 'figs'), ('--report', 'cert'))
_NOISE = (('--out', 'h.yaml'), ('--kalibr', 'imu.yaml'), ('--plot', 'figs'))
_COMPENSATE = (('--out', 'bag2'), ('--plot', 'figs'))

OUTPUT_FLAGS = [
    *(OutputFlag('calibrate', f, k, ('calibrate', NO_INPUT / 'bag'), _CALIBRATE, f == '--out')
      for f, k in (('--out', 'file'), ('--plot', 'dir'), ('--report', 'dir'))),
    *(OutputFlag('noise', f, k, ('noise', NO_INPUT / 'bag'), _NOISE, f == '--out')
      for f, k in (('--out', 'file'), ('--kalibr', 'file'), ('--plot', 'dir'))),
    *(OutputFlag('compensate', f, k, ('compensate', NO_INPUT / 'bag', '--calibration',
                                      NO_INPUT / 'h.yaml'), _COMPENSATE)
      for f, k in (('--out', 'bag'), ('--plot', 'dir'))),
    OutputFlag('simulate', '--out', 'bag', ('simulate', 'k_tilde_bench')),
    OutputFlag('report', '--out', 'dir', ('report', NO_INPUT / 'h.yaml')),
    OutputFlag('batch', '--out', 'dir', ('batch', NO_INPUT / 'fleet.yaml')),
    OutputFlag('export', '--out', 'file', ('export', NO_INPUT / 'h.yaml', '--format', 'gtsam')),
    OutputFlag('repair', '--out', 'bag', ('repair', NO_INPUT / 'bag')),
]
"""Every output flag of every ``gyro-calib`` subcommand (``info`` and ``methods`` write
nothing; ``--json`` is stdout)."""


def test_the_output_flag_list_is_every_path_flag_that_writes() -> None:
    """A new output flag must join OUTPUT_FLAGS (parsers read from gyro_calib.cli)."""
    import argparse

    from gyro_calib.cli import _parser

    # inputs, not outputs (--lab's certificate-number register is checked for writing by the
    # lab loader before any work: test_certificate_lab)
    readers = {'--config', '--calibration', '--spec', '--lab', '--accel-from', '--merge-into',
               '--sections'}  # --merge-into reads THEIR_FILE; --out is what is written
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    found = {(name, opt) for name, p in sub.choices.items() for a in p._actions
             for opt in a.option_strings
             if opt.startswith('--') and opt not in readers
             and (a.type is Path or opt in ('--out', '--plot', '--kalibr', '--report'))}
    assert found == {(f.command, f.flag) for f in OUTPUT_FLAGS}


def _name(flag: OutputFlag) -> str:
    return {'file': 'out.yaml', 'dir': 'outdir', 'bag': 'newbag'}[flag.kind]


@pytest.fixture
def read_only_dir(tmp_path: Path) -> Iterator[Path]:
    """A directory in which no file can be created, also for root.

    chmod 0o555 stops a user; root writes through it, so root gets ``chattr +i`` (the
    immutable attribute, which stops root too); where neither works (root without
    CAP_LINUX_IMMUTABLE) sysfs's root directory, where no file can be created either.
    """
    ro = tmp_path / 'read_only'
    ro.mkdir()
    ro.chmod(0o555)
    immutable = False
    if _writable(ro) and shutil.which('chattr'):
        immutable = subprocess.run(['chattr', '+i', str(ro)], capture_output=True).returncode == 0
    where = ro if not _writable(ro) else Path('/sys')
    assert where.is_dir() and not _writable(where), 'no read-only directory could be made'
    yield where
    if immutable:
        subprocess.run(['chattr', '-i', str(ro)], check=True)
    ro.chmod(0o755)


def _writable(directory: Path) -> bool:
    try:
        (directory / '.probe').touch()
    except OSError:
        return False
    (directory / '.probe').unlink()
    return True


WHERE = ['in a read-only directory', 'on sysfs', 'under a regular file',
         'in a directory that does not exist', 'the read-only directory itself',
         'of the wrong kind', 'a link into a read-only directory']


def _unwritable(where: str, flag: OutputFlag, tmp_path: Path, read_only: Path) -> Path:
    """The output path of case ``where``."""
    if where == 'in a read-only directory':
        return read_only / _name(flag)
    if where == 'on sysfs':
        return Path('/sys') / _name(flag)
    if where == 'under a regular file':
        (tmp_path / 'plain').write_text('a file, not a directory\n')
        return tmp_path / 'plain' / _name(flag)
    if where == 'in a directory that does not exist':  # refused, never created
        return tmp_path / 'missing' / _name(flag)
    if where == 'the read-only directory itself':  # an existing output directory
        return read_only
    if where == 'a link into a read-only directory':  # the hand-off replaces the link's target
        (tmp_path / 'link.yaml').symlink_to(read_only / 'h.yaml')
        return tmp_path / 'link.yaml'
    # a directory where a file goes, a file where a directory goes, an existing bag path
    wrong = tmp_path / 'wrong'
    if flag.kind == 'dir':
        wrong.write_text('a file where a directory is expected\n')
    else:
        wrong.mkdir()
    return wrong


@pytest.mark.parametrize('flag, where', [
    pytest.param(f, w, id=f'{f.command} {f.flag}: {w}') for f in OUTPUT_FLAGS for w in WHERE
    if (w != 'the read-only directory itself' or f.kind == 'dir')  # an existing output dir
    and (w != 'a link into a read-only directory' or f.handoff)])
def test_an_output_path_that_cannot_be_written_is_refused_before_any_work(
        flag: OutputFlag, where: str, tmp_path: Path, read_only_dir: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = _unwritable(where, flag, tmp_path, read_only_dir)
    spare = tmp_path / 'spare'
    spare.mkdir()
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob('*'))

    run = gyro_calib(capsys, *flag.argv(out, spare))

    line = the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    assert flag.flag in line and str(out) in line, line
    assert str(NO_INPUT) not in line, f'the input was read before the output was checked: {line}'
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob('*')) == before, (
        'nothing may be written, not even the other outputs')
    assert not list(Path('/sys').glob('.gyro-calib-probe*'))


# -- output errors that only show at write time: a disk that fills --------------------------
@contextlib.contextmanager
def disk_full() -> Iterator[None]:
    """Every write that would make a file larger than 16 bytes fails (EFBIG), root's too.

    RLIMIT_FSIZE holds for root as for anyone (SIGXFSZ ignored, the write fails with "File
    too large", as on a full disk it fails with "No space left on device"); an empty file
    can still be created, so the checks before any work pass and the failure comes while
    the output is written.
    """
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)
    previous = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (16, limit[1]))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, limit)
        signal.signal(signal.SIGXFSZ, previous)


@pytest.fixture(scope='module')
def handoff_of_k_tilde_bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('handoff') / 'gyro.yaml'
    assert main(['calibrate', str(COMMITTED_BAG), '--out', str(out), '--no-progress']) == 0
    return out


@pytest.fixture(scope='module')
def imu_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """40 s of a white-noise IMU at 100 Hz: every noise output can be written from it."""
    from sim_nodes.noise.bag_scenarios import imu_template

    rng = np.random.default_rng(5)
    n = 4000
    t = 1_700_000_000_000_000_000 + 10_000_000 * np.arange(n, dtype=np.int64)
    template, accel_at = imu_template('imu')
    rows = template.rows(t, rng.normal(0, 3e-3, (n, 3)))
    at = template.value_at + accel_at
    accel = rng.normal(0, 2e-2, (n, 3)) + (0, 0, 9.81)
    rows[:, at:at + 24] = np.ascontiguousarray(accel.astype('<f8')).view(np.uint8).reshape(n, 24)
    bag = tmp_path_factory.mktemp('imu') / 'imu'
    write_bag(bag, [BagMessage('/imu/data', int(ti), r.tobytes()) for ti, r in zip(t, rows)],
              types={'/imu/data': 'sensor_msgs/msg/Imu'})
    return bag


WRITE_TIME = {
    'calibrate --out': lambda out, inputs: ['calibrate', COMMITTED_BAG, '--out', out / 'c.yaml'],
    'calibrate --plot': lambda out, inputs: ['calibrate', COMMITTED_BAG, '--plot', out / 'figs'],
    'calibrate --report': lambda out, inputs: ['calibrate', COMMITTED_BAG,
                                               '--report', out / 'cert'],
    'noise --out': lambda out, inputs: ['noise', inputs['imu'], '--out', out / 'h.yaml'],
    'noise --kalibr': lambda out, inputs: ['noise', inputs['imu'], '--kalibr', out / 'imu.yaml'],
    'noise --plot': lambda out, inputs: ['noise', inputs['imu'], '--plot', out / 'figs'],
    'simulate --out': lambda out, inputs: ['simulate', 'k_tilde_bench', '--out', out / 'bag'],
    'report --out': lambda out, inputs: ['report', inputs['handoff'], '--out', out / 'cert',
                                         '--no-pdf'],
}
"""Output flags run to the end on a disk that fills (``compensate`` writes through the same
helpers as ``calibrate --plot`` and ``simulate --out``; ``batch`` below)."""


@pytest.mark.parametrize('case', list(WRITE_TIME))
def test_a_disk_that_fills_while_an_output_is_written_ends_in_one_line_and_no_partial_file(
        case: str, tmp_path: Path, imu_record: Path, handoff_of_k_tilde_bench: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out_dir = tmp_path / 'out'
    out_dir.mkdir()
    argv = WRITE_TIME[case](out_dir, {'imu': imu_record, 'handoff': handoff_of_k_tilde_bench})
    target = argv[-1] if argv[-1] != '--no-pdf' else argv[-2]

    with disk_full():
        run = gyro_calib(capsys, *argv, *(['--no-progress'] if argv[0] in (
            'calibrate', 'noise') else []))

    line = the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    # the line names the output (the hand-off by its path, the others by flag and path)
    named = ('calibration file' if target.suffix == '.yaml' and case.endswith('--out')
             else case.split()[1])
    assert f'cannot write {named} {target}' in line and 'File too large' in line, line
    assert listing(out_dir) == [], 'no output, half-written file or temporary file may remain'


def test_batch_on_a_disk_that_fills_ends_in_one_line_and_leaves_no_partial_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import gyro_calib.batch.run as batch_run

    broken = directory_not_a_bag(tmp_path)  # a gyro whose bag fails: the fleet files remain
    manifest = tmp_path / 'fleet.yaml'
    manifest.write_text(f'gyros:\n- id: X-1\n  bags: [{broken}]\n', encoding='utf-8')
    run_batch = batch_run.run_batch

    def on_a_full_disk(*args: object, **kwargs: object) -> object:
        with disk_full():  # the workers run already; the fleet's files are the parent's
            return run_batch(*args, **kwargs)  # type: ignore[arg-type]
    monkeypatch.setattr(batch_run, 'run_batch', on_a_full_disk)
    out = tmp_path / 'fleet'

    run = gyro_calib(capsys, 'batch', manifest, '--out', out, '--workers', '1', '--no-progress')

    line = the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    assert f'cannot write --out {out}' in line and 'File too large' in line, line
    assert not out.exists()


# -- the mistakes of a new user's walk: usage errors, an empty --out, a misspelt column ------
@pytest.mark.parametrize('argv, words', [
    (['batch', 'm.csv', '--out', 'o', '--workers', 'abc'],
     ('batch', '--workers', "'abc'", 'gyro-calib batch --help')),
    (['calibrate'], ('calibrate', 'BAG', 'gyro-calib calibrate --help')),
    (['frobnicate'], ("'frobnicate'", 'calibrate', 'gyro-calib --help')),
])
def test_a_usage_error_is_one_line_naming_the_flag_and_where_help_is(
        argv: list[str], words: tuple[str, ...], capsys: pytest.CaptureFixture[str]) -> None:
    run = gyro_calib(capsys, *argv)
    line = the_one_error_line(run)  # argparse printed its usage block too
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    for word in words:
        assert word in line, line


@pytest.mark.parametrize('content', [b'', b'# nothing yet\n', b'garbage: 1\n'])
def test_an_existing_out_file_that_is_not_a_handoff_is_refused_naming_out(
        content: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """An empty or foreign --out file: one line naming --out and what to do; left as it was."""
    out = tmp_path / 'gyro.yaml'
    out.write_bytes(content)
    run = gyro_calib(capsys, 'calibrate', COMMITTED_BAG, '--out', out, '--no-progress')
    line = the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    assert f'--out {out}' in line and 'new path' in line, line
    if not content.strip(b'# nothing yet\n'):
        assert 'is empty' in line, line
    assert out.read_bytes() == content and sorted(tmp_path.iterdir()) == [out]


@pytest.mark.parametrize('manifest, words', [
    ('gyro_id,bag\nA,bags/k_tilde_bench\n', ("unknown column 'bag'", "did you mean 'bags'")),
    ('gyro_id,bags,latitude\nA,bags/k_tilde_bench,45\n',
     ("unknown column 'latitude'", "did you mean 'latitude_deg'")),
    ('- id: A\n  bag: bags/k_tilde_bench\n', ("unknown field 'bag'", "did you mean 'bags'")),
    ('- id: A\n  bags: [bags/k_tilde_bench]\n  settings: {latitud_deg: 45}\n',
     ("unknown setting 'latitud_deg'", "did you mean 'latitude_deg'")),
])
def test_a_misspelt_manifest_column_or_field_names_the_nearest_one(
        manifest: str, words: tuple[str, ...], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / ('m.csv' if manifest.startswith('gyro_id') else 'm.yaml')
    path.write_text(manifest, encoding='utf-8')
    run = gyro_calib(capsys, 'batch', path, '--out', tmp_path / 'out')
    line = the_one_error_line(run)
    assert run.code == EXIT_BAD_INPUT and run.out == ''
    for word in words:
        assert word in line, line
    assert not (tmp_path / 'out').exists()


def test_two_simulate_runs_into_one_out_never_mix_and_the_loser_says_it_wrote_nothing(
        tmp_path: Path) -> None:
    """Two simulate runs into one --out: one bag, all of it the winner's.

    They shared one staging directory: the bag held one run's data and the other's metadata,
    and the run that said 'nothing was written' had supplied the data.
    """
    import os
    import subprocess
    import sys

    out = tmp_path / 'twin'
    env = {**os.environ, 'PYTHONPATH': str(Path(__file__).resolve().parent.parent)}
    short = ['--duration-s', '20']  # the race is in publishing the bag, not in its length
    runs = [subprocess.Popen([sys.executable, '-m', 'gyro_calib.cli', 'simulate', 'k_tilde_bench',
                              '--out', str(out), '--seed', str(seed), *short], env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for seed in (3, 4)]
    results = [(r.wait(timeout=300), *r.communicate()) for r in runs]
    codes = sorted(code for code, _, _ in results)
    assert codes == [0, 2], results
    loser = next(err for code, _, err in results if code == 2)
    assert len(loser.strip().splitlines()) == 1 and ('wrote nothing' in loser
                                                     or 'exists already' in loser), loser
    winner_seed = next(seed for (code, _, _), seed in zip(results, (3, 4)) if code == 0)
    meta = (out / 'metadata.yaml').read_text(encoding='utf-8')
    assert f'seed: {winner_seed}' in meta.replace("'", '') or f"seed = {winner_seed}" in meta
    assert sorted(p.name for p in tmp_path.iterdir()) == ['twin']  # no staging left
    ref = tmp_path / 'ref'  # the data are the winner's too (they were the other run's)
    assert main(['simulate', 'k_tilde_bench', '--out', str(ref), '--seed', str(winner_seed),
                 *short]) == 0
    from rosbags.rosbag2 import Reader

    def pulses(bag: Path) -> list[tuple[int, bytes]]:
        with Reader(bag) as reader:
            cons = [c for c in reader.connections if c.topic == '/gyro/pulses']
            return [(t, bytes(raw)) for _, t, raw in reader.messages(connections=cons)]

    assert pulses(out) == pulses(ref)
