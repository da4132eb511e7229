"""The documentation site builds, with warnings as errors, and names nothing that does not exist.

Issue 39: ``./run.sh docs`` builds the Sphinx + MyST site under docs/ with ``-W -n``
(warnings are errors, every cross-reference must resolve). What is checked here:

- the whole site builds from the sources alone (the reference pages are generated from the
  code during the build) with no warning, and has the pages the README links to;
- every internal link of the built HTML reaches a page that exists, and its ``#anchor``
  an element of that page (a link check independent of the one MyST makes);
- a page naming a flag, a node parameter or a hand-off key the code does not have fails
  the build: through the roles (``{flag}`…```) and through plain Markdown (the checks of
  ``docs/_ext/gyro_docs.py``), each shown to fail on a name that does not exist;
- the methods' figures shown on the site are exactly what ``docs/make_figures.py`` draws.
"""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / 'docs'
sys.path.insert(0, str(DOCS / '_ext'))

import gyro_docs  # noqa: E402


def sphinx(source: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    """``sphinx-build -W --keep-going -n -b html`` as ``./run.sh docs`` runs it."""
    return subprocess.run(
        [sys.executable, '-m', 'sphinx', '-W', '--keep-going', '-n', '-q', '-b', 'html',
         '-d', str(out / '.doctrees'), *extra, str(source), str(out)],
        capture_output=True, text=True, timeout=300, cwd=ROOT)


@pytest.fixture(scope='module')
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('site')
    done = sphinx(DOCS, out)
    assert done.returncode == 0 and 'WARNING' not in done.stderr, done.stderr
    return out


def test_run_sh_docs_builds_the_site_as_this_test_does() -> None:
    text = (ROOT / 'run.sh').read_text(encoding='utf-8')
    assert re.search(r'docs\) .*\n.*-m sphinx -W --keep-going -n .*-b html docs docs/_build/html',
                     text), 'run.sh docs'


def test_the_site_builds_without_a_warning_and_has_every_page(site: Path) -> None:
    pages = {p.relative_to(site).as_posix() for p in site.rglob('*.html')}
    for page in ('index.html', 'methods.html', 'methods/rbrlg.html', 'methods/figures.html',
                 'tutorials/rlg-bench.html', 'reference/generated/cli.html',
                 'reference/generated/nodes.html', 'reference/generated/handoff-keys.html',
                 'reference/generated/topics.html', 'reference/generated/result-schema.html'):
        assert page in pages, page
    sources = {p.relative_to(DOCS).with_suffix('.html').as_posix() for p in DOCS.rglob('*.md')
               if '_build' not in p.parts}
    assert sources <= pages, sorted(sources - pages)
    readme = (ROOT / 'README.md').read_text(encoding='utf-8')
    for link in re.findall(r'\]\((docs/[^)#]+\.md)', readme):
        assert (ROOT / link).is_file(), link
        assert link.removeprefix('docs/').replace('.md', '.html') in pages, link


def test_every_internal_link_of_the_site_resolves(site: Path) -> None:
    ids: dict[Path, set[str]] = {}
    checked = 0
    for page in sorted(site.rglob('*.html')):
        html = page.read_text(encoding='utf-8')
        for href in re.findall(r'href="([^"]+)"', html):
            parts = urlsplit(href)
            if parts.scheme or parts.netloc or href.startswith('mailto:'):
                continue
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / 'index.html'
            assert target.is_file(), f'{page.relative_to(site)}: link {href} has no page'
            if parts.fragment and target.suffix == '.html':
                if target not in ids:
                    ids[target] = set(re.findall(r'\bid="([^"]+)"',
                                                 target.read_text(encoding='utf-8')))
                assert unquote(parts.fragment) in ids[target], \
                    f'{page.relative_to(site)}: link {href}: no such anchor'
            checked += 1
    assert checked > 1000


def test_the_generated_reference_lists_every_flag_parameter_key_and_topic(site: Path) -> None:
    facts = gyro_docs.facts()
    cli = (site / 'reference/generated/cli.html').read_text(encoding='utf-8')
    for name, parser in facts.parsers.items():
        for action in parser._actions:
            longs = [s for s in action.option_strings if s.startswith('--')]
            if longs and longs[0] != '--help':
                anchor = f'flag-{name or "gyro-calib"}-{longs[0].lstrip("-")}'
                assert f'id="{anchor}"' in cli, (name, longs[0])
    nodes = (site / 'reference/generated/nodes.html').read_text(encoding='utf-8')
    for node, info in facts.nodes.items():
        for param in info['parameters']:
            assert f'id="param-{node}.{param["name"]}"' in nodes, (node, param['name'])
    keys = (site / 'reference/generated/handoff-keys.html').read_text(encoding='utf-8')
    for key in facts.keys:
        assert f'id="key-{key}"' in keys, key
    topics = (site / 'reference/generated/topics.html').read_text(encoding='utf-8')
    for _, value, _ in gyro_docs.contract_topics():
        if isinstance(value, str) and value.startswith('/'):
            assert value in topics, value


PAGE_WITH_MISTAKES = '''# Mistakes

```bash
gyro-calib calibrate bags/x --out gyro.yaml --no-such-flag
gyro-calib info bags/x --kalibr imu.yaml
calibration_node --ros-args -p output_file:=gyro.yaml -p no_such_parameter:=1
```

Plain text: `--not-a-flag`, `bogus_bias_rad_s`, `k_tilde_rad_per_pulse_std`, `--out FILE`,
`-p latitude_deg:=28.2`, `-p not_declared_anywhere:=3`.
'''


def test_the_plain_markdown_checks_name_each_mistake_and_nothing_else() -> None:
    found = [what for _, what in gyro_docs.problems(PAGE_WITH_MISTAKES, gyro_docs.facts())]
    assert found == [
        'gyro-calib calibrate has no flag --no-such-flag',
        'gyro-calib info has no flag --kalibr',
        'node calibration_node declares no parameter no_such_parameter',
        'no command has a flag --not-a-flag',
        '`bogus_bias_rad_s` is no hand-off key, node parameter or name in the code',
        'no node declares a parameter not_declared_anywhere',
    ], found


def test_a_page_naming_what_does_not_exist_fails_the_build(tmp_path: Path) -> None:
    """A small site with the same extension and one page of right and wrong names.

    The build fails; each wrong name (three roles, a plain-text flag) is named in a warning,
    and none of the right ones (one role of each kind) is.
    """
    src = tmp_path / 'src'
    (src / '_ext').mkdir(parents=True)
    shutil.copy(DOCS / 'conf.py', src / 'conf.py')
    with (src / 'conf.py').open('a', encoding='utf-8') as conf:
        conf.write(f"\nsys.path.insert(0, {str(DOCS / '_ext')!r})\n"
                   "gyro_docs_pages = ['cli.md', 'handoff-keys.md', 'topics.md']\n")
    (src / 'index.md').write_text(
        '# Test\n\n```{toctree}\nreference/generated/cli\nreference/generated/handoff-keys\n'
        'reference/generated/topics\nhandoff\npage\n```\n', encoding='utf-8')
    (src / 'handoff.md').write_text('(handoff-file)=\n# Hand-off\n\n(one-json-shape)=\n## JSON\n\n'
                                    '(topic-contract-prose)=\n## Topics\n', encoding='utf-8')
    (src / 'page.md').write_text(
        '# Page\n\n{flag}`calibrate --out`, {key}`k_tilde_rad_per_pulse`, {topic}`/gyro/pulses`,'
        ' {flag}`gyro-calib --version`.\n\n{flag}`calibrate --nope`, {key}`no_such_key_rad`, '
        '{topic}`/no/topic`; `gyro-calib noise BAG --lat 3`.\n', encoding='utf-8')
    done = sphinx(src, tmp_path / 'out')
    assert done.returncode != 0
    warnings = [ln for ln in done.stderr.splitlines() if 'WARNING' in ln]
    for name in ('calibrate --nope', 'no_such_key_rad', '/no/topic', 'no flag --lat'):
        assert any(name in w for w in warnings), (name, done.stderr)
    assert len(warnings) == 4, done.stderr


def test_the_figures_page_shows_what_make_figures_draws() -> None:
    page = (DOCS / 'methods' / 'figures.md').read_text(encoding='utf-8')
    shown = set(re.findall(r'```\{figure\} figures/([\w.-]+\.png)', page))
    committed = {p.name for p in (DOCS / 'methods' / 'figures').glob('*.png')}
    assert shown == committed and len(shown) >= 12
    # every figure name the plotting code writes, for a method with a run in make_figures.py
    source = (DOCS / 'make_figures.py').read_text(encoding='utf-8')
    runs = ast.literal_eval(re.search(r'RUNS: list\[list\[str\]\] = (\[.*?\n\])', source,
                                      re.S).group(1))
    assert len(runs) >= 6
    code = '\n'.join(p.read_text(encoding='utf-8') for p in (ROOT / 'gyro_calib').rglob('*.py'))
    for name in committed:
        stem = re.sub(r'_[yz]$', '_{axis}', name.removesuffix('.png'))
        assert f"{stem}.png'" in code or f"'{name}'" in code, name


def test_the_readme_is_short_and_says_what_a_newcomer_needs() -> None:
    """The README is at most ~200 lines and holds what issue 39 lists.

    What it is, the two commands, a path per kind of user, the documentation, the ROS 2
    distributions, the licence; the rest lives in docs/.
    """
    readme = (ROOT / 'README.md').read_text(encoding='utf-8')
    assert len(readme.splitlines()) <= 200
    for heading in ('## Two commands', '## Where to start', '## Documentation',
                    '## Supported ROS 2 distributions', '## Licence'):
        assert f'\n{heading}\n' in readme, heading
    for words in ('./run.sh demo', './run.sh test', './run.sh docs', 'Kilted', 'Jazzy',
                  'Apache', 'docs/tutorials/', 'docs/reference/'):
        assert words in readme, words
    from gyro_calib.registry import METHODS

    for method in METHODS:
        assert f'| `{method}` |' in readme, method
