"""Every tutorial of the documentation runs as written: its commands and their outputs (issue 39).

A tutorial (``docs/tutorials/*.md``) is a sequence of blocks, run in order in one scratch
directory (``bags/`` and ``config/`` linked in):

- a ``{code-block}`` whose ``:caption:`` is a file name (``fleet.yaml``) is written there;
- a ```` ```console ```` block holds commands (``$ gyro-calib …``, ``$ cat FILE``,
  ``$ ls DIR``), each followed by the output the page shows. Every command must exit 0 and
  every output line shown must appear in what the command printed (stdout or stderr), in
  the order shown; ``...`` on a line of its own stands for lines left out and ``…`` inside
  a line for any text (an absolute path, a hash).

A page cannot show a command that fails, an output the tool no longer prints, or a file
the reader is not told to write.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from gyro_calib.cli import main

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / 'docs' / 'tutorials').glob('*.md'))
FENCE = re.compile(r'^```(\{code-block\}\s*\S*|console)\s*\n(.*?)^```\s*$', re.M | re.S)


def steps(text: str) -> list[tuple[str, str, list[str]]]:
    """('file', name, lines) and ('run', command, expected output lines), in page order."""
    out: list[tuple[str, str, list[str]]] = []
    for m in FENCE.finditer(text):
        body = m.group(2).splitlines()
        if m.group(1).startswith('{code-block}'):
            options = [ln for ln in body if ln.startswith(':')]
            caption = [ln.split(':', 2)[2].strip() for ln in options if ln.startswith(':caption:')]
            if caption and re.fullmatch(r'[\w.-]+\.\w+', caption[0]):
                content = body[len(options):]
                if content and not content[0].strip():
                    content = content[1:]
                out.append(('file', caption[0], content))
            continue
        for line in body:
            if line.startswith('$ '):
                out.append(('run', line[2:].strip(), []))
            elif out and out[-1][0] == 'run':
                out[-1][2].append(line)
    return out


def _pattern(line: str) -> re.Pattern[str]:
    parts = [re.escape(' '.join(p.split())) for p in line.split('…')]
    return re.compile('.*'.join(parts))


def shown_in_order(expected: list[str], printed: str) -> str | None:
    """The first shown line not found (in order) in ``printed``; None when all are."""
    lines = [' '.join(ln.split()) for ln in printed.splitlines()]
    at = 0
    for want in expected:
        if not want.strip() or want.strip() == '...':
            continue
        pattern = _pattern(want.strip())
        while at < len(lines) and not pattern.search(lines[at]):
            at += 1
        if at == len(lines):
            return want
        at += 1
    return None


def run(command: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run one tutorial command in the current directory: (status, stdout, stderr)."""
    words = shlex.split(command)
    if words[0] == 'gyro-calib':
        try:
            status = main(words[1:])
        except SystemExit as exc:  # --version, as argparse ends it
            status = int(exc.code or 0)
        out, err = capsys.readouterr()
        return status, out, err
    if words[0] == 'cat' and len(words) == 2:
        return 0, Path(words[1]).read_text(encoding='utf-8'), ''
    if words[0] == 'ls' and len(words) == 2:
        return 0, '\n'.join(sorted(p.name for p in Path(words[1]).iterdir())) + '\n', ''
    raise AssertionError(f'a tutorial command the test cannot run: {command!r}')


def test_there_is_a_tutorial_per_user_story_and_each_runs_something() -> None:
    names = {p.stem for p in TUTORIALS}
    assert {'rlg-bench', 'mems-noise', 'triad-openvins', 'fleet-certificates'} <= names
    for page in TUTORIALS:
        runs = [s for s in steps(page.read_text(encoding='utf-8')) if s[0] == 'run']
        assert len(runs) >= 2, f'{page.name}: fewer than two commands'
        assert sum(len([ln for ln in s[2] if ln.strip() not in ('', '...')]) for s in runs) >= 3


def test_the_output_check_can_fail() -> None:
    assert shown_in_order(['a', '...', 'c…e'], 'a\nb\nc d e\n') is None
    assert shown_in_order(['c', 'a'], 'a\nc\n') == 'a'
    assert shown_in_order(['x'], 'a\n') == 'x'


@pytest.mark.parametrize('page', TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_tutorial_runs_as_written(page: Path, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str],
                                  monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ('bags', 'config'):
        (tmp_path / name).symlink_to(ROOT / name)
    monkeypatch.chdir(tmp_path)
    for kind, what, lines in steps(page.read_text(encoding='utf-8')):
        if kind == 'file':
            (tmp_path / what).write_text('\n'.join(lines) + '\n', encoding='utf-8')
            continue
        status, out, err = run(what, capsys)
        assert status == 0, f'{page.name}: $ {what}\nexit {status}\n{err}'
        missing = shown_in_order(lines, out + err)
        if missing is not None:  # stdout and stderr are separate streams: either order
            missing = shown_in_order(lines, err + out)
        assert missing is None, (f'{page.name}: $ {what}\nthe page shows {missing!r}, '
                                 f'which is not printed (in that order):\n{out}{err}')
