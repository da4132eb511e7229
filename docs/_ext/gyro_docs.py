"""Sphinx extension of the gyro_calib site: the reference generated from the code, and its checks.

At ``builder-inited`` it writes ``docs/reference/generated/*.md`` (git-ignored) from the code:

- ``cli.md``: every ``gyro-calib`` subcommand and flag, from the argparse parsers
  (``gyro_calib.cli._parser``), and the demo's flags (``bench_demo``, ``./run.sh demo``);
- ``nodes.md``: every node's declared parameters with type, default, range and description,
  read from the nodes themselves (``node_parameters.py``, one subprocess);
- ``handoff-keys.md``: every hand-off key of every method (``registry.handoff_schema``);
- ``topics.md``: the topic contract (``gyro_calib/topics.py``, names and docstrings);
- ``result-schema.md``: the JSON result schema (``gyro_calib/schema/result.schema.json``).

Each item is a Sphinx object (``flag``, ``param``, ``key``, ``topic``) that pages cite with
the roles of the same names, e.g. ``{flag}`calibrate --out```, ``{param}`noise_node.topic```,
``{key}`k_tilde_rad_per_pulse```, ``{topic}`/gyro/pulses```. With ``nitpicky`` a role naming
nothing is a warning, and ``-W`` makes it an error.

Pages written as plain Markdown are checked too (``source-read``), so that a page naming a
flag, a node parameter or a hand-off key that does not exist fails the build:

- a ``gyro-calib SUBCOMMAND ... --flag`` (in a code block or inline code): the flag must
  be one of that subcommand's; ``./run.sh demo``/``bench_demo --flag``: one of the demo's;
- a node line (``ros2 run gyro_calib NODE`` or ``NODE --ros-args``): each ``-p NAME:=`` must
  be one that NODE declares; any other ``NAME:=`` one that some node declares;
- inline code that is a flag alone (```--out FILE```): a flag of some command;
- inline code that looks like a hand-off key (ends in ``_std``/``_dof``, or in a unit
  ``_rad_per_pulse``, ``_rad_s``, ...) must be a key (or key + ``_std``/``_dof``), a node
  parameter, a settings field or a name the code has.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.util import logging

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
logger = logging.getLogger(__name__)

EXTERNAL_FLAGS = {
    '--ros-args', '--params-file', '--remap', '--log-level', '--base-paths',
    '--symlink-install', '--packages-select', '--from-paths', '--src', '--dst', '--help',
    '--version', '--strict', '--no-deps', '--user', '--quiet', '--headless', '--no-sandbox',
    '--disable-gpu', '--screenshot', '--window-size', '--no-progress', '--ros',
}
"""Flags of other tools the pages show (ros2, colcon, rosdep, rosbags-convert, pip, pytest,
chromium, ./run.sh test --ros) and argparse's own."""

RUN_SH_FLAGS = {'--ros'}
"""run.sh's own flags, before the demo's (``./run.sh demo --ros jazzy``)."""

UNIT_SUFFIX = re.compile(
    r'_(std|dof|rad_per_pulse|counts_per_rad|rad_s|rad|rad_s2|rad_per_sqrt_s|'
    r'rad_s_per_sqrt_s|rad_s_per_k|per_k|ppm|ppb|celsius|c|degc|m_s2|m_s3|s|hz)$')


# --------------------------------------------------------------------------- the code's facts

def _import_root() -> None:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))


def cli_parsers() -> dict[str, argparse.ArgumentParser]:
    """'' → the top-level parser, subcommand → its parser, 'demo' → bench_demo's."""
    _import_root()
    from gyro_calib.cli import _parser
    from gyro_calib.nodes import bench_demo

    top = _parser()
    out: dict[str, argparse.ArgumentParser] = {'': top}
    for action in top._actions:
        if isinstance(action, argparse._SubParsersAction):
            out.update(action.choices)
    captured: dict[str, argparse.ArgumentParser] = {}
    original = argparse.ArgumentParser.parse_args

    def capture(self: argparse.ArgumentParser, *a: Any, **k: Any) -> Any:
        captured['demo'] = self
        raise SystemExit(0)

    argparse.ArgumentParser.parse_args = capture  # type: ignore[method-assign]
    try:
        bench_demo.parse_args([])
    except SystemExit:
        pass
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]
    out['demo'] = captured['demo']
    return out


def flags_of(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string of ``parser``."""
    return {s for a in parser._actions for s in a.option_strings}


NODE_CACHE = DOCS / 'reference' / 'generated' / 'nodes.json'
"""The last dump of the nodes' parameters, with the hash of the code it was read from."""


def _code_hash() -> str:
    """SHA-256 of the code the nodes are built from (gyro_calib/, sim_nodes/, rclpy's version)."""
    import hashlib

    digest = hashlib.sha256()
    for top in ('gyro_calib', 'sim_nodes'):
        for path in sorted((ROOT / top).rglob('*.py')):
            digest.update(path.relative_to(ROOT).as_posix().encode())
            digest.update(path.read_bytes())
    digest.update(Path(__file__).with_name('node_parameters.py').read_bytes())
    from importlib import metadata

    for dist in ('ros-rclpy', 'rclpy'):  # another ROS 2 distribution: dump again
        try:
            digest.update(f'{dist} {metadata.version(dist)}'.encode())
        except metadata.PackageNotFoundError:
            pass
    return digest.hexdigest()


def node_parameters() -> dict[str, Any]:
    """Every node's declared parameters (``node_parameters.py`` in a subprocess).

    The dump is kept in :data:`NODE_CACHE` with the hash of the code; while the code is
    unchanged the nodes are not started again.
    """
    code_hash = _code_hash()
    try:
        cached = json.loads(NODE_CACHE.read_text(encoding='utf-8'))
        if cached.get('code_sha256') == code_hash:
            return cached['nodes']  # type: ignore[no-any-return]
    except (OSError, ValueError, KeyError):
        pass
    nodes = _dump_node_parameters()
    NODE_CACHE.parent.mkdir(parents=True, exist_ok=True)
    tmp = NODE_CACHE.with_suffix(f'.{os.getpid()}.tmp')
    tmp.write_text(json.dumps({'code_sha256': code_hash, 'nodes': nodes}), encoding='utf-8')
    tmp.replace(NODE_CACHE)
    return nodes


def _dump_node_parameters() -> dict[str, Any]:
    _import_root()
    from gyro_calib.nodes.processes import pick_domain_id, ros_environment

    env = ros_environment(pick_domain_id())
    env['PYTHONPATH'] = os.pathsep.join([str(ROOT), env.get('PYTHONPATH', '')]).strip(os.pathsep)
    done = subprocess.run([sys.executable, str(Path(__file__).with_name('node_parameters.py'))],
                          env=env, capture_output=True, text=True, timeout=300, cwd=ROOT)
    if done.returncode != 0:
        raise RuntimeError(f'node_parameters.py failed:\n{done.stderr}')
    return json.loads(done.stdout)  # type: ignore[no-any-return]


def handoff_keys() -> dict[str, Any]:
    """Every hand-off key of every method, by name."""
    _import_root()
    from gyro_calib.registry import handoff_schema

    return handoff_schema()


def contract_topics() -> list[tuple[str, str, str]]:
    """(constant, value, docstring) of every constant of gyro_calib/topics.py, in order."""
    source = (ROOT / 'gyro_calib' / 'topics.py').read_text(encoding='utf-8')
    body = ast.parse(source).body
    out = []
    for i, stmt in enumerate(body):
        if (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1
                and isinstance(stmt.targets[0], ast.Name) and stmt.targets[0].id.isupper()):
            value = ast.literal_eval(stmt.value)
            doc = ''
            if i + 1 < len(body) and isinstance(body[i + 1], ast.Expr) and isinstance(
                    getattr(body[i + 1], 'value', None), ast.Constant):
                doc = str(body[i + 1].value.value)  # type: ignore[attr-defined]
            out.append((stmt.targets[0].id, value, ' '.join(doc.split())))
    return out


class Facts:
    """What exists: flags per command, node parameters, hand-off keys, code names (cached)."""

    def __init__(self) -> None:
        """Read every fact from the code (and the nodes, in a subprocess)."""
        self.parsers = cli_parsers()
        self.flags = {name: flags_of(p) for name, p in self.parsers.items()}
        self.all_flags = set().union(*self.flags.values()) | EXTERNAL_FLAGS
        self._nodes: dict[str, Any] | None = None
        self.keys = handoff_keys()
        code = [p.read_text(encoding='utf-8') for top in ('gyro_calib', 'sim_nodes')
                for p in (ROOT / top).rglob('*.py')]
        code += [p.read_text(encoding='utf-8') for p in (ROOT / 'gyro_calib').rglob('*.json')]
        self.code = '\n'.join(code)

    @property
    def nodes(self) -> dict[str, Any]:
        """Every node's declared parameters (started once, when first asked for)."""
        if self._nodes is None:
            self._nodes = node_parameters()
        return self._nodes

    @property
    def params(self) -> dict[str, set[str]]:
        """Node → the names of its declared parameters."""
        return {n: {p['name'] for p in v['parameters']} for n, v in self.nodes.items()}

    @property
    def all_params(self) -> set[str]:
        """Every parameter name some node declares."""
        return set().union(*self.params.values())


_FACTS: Facts | None = None


def facts() -> Facts:
    """The facts, read once per build."""
    global _FACTS
    if _FACTS is None:
        _FACTS = Facts()
    return _FACTS


# ------------------------------------------------------------------------------ generation

def _md_escape(text: str) -> str:
    return text.replace('|', '\\|').replace('<', '&lt;').replace('*', '\\*')


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    if not action.help or action.help == argparse.SUPPRESS:
        return ''
    formatter = parser._get_formatter()
    return ' '.join(formatter._expand_help(action).split())


def _default(action: argparse.Action) -> str:
    d = action.default
    if d is None or d is argparse.SUPPRESS or isinstance(action, (
            argparse._HelpAction, argparse._VersionAction)):
        return ''
    if isinstance(action, argparse._StoreTrueAction) and d is False:
        return ''
    return f'default: `{d!r}`' if not isinstance(d, str) else f'default: `{d}`'


def generate_cli(f: Facts) -> str:
    """The CLI reference page: every subcommand, flag and positional argument."""
    lines = ['# `gyro-calib` and the demo: every subcommand and flag (generated)', '',
             '```{note}', 'Generated from the argparse parsers (`gyro_calib.cli`, '
             '`gyro_calib.nodes.bench_demo`) by `docs/_ext/gyro_docs.py` at every build; '
             'cite an entry with ``{flag}`SUBCOMMAND --flag` ``.', '```', '']
    top = f.parsers['']
    lines += ['(cli-top)=', '## gyro-calib', '', _md_escape(top.description or ''), '',
              '```text', top.format_usage().strip(), '```', '']
    for action in top._actions:
        if action.option_strings and not isinstance(action, argparse._HelpAction):
            lines += [f'```{{flag}} gyro-calib {action.option_strings[0]}', '',
                      _md_escape(_help(top, action)) or '(no help text)', '```', '']
    for name, parser in f.parsers.items():
        if name in ('', 'demo'):
            continue
        lines += _parser_section(f'gyro-calib {name}', name, parser)
    lines += _parser_section('./run.sh demo (bench_demo)', 'demo', f.parsers['demo'])
    return '\n'.join(lines) + '\n'


def _parser_section(title: str, name: str, parser: argparse.ArgumentParser) -> list[str]:
    lines = [f'(cli-{name})=', f'## {title}', '']
    desc = (parser.description or '').strip()
    if desc:
        lines += ['```text', desc, '```', '']
    lines += ['```text', parser.format_usage().strip(), '```', '']
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if action.option_strings:
            longs = [s for s in action.option_strings if s.startswith('--')]
            target = f'{name} {(longs or action.option_strings)[0]}'
            sig = ', '.join(action.option_strings)
        else:
            target = f'{name} {action.metavar or action.dest.upper()}'
            sig = str(action.metavar or action.dest.upper())
        meta = action.metavar if action.option_strings and action.metavar else (
            action.dest.upper() if action.option_strings and action.nargs != 0 else '')
        parts = []
        if meta:
            parts.append(f'takes `{meta}`')
        if action.nargs in ('+', '*'):
            parts.append('one or more' if action.nargs == '+' else 'any number')
        if action.choices:
            parts.append('one of ' + ', '.join(f'`{c}`' for c in action.choices))
        if getattr(action, 'required', False) and action.option_strings:
            parts.append('required')
        d = _default(action)
        if d:
            parts.append(d)
        lines += [f'```{{flag}} {target}', '']
        text = _help(parser, action)
        also = f'`{sig}`: ' if len(action.option_strings) > 1 else ''
        lines += [also + (_md_escape(text) or '(no help text)') + (
            f' — {"; ".join(parts)}.' if parts else ''), '```', '']
    return lines


def _value_text(value: Any) -> str:
    return '' if value is None else f'`{json.dumps(value, ensure_ascii=False)}`'


def generate_nodes(f: Facts) -> str:
    """The node reference page: every declared parameter of every node."""
    lines = ['# Node parameters (generated)', '', '```{note}',
             'Generated at every build from what each node executable declares when it is '
             'constructed with its defaults (`docs/_ext/node_parameters.py`: each node\'s '
             'declared name, type, default, range and description). Cite one with '
             '``{param}`NODE.NAME` ``. A parameter marked *required* has no usable default.',
             '```', '', 'Nodes: ' + ', '.join(f'[`{n}`](#node-{n})' for n in f.nodes) + '.', '']
    for name, info in f.nodes.items():
        lines += [f'(node-{name})=', f'## `{name}`', '',
                  f'Module `{info["module"]}`; started as `ros2 run gyro_calib {name}` or '
                  f'`{name}` (console script).', '']
        for p in info['parameters']:
            facts_ = [f'type `{p["type"]}`']
            if p['required']:
                facts_.append('required')
            elif p['default'] is not None:
                facts_.append('default ' + _value_text(p['default']))
            if 'range' in p:
                facts_.append(f'range {p["range"][0]:g} … {p["range"][1]:g}')
            if p['read_only']:
                facts_.append('read-only')
            lines += [f'```{{param}} {name}.{p["name"]}', '',
                      f'{_md_escape(p["description"]) or "(no description)"} — '
                      f'{"; ".join(facts_)}.', '```', '']
    return '\n'.join(lines) + '\n'


def generate_keys(f: Facts) -> str:
    """The hand-off key reference page, by method."""
    lines = ['# Hand-off keys (generated)', '', '```{note}',
             'Generated at every build from the hand-off schema (`gyro_calib.registry.'
             'handoff_schema`: every method\'s `handoff_keys()`). Cite one with '
             '``{key}`NAME` ``. A key with an uncertainty has `NAME_std` (standard, k = 1) and '
             '`NAME_dof` beside it in the file. The file itself: [the hand-off file]'
             '(#handoff-file).', '```', '']
    by_method: dict[str, list[Any]] = {}
    for key in f.keys.values():
        by_method.setdefault(key.method, []).append(key)
    for method, keys in by_method.items():
        lines += [f'(keys-{method})=', f'## `{method}`', '']
        for key in keys:
            facts_ = [f'kind `{key.kind}`']
            if key.has_std:
                facts_.append(f'with `{key.name}_std`')
            if key.follows:
                facts_.append(f'follows `{key.follows}`')
            if key.bench_specific:
                facts_.append('holds on its bench only')
            if key.scales_with_scale_factor:
                facts_.append('scales with the scale factor')
            lines += [f'```{{key}} {key.name}', '', f'{_md_escape(key.description)} — '
                      f'{"; ".join(facts_)}.', '```', '']
    return '\n'.join(lines) + '\n'


def generate_topics(f: Facts) -> str:
    """The topic contract page: every topic constant and its docstring."""
    lines = ['# Topics (generated)', '', '```{note}',
             'Generated at every build from `gyro_calib/topics.py` (each constant and its '
             'docstring). Cite a topic with ``{topic}`/gyro/pulses` ``. What the nodes do '
             'with them, QoS and namespaces: [topic contract](#topic-contract-prose).', '```',
             '', '## Topics', '']
    joints = []
    for const, value, doc in contract_topics():
        if isinstance(value, str) and value.startswith('/'):
            lines += [f'```{{topic}} {value}', '', f'`topics.{const}`. {_md_escape(doc)}',
                      '```', '']
        else:
            joints.append((const, value, doc))
    lines += ['## Joint and sensor names', '', '| constant | value | meaning |',
              '|---|---|---|']
    for const, value, doc in joints:
        lines.append(f'| `{const}` | `{value!r}` | {_md_escape(doc)} |')
    return '\n'.join(lines) + '\n'


def _schema_kind(sub: dict[str, Any]) -> str:
    """A field's type as the schema states it: type, enumeration, reference, item type."""
    kind = sub.get('type', '')
    if isinstance(kind, list):
        kind = ' or '.join(kind)
    if 'enum' in sub:
        kind = 'one of ' + ', '.join(f'`{v}`' for v in sub['enum'])
    if '$ref' in sub:
        kind = f'`{sub["$ref"].rsplit("/", 1)[-1]}` (see `$defs`)'
    for key, word in (('items', 'of'), ('additionalProperties', 'name →')):
        inner = sub.get(key)
        if isinstance(inner, dict) and ('$ref' in inner or 'type' in inner):
            kind += f' {word} ' + _schema_kind(inner)
    return str(kind)


def generate_result_schema(_f: Facts) -> str:
    """The JSON result schema page: every field, then the schema itself."""
    schema_path = ROOT / 'gyro_calib' / 'schema' / 'result.schema.json'
    schema = json.loads(schema_path.read_text(encoding='utf-8'))
    lines = ['# JSON result schema (generated)', '', '```{note}',
             'Generated at every build from `gyro_calib/schema/result.schema.json`, the JSON '
             'Schema every `--json` output is validated against (its shape in prose: '
             '[one JSON shape](#one-json-shape)).', '```', '',
             _md_escape(schema.get('description', '')), '', '## Fields', '',
             '| field | type | meaning |', '|---|---|---|']

    def walk(node: dict[str, Any], path: str, depth: int) -> None:
        for name, sub in (node.get('properties') or {}).items():
            kind = _schema_kind(sub)
            lines.append(f'| `{path}{name}` | {kind} | '
                         f'{_md_escape(" ".join(str(sub.get("description", "")).split()))} |')
            if depth < 4:
                walk(sub, f'{path}{name}.', depth + 1)
                for key in ('additionalProperties', 'items'):
                    inner = sub.get(key)
                    if isinstance(inner, dict):
                        walk(inner, f'{path}{name}.{"*" if key != "items" else "[]"}.',
                             depth + 1)
        for name, sub in (node.get('$defs') or node.get('definitions') or {}).items():
            if depth == 0:
                lines.append(f'| `$defs.{name}` | {sub.get("type", "")} | '
                             f'{_md_escape(" ".join(str(sub.get("description", "")).split()))} |')
                walk(sub, f'$defs.{name}.', 1)

    walk(schema, '', 0)
    lines += ['', '## The schema', '', '```{literalinclude} ../../../gyro_calib/schema/'
              'result.schema.json', ':language: json', '```']
    return '\n'.join(lines) + '\n'


PAGES = {'cli.md': generate_cli, 'nodes.md': generate_nodes, 'handoff-keys.md': generate_keys,
         'topics.md': generate_topics, 'result-schema.md': generate_result_schema}


def generate(app: Sphinx) -> None:
    """Write the generated reference pages (a page whose text is unchanged is left).

    Into ``gyro_docs_generated`` (relative to the source directory); ``gyro_docs_pages``
    names the pages to write (default: all of :data:`PAGES`).
    """
    target = Path(app.srcdir) / app.config.gyro_docs_generated
    target.mkdir(parents=True, exist_ok=True)
    f = facts()
    for name, make in PAGES.items():
        if app.config.gyro_docs_pages is not None and name not in app.config.gyro_docs_pages:
            continue
        text = make(f)
        path = target / name
        if not path.exists() or path.read_text(encoding='utf-8') != text:
            path.write_text(text, encoding='utf-8')  # unchanged pages keep their mtime


# --------------------------------------------------------------------------- object types

def _parse(kind: str) -> Any:
    def parse(env: Any, sig: str, signode: addnodes.desc_signature) -> str:
        signode += addnodes.desc_name(sig, sig)
        return sig.strip()
    return parse


def _add_types(app: Sphinx) -> None:
    for kind, label in (('flag', 'command-line flag'), ('param', 'node parameter'),
                        ('key', 'hand-off key'), ('topic', 'topic')):
        app.add_object_type(kind, kind, indextemplate=f'pair: %s; {label}',
                            parse_node=_parse(kind), objname=label)


# ------------------------------------------------------------------------------ the checks

COMMAND = re.compile(r'gyro-calib((?:\s+[^\s`#;&|)]+|\s+\|)*)')
DEMO = re.compile(r'(?:\./run\.sh demo|bench_demo)((?:\s+[^\s`#;&)]+)*)')
FLAG = re.compile(r'(?<![\w-])(--[a-z][a-z0-9-]*)')
ASSIGN = re.compile(r'(?<![\w.])([a-z][\w.]*):=')
INLINE = re.compile(r'(?<!`)`([^`\n]+)`(?!`)')
ROLE = re.compile(r'\{[\w:-]+\}`[^`\n]*`')
BENCHMARK = re.compile(r'benchmarks/\w+\.py')
NOCHECK = '<!-- not a name -->'
"""A line holding this comment is not checked: it shows a name that does not exist on purpose
(``--lat`` is refused, not taken for ``--latitude-deg``)."""


def problems(text: str, f: Facts) -> list[tuple[int, str]]:
    """(line, what is wrong) for every flag, parameter or key ``text`` names that is not there."""
    out: list[tuple[int, str]] = []
    fenced = False
    nodes_ = set(f.params) if ':=' in text else set()
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith('```'):
            fenced = not fenced
            continue
        if NOCHECK in line:
            continue
        spans = [line] if fenced else INLINE.findall(ROLE.sub('', line))  # roles: by Sphinx
        scripts = ''.join((ROOT / b).read_text(encoding='utf-8')
                          for b in set(BENCHMARK.findall(line)) if (ROOT / b).is_file())
        for span in spans:
            out += [(number, w) for w in _span_problems(span, f, nodes_, fenced, scripts)]
    return out


def _span_problems(span: str, f: Facts, nodes_: set[str], fenced: bool,
                   scripts: str) -> list[str]:
    """What ``span`` (a code line, or one inline literal) names that does not exist.

    ``scripts`` is the source of the benchmark scripts its line names: their flags are
    looked up there.
    """
    found: list[str] = []
    code = span.split(' # ', 1)[0] if fenced else span
    seen_flags: set[str] = set()
    for m in COMMAND.finditer(code):
        words = m.group(1).split()
        sub = words[0] if words and words[0] in f.flags and words[0] != 'demo' else ''
        for w in words:
            for flag in FLAG.findall(w):
                seen_flags.add(flag)
                if flag not in f.flags[sub] and flag not in ('--no-progress',):
                    found.append(f'gyro-calib {sub or ""} has no flag {flag}'.replace('  ', ' '))
    for m in DEMO.finditer(code):
        for flag in FLAG.findall(m.group(1)):
            seen_flags.add(flag)
            if flag not in f.flags['demo'] and flag not in RUN_SH_FLAGS:
                found.append(f'./run.sh demo (bench_demo) has no flag {flag}')
    for m in re.finditer(r'benchmarks/\w+\.py((?:\s+[^\s`#;&)]+)*)', code):
        for flag in FLAG.findall(m.group(1)):
            seen_flags.add(flag)
            if f"'{flag}'" not in scripts:
                found.append(f'{m.group(0).split()[0]} has no flag {flag}')
    words = code.split()
    node = next((w for w in words if w in nodes_), None)
    if node and ('--ros-args' in words or 'run' in words):
        for name in ASSIGN.findall(code):
            if not name.startswith('_') and name not in f.params[node]:
                found.append(f'node {node} declares no parameter {name}')
    else:
        for name in ASSIGN.findall(code):
            if not name.startswith('_') and name not in f.all_params:
                found.append(f'no node declares a parameter {name}')
    if not fenced:
        alone = re.fullmatch(r'(--[a-z][a-z0-9-]*)(?:[ =][^`]*)?', span.strip())
        if (alone and alone.group(1) not in seen_flags and alone.group(1) not in f.all_flags
                and f"'{alone.group(1)}'" not in scripts):
            found.append(f'no command has a flag {alone.group(1)}')
        name = span.strip()
        if re.fullmatch(r'[a-z][a-z0-9]*(?:_[a-z0-9]+)+', name) and UNIT_SUFFIX.search(name):
            base = re.sub(r'_(std|dof)$', '', name)
            known = (name in f.keys or base in f.keys or name in f.all_params
                     or _imu_key(base, f) or name in f.code
                     or name.replace('_std_uncertainty', '') in f.code)
            if not known:
                found.append(f'`{name}` is no hand-off key, node parameter or name in the code')
    return found


def _imu_key(name: str, f: Facts) -> bool:
    return any(name == re.sub(r'_[xyz]_', '_x_', k, count=1) for k in f.keys
               if k.startswith('imu_')) if name.startswith('imu_') else False


def check_source(app: Sphinx, docname: str, source: list[str]) -> None:
    """Warn (an error under -W) for every name the page gives that does not exist."""
    if docname.startswith(app.config.gyro_docs_generated.rstrip('/') + '/'):
        return
    for number, what in problems(source[0], facts()):
        logger.warning(f'{what} [gyro_docs.name]', location=(docname, number))


def setup(app: Sphinx) -> dict[str, Any]:
    """Register the object types and roles, the generator and the checks."""
    _add_types(app)
    app.add_config_value('gyro_docs_generated', 'reference/generated', 'env')
    app.add_config_value('gyro_docs_pages', None, 'env')
    app.connect('builder-inited', generate)
    app.connect('source-read', check_source)
    return {'version': '1', 'parallel_read_safe': True, 'parallel_write_safe': True}
