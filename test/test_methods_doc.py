"""Every method citation in the project resolves into docs/methods.md (issue 17 item 14).

docs/methods.md is the index of one page per method, docs/methods/<name>.md (issue 39): a
citation ``docs/methods.md §C.4 eq. (12)`` resolves into the page whose heading is ``# §C``.

The code, the README, the CLI output and the figures cite the method documentation as
``docs/methods.md §A.2 eq. (3)`` (docstrings: ``METHODS §A.2 eq. 3``). A citation is a
contract with the reader: the section (``§A``), the subsection (``§A.2``) and each equation
number it names must exist in the document. Inside a method's own package a bare
``eq. (N)`` means that method's section; one naming a paper or a standard (``seed 001
eqs. 8–10``, ``NIST SP 1065 eq. 11``) is not a citation of the document.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / 'docs' / 'methods.md'
PAGES = sorted((ROOT / 'docs' / 'methods').glob('*.md'))
"""One page per method; DOC is their index (what every page shares, the references)."""
SOURCES = ('gyro_calib', 'sim_nodes', 'benchmarks', 'test')
PACKAGE_SECTION = {'rbrlg': 'A', 'fog': 'B', 'dither': 'C', 'thermal': 'D', 'noise': 'E',
                   'triad': 'F', 'multiposition': 'G'}

NUMBER = r'\(?\d+[a-z]?\)?'
SEPARATOR = r'\s*(?:,|–|-|\+|/|and)\s*'
EQUATIONS = re.compile(rf'eqs?\.\s*({NUMBER}(?:{SEPARATOR}{NUMBER})*)')
CITATION = re.compile(r'§([A-G])(?:\.(\d+)(?:[–-](?:[A-G]\.)?(\d+))?)?')
EXTERNAL = re.compile(r'(seed \d+|paper|NIST|SP 1065|IEEE|Std|GUM|Annex)[^.;]{0,12}$')
TAG = re.compile(r'\((\d+[a-z]?)\)\s*$')


def parse_doc(text: str) -> tuple[set[str], dict[str, set[str]]]:
    """(anchors, section letter → equation tags) of the document.

    Anchors are the MyST targets ``(A.2)=`` (and ``<a id="…">``, as the single file had);
    an equation is a line inside a fenced block of a ``# §X`` page (or ``## §X`` section)
    ending with its tag ``(N)`` or ``(Na)``. A tag used twice in one section is an error.
    """
    anchors = set(re.findall(r'<a id="([^"]+)"></a>', text))
    anchors |= set(re.findall(r'^\(([^)\s]+)\)=$', text, re.M))
    equations: dict[str, set[str]] = {}
    section, fenced = None, False
    for line in text.splitlines():
        head = re.match(r'##? §([A-G]) ', line)
        if head:
            section = head.group(1)
            equations.setdefault(section, set())
        elif not fenced and (line.startswith('# ') or
                             (line.startswith('## ') and not line.startswith('## §'))):
            section = None
        if line.lstrip().startswith('```'):
            fenced = not fenced
            continue
        tag = TAG.search(line)
        if fenced and section and tag:
            assert tag.group(1) not in equations[section], \
                f'§{section} eq. ({tag.group(1)}) is numbered twice in {DOC.name}'
            equations[section].add(tag.group(1))
    return anchors, equations


DOC_TEXT = '\n'.join(p.read_text(encoding='utf-8') for p in [DOC, *PAGES])
ANCHORS, EQUATIONS_BY_SECTION = parse_doc(DOC_TEXT)


def expand(numbers: str) -> list[str]:
    """Equation numbers of a cited list: ``(19)–(20)`` → 19, 20; ``14/17`` → 14, 17."""
    out: list[str] = []
    parts = re.split(rf'({SEPARATOR})', numbers)
    tags = [p.strip('()') for p in parts[::2]]
    seps = [p.strip() for p in parts[1::2]]
    for i, tag in enumerate(tags):
        if i and seps[i - 1] in ('–', '-') and tag.isdigit() and tags[i - 1].isdigit():
            out.extend(str(n) for n in range(int(tags[i - 1]) + 1, int(tag)))
        out.append(tag)
    return out


def project_files() -> list[Path]:
    files = [ROOT / 'README.md', ROOT / 'run.sh'] + sorted(
        p for p in (ROOT / 'docs').rglob('*.md')
        if not {'generated', '_build'} & set(p.relative_to(ROOT / 'docs').parts))
    for top in SOURCES:
        files.extend(sorted((ROOT / top).rglob('*.py')))
    return [f for f in files if f.is_file()]


def citations() -> list[tuple[str, str, str | None, list[str]]]:
    """(where, section, subsection or None, equation tags) of every § citation."""
    found = []
    for path in project_files():
        text = path.read_text(encoding='utf-8')
        rel = path.relative_to(ROOT).as_posix()
        for m in CITATION.finditer(text):
            line = text.count('\n', 0, m.start()) + 1
            tail = re.match(rf'[\s,]*{EQUATIONS.pattern}', text[m.end():])
            tags = expand(tail.group(1)) if tail else []
            subsections = [s for s in (m.group(2), m.group(3)) if s]
            for sub in subsections or [None]:
                found.append((f'{rel}:{line} {m.group(0)}', m.group(1), sub, tags))
    return found


def bare_citations() -> list[tuple[str, str, list[str]]]:
    """(where, section, equation tags) of ``eq. (N)`` without § inside a method package."""
    found = []
    for name, section in PACKAGE_SECTION.items():
        for path in sorted((ROOT / 'gyro_calib' / name).rglob('*.py')):
            text = path.read_text(encoding='utf-8')
            for m in EQUATIONS.finditer(text):
                before = text[max(0, m.start() - 40):m.start()]
                if EXTERNAL.search(before) or '§' in before[-25:]:
                    continue
                line = text.count('\n', 0, m.start()) + 1
                where = f'{path.relative_to(ROOT).as_posix()}:{line} {m.group(0)}'
                found.append((where, section, expand(m.group(1))))
    return found


CITED = citations()
BARE = bare_citations()


def test_the_document_has_every_method_and_its_equations() -> None:
    assert len(PAGES) >= 7
    for page in PAGES:  # the index lists every page (in its table and its toctree)
        assert f'methods/{page.stem}' in DOC.read_text(encoding='utf-8'), page.name
    assert set(EQUATIONS_BY_SECTION) == set('ABCDEFG')
    for section, tags in EQUATIONS_BY_SECTION.items():
        assert section in ANCHORS
        assert len(tags) >= 10, f'§{section} numbers only {sorted(tags)}'
    # the numbers the code cited before the document existed (paper numbering) stay valid
    for section, tags in {'A': '1 2 3 4 5 10 15 16 17 18 19 20 21', 'C': '24',
                          'D': '2 14 17'}.items():
        assert set(tags.split()) <= EQUATIONS_BY_SECTION[section], section


def test_the_scan_finds_the_citations() -> None:
    """The parsers see what they must: a scan that finds nothing would pass vacuously."""
    assert len(CITED) > 150
    assert any(tags for *_, tags in CITED)
    assert len(BARE) > 20
    assert expand('(19)–(20)') == ['19', '20']
    assert expand('15–17') == ['15', '16', '17']
    assert expand('14/17') == ['14', '17']
    assert expand('1 + 2') == ['1', '2']


@pytest.mark.parametrize('where, section, sub, tags', CITED, ids=[c[0] for c in CITED])
def test_every_section_citation_resolves(where: str, section: str, sub: str | None,
                                         tags: list[str]) -> None:
    assert section in ANCHORS, f'{where}: no §{section} in {DOC.name}'
    if sub is not None:
        assert f'{section}.{sub}' in ANCHORS, f'{where}: no §{section}.{sub} in {DOC.name}'
    for tag in tags:
        assert tag in EQUATIONS_BY_SECTION[section], \
            f'{where}: §{section} has no eq. ({tag}) in {DOC.name}'


@pytest.mark.parametrize('where, section, tags', BARE, ids=[c[0] for c in BARE])
def test_every_bare_equation_in_a_method_package_resolves(where: str, section: str,
                                                          tags: list[str]) -> None:
    for tag in tags:
        assert tag in EQUATIONS_BY_SECTION[section], \
            f'{where}: §{section} has no eq. ({tag}) in {DOC.name}'


def test_every_file_and_name_the_document_points_to_exists() -> None:
    """Every file and name the document points to exists.

    A path or a setting/function name in backticks is a pointer into the code: it must
    not outlive a rename.
    """
    text = DOC_TEXT
    paths = set(re.findall(r'`((?:gyro_calib|sim_nodes|benchmarks|test)/[\w/]*(?:\.py)?)`', text))
    assert len(paths) > 10
    for path in sorted(paths):
        assert (ROOT / path).exists(), f'{DOC.name} points to {path}, which does not exist'
    code = '\n'.join(p.read_text(encoding='utf-8') for p in (ROOT / 'gyro_calib').rglob('*.py'))
    names = set(re.findall(r'`([A-Za-z_]\w*_\w*)(?::[^`]*)?`', text))
    assert len(names) > 30
    for name in sorted(names):
        assert name in code, f'{DOC.name} names `{name}`, which the code does not have'


def test_the_readme_links_the_document() -> None:
    readme = (ROOT / 'README.md').read_text(encoding='utf-8')
    assert '(docs/methods.md)' in readme
    assert 'METHODS §' not in readme, 'the README cites docs/methods.md, not METHODS'
