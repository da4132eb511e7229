"""Every command in the README's and the documentation's bash blocks is run.

Every command in the ```bash blocks of README.md and of the hand-written pages under docs/
(where the README's sections moved, issue 39) is run, so neither can drift from the tools
(issue 17 item 4). The tutorials' ```console blocks, with their output, are run by
test/test_docs_tutorials.py.

The commands are extracted from the pages themselves, in order, block by block:

- ``gyro-calib ...`` lines run in-process, in one scratch directory per block (with
  ``bags/`` and ``config/`` linked in), so a bag a block simulates or a hand-off file it
  writes is there for the block's next line. They must exit 0. Optional groups ``[...]``
  are taken when every placeholder in them has a value here (DIR, BAG, T, ID, NAME) and
  they offer no alternatives (``a | b``) or repetition (``...``); otherwise left out.
- node executables (``ros2 run gyro_calib NODE`` or NODE alone, with its ``-p`` and
  ``--params-file``) are started with the README's arguments in the test's private DDS
  domain, one block at a time: each must come up without a fatal line, without a traceback,
  and use every parameter the README gives it (a parameter it does not declare is reported
  by the node and fails the test), then is stopped.
- ``./run.sh demo|test`` must be subcommands run.sh has; the ``colcon build`` line is what
  test/test_colcon_build.py builds.
- the files the commands name (``spec.yaml``, ``fleet.yaml``) are the pages' own ```yaml
  examples (:data:`README_FILES`).
"""

from __future__ import annotations

import re
import shlex
import signal
import subprocess
import time
from pathlib import Path

import pytest

from gyro_calib.cli import main
from gyro_calib.nodes.processes import NODE_MODULES

from .dds_harness import NodeProcess

ROOT = Path(__file__).resolve().parents[2]
PLACEHOLDERS = {'DIR': 'figs', 'BAG': 'bags/noise_imu_static', 'T': '/imu/data',
                'ID': 'imu-1', 'NAME': 'rbrlg'}
"""Values for the README's synopsis placeholders."""


PAGES = [ROOT / 'README.md'] + sorted(
    p for p in (ROOT / 'docs').rglob('*.md')
    if not {'generated', '_build'} & set(p.relative_to(ROOT / 'docs').parts))
"""README.md and the hand-written documentation pages (the generated reference has no commands)."""


def readme_blocks() -> list[tuple[str, list[str]]]:
    """('page:line', commands) of every ```bash block of the pages; comments dropped."""
    blocks: list[tuple[str, list[str]]] = []
    for page in PAGES:
        current: list[str] | None = None
        start = 0
        for number, line in enumerate(page.read_text().splitlines(), 1):
            stripped = line.strip()
            if stripped.startswith('```bash'):
                current, start = [], number
            elif stripped.startswith('```') and current is not None:
                blocks.append((f'{page.relative_to(ROOT).as_posix()}:{start}', current))
                current = None
            elif current is not None:
                text = stripped.split(' #', 1)[0].strip()
                if text and not text.startswith('#'):
                    current.append(text)
    return blocks


README_FILES = {'spec.yaml': 'decision_rule:', 'fleet.yaml': 'gyros:',
                'lab.yaml': 'certificate_number:'}
"""Files the README's commands name, written from the README's ```yaml block holding the key."""


def readme_files() -> dict[str, str]:
    """File name → the text of the pages' ```yaml block that defines it."""
    text = '\n'.join(p.read_text() for p in PAGES)
    blocks = re.findall(r'^```yaml\n(.*?)^```', text, re.M | re.S)
    out = {}
    for name, key in README_FILES.items():
        found = [b for b in blocks if key in b
                 and 'imu.' not in b and 'IMU-' not in b]  # an IMU's spec and fleet: own page
        assert len(found) == 1, f'docs: one ```yaml block with {key!r} expected for {name}'
        out[name] = found[0]
    return out


def expand(command: str) -> list[str]:
    """The command's words with optional groups taken or left out (module docstring)."""
    words, out, group = shlex.split(command), [], None
    for word in words:
        if group is None and word.startswith('['):
            group, word = [], word[1:]
        if group is None:
            out.append(word)
            continue
        closes = word.endswith(']') and word.count(']') > word.count('[')
        group.append(word[:-1] if closes else word)
        if closes:
            tokens = [t for g in group for t in re.findall(r'\b[A-Z][A-Z_]*\b', g)
                      if not t.startswith('_')]
            if ('|' not in group and not any('...' in g for g in group)
                    and all(t in PLACEHOLDERS for t in tokens)):
                out += [PLACEHOLDERS.get(g, g) for g in group]
            group = None
    return [PLACEHOLDERS.get(w, w) if w in ('BAG', 'DIR') else w for w in out]


def _kind(words: list[str]) -> str:
    if words[:3] == ['ros2', 'run', 'gyro_calib']:
        return 'node'
    return {'gyro-calib': 'cli', './run.sh': 'run.sh', 'colcon': 'colcon'}.get(
        words[0], 'node' if words[0] in NODE_MODULES else 'unknown')


BLOCKS = readme_blocks()


def test_the_readme_has_commands_and_every_one_is_of_a_known_kind() -> None:
    assert any(where.startswith('README.md:') for where, _ in BLOCKS)
    kinds = [_kind(expand(c)) for _, cmds in BLOCKS for c in cmds]
    assert kinds.count('cli') >= 10 and kinds.count('node') >= 8
    assert 'unknown' not in kinds, [c for _, cmds in BLOCKS for c in cmds]


CLI_BLOCKS = [(start, cmds) for start, cmds in BLOCKS
              if any(_kind(expand(c)) != 'node' for c in cmds)]


@pytest.mark.parametrize('start, commands', CLI_BLOCKS, ids=[s for s, _ in CLI_BLOCKS])
def test_readme_block_runs(start: str, commands: list[str], tmp_path: Path,
                           capsys: pytest.CaptureFixture[str],
                           monkeypatch: pytest.MonkeyPatch) -> None:
    """The block's gyro-calib lines in order, in one scratch directory (node lines: below)."""
    _scratch(tmp_path)
    monkeypatch.chdir(tmp_path)
    for command in commands:
        words = expand(command)
        kind = _kind(words)
        if kind == 'cli':
            try:
                code = main(words[1:] + (['--no-progress'] if words[1] in
                                         ('calibrate', 'noise', 'batch') else []))
            except SystemExit as exc:  # --version, as argparse ends it
                code = int(exc.code or 0)
            out, err = capsys.readouterr()
            assert code == 0, f'{start} line {command!r}:\n{err}'
        elif kind == 'run.sh':
            cases = re.findall(r'^\s+([a-z]+)\)', (ROOT / 'run.sh').read_text(), re.M)
            assert words[1] in cases, f'run.sh has no subcommand {words[1]!r}'
        elif kind == 'colcon':
            build = (ROOT / 'test' / 'test_colcon_build.py').read_text()
            assert words[:2] == ['colcon', 'build'] and "'--base-paths'" in build


def test_every_readme_node_line_starts_and_uses_every_parameter_it_gives(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """Every node line of every block started at once (a scratch directory per block)."""
    started: list[tuple[str, NodeProcess]] = []
    for start, commands in BLOCKS:
        cwd = _scratch(tmp_path / re.sub(r'\W', '_', start))
        for command in commands:
            words = expand(command)
            if _kind(words) == 'node':
                name = words[3] if words[0] == 'ros2' else words[0]
                started.append((command, _start(name, words[words.index(name) + 1:], nodes,
                                                cwd)))
    assert len(started) >= 8
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and not all(n.lines or n.proc.poll() is not None
                                                  for _, n in started):
        time.sleep(0.1)
    time.sleep(0.5)
    # publishers (simulators, player) stop first: their readers are still there
    for first in (True, False):
        group = [n for _, n in started if (n.name.endswith('_sim') or n.name == 'bag_player')
                 == first]
        for n in group:
            if n.proc.poll() is None:
                n.send_signal(signal.SIGINT)
        stop_by = time.monotonic() + 5.0  # the logs are what is checked: no long goodbyes
        for n in group:
            n.stop(timeout_s=max(stop_by - time.monotonic(), 0.1))
    for command, node in started:
        _check(command, node)


def _scratch(path: Path) -> Path:
    """A scratch directory with bags/ and config/ linked and the README's files written."""
    path.mkdir(parents=True, exist_ok=True)
    for name in ('bags', 'config'):
        (path / name).symlink_to(ROOT / name)
    for name, text in readme_files().items():
        (path / name).write_text(text)
    return path


def _start(name: str, args: list[str], nodes: list[NodeProcess], cwd: Path) -> NodeProcess:
    """Start node ``name`` with the README's arguments verbatim, in ``cwd``."""
    import os
    import sys

    from gyro_calib.nodes.processes import ros_environment

    assert not args or args[0] == '--ros-args', args
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    proc = subprocess.Popen([sys.executable, '-m', NODE_MODULES[name], *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=cwd)
    node = NodeProcess(name, proc)
    nodes.append(node)
    return node


def _check(command: str, node: NodeProcess) -> None:
    log = node.log()
    assert node.lines, f'README line {command!r}: the node logged nothing in 60 s'
    assert 'given but not declared' not in log, f'README line {command!r}:\n{log}'
    assert 'Traceback' not in log and '[FATAL]' not in log, f'README line {command!r}:\n{log}'
    assert node.proc.returncode != 2, f'README line {command!r}:\n{log}'


def test_start_of_every_node_is_a_console_script() -> None:
    scripts = subprocess.run(
        ['grep', '-o', r"'[a-z_]* = ", str(ROOT / 'setup.py')], capture_output=True,
        text=True, check=True).stdout
    for _, cmds in BLOCKS:
        for command in cmds:
            words = expand(command)
            if _kind(words) == 'node':
                name = words[3] if words[0] == 'ros2' else words[0]
                assert f"'{name} = " in scripts, name
