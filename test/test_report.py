"""The calibration certificate (``gyro-calib report``, ``calibrate --report``), as a lab reads it.

For every committed scenario bag the certificate shows every quantity of the hand-off file
with the hand-off's value and standard uncertainty (checked from the HTML's printed numbers,
to the digit they are rounded at), k for 95 % from the estimator's degrees of freedom (Student
t, computed here with scipy), U = k·u, and the count n; one bag per method also carries every
figure the method draws. Verdicts under a spec follow the decision rule (PASS, FAIL and
CONDITIONAL are all exercised); without a spec the certificate says it states none. The HTML
is self-contained (no external resource, no script); headless Chromium renders it to a
non-blank PNG without a console message; the PDF's text holds the printed values. Bad input
(missing hand-off, bad spec) is one line, exit 2, nothing written.
"""

from __future__ import annotations

import base64
import functools
import math
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest
import scipy.stats
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.cli import main
from gyro_calib.handoff import Calibration, load_calibration
from gyro_calib.registry import handoff_schema
from gyro_calib.report.certificate import build_certificate, render_html, render_pdf
from gyro_calib.report.evidence import RunEvidence, evidence_from_outcome
from gyro_calib.report.spec import (
    CONDITIONAL,
    FAIL,
    PASS,
    Limit,
    load_spec,
    spec_from_dict,
    verdict,
)
from gyro_calib.report.units import user_unit
from gyro_calib.session import CalibrationOptions

ONE_SIGMA = 0.8413447460685429
"""P(z < 1): the Student t a scatter of few repetitions is widened by (docs/methods.md)."""

BAGS = Path(__file__).resolve().parent.parent / 'bags'
SCENARIO_BAGS = sorted(p.name for p in BAGS.iterdir()
                       if p.is_dir() and not p.name.startswith(('triad_', 'multiposition_')))
"""Every committed bag of one gyro (a triad's certificate: test/test_certificate_imu.py; a MEMS
IMU's multiposition bags calibrate only when asked, ``--method multiposition``)."""
WITH_FIGURES = {'k_tilde_bench', 'theta_four_position', 'fog_mapping_self_cal', 'dither_z',
                'thermal_validation', 'noise_rlg_static'}
"""One bag per method (two for the RBRLG: K̃ alone, K̃ + θ) is drawn with its figures; the
figures are the methods' own (``--plot``), the values are the same with or without."""
NOTHING_MEASURED = {'dither_stripped'}
"""Bags from which no method measures a hand-off value (no certificate: exit 1 in calibrate)."""


def _methods(name: str) -> list[str] | None:
    return ['noise'] if name.startswith('noise') else None


@functools.cache
def _run(name: str) -> tuple[Calibration | None, RunEvidence]:
    options = CalibrationOptions(gyro_id=f'G-{name}')
    outcome = calibrate_bags([BAGS / name], methods=_methods(name), options=options)
    record = None
    for session in outcome.sessions.values():
        part = session.handoff(outcome.source, gyro_id=options.gyro_id)
        if part is not None:
            record = part if record is None else part.merged_into(record, handoff_schema())
    return record, evidence_from_outcome(outcome, options, figures=name in WITH_FIGURES)


class _Page(HTMLParser):
    """Rows, cells, figures, links and scripts of a certificate."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: dict[str, dict[str, Any]] = {}
        self.figures: list[str] = []
        self.images: list[str] = []
        self.external: list[str] = []
        self.scripts = 0
        self.text: list[str] = []
        self._row: dict[str, Any] | None = None
        self._cell: str | None = None
        self._relative: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        for name in ('src', 'href'):
            url = a.get(name) or ''
            if url and not url.startswith(('data:', '#')):
                self.external.append(url)
        if tag == 'script':
            self.scripts += 1
        if tag == 'link':
            self.external.append(str(a))
        if tag == 'tr' and 'quantity' in (a.get('class') or ''):
            self._row = {'value_si': float(a['data-value-si'] or 'nan'),
                         'std_si': float(a['data-std-si'] or 'nan'), 'cells': []}
            self.rows[a['data-key'] or ''] = self._row
        if tag == 'td' and self._row is not None:
            self._cell = ''
        if tag == 'span' and 'rel' in (a.get('class') or '').split() and self._row is not None:
            self._relative = ''  # the relative u under u (scale factors): kept apart
        if tag == 'figure':
            self.figures.append(a.get('data-figure') or '')
        if tag == 'img':
            self.images.append(a.get('src') or '')

    def handle_endtag(self, tag: str) -> None:
        if tag == 'span' and self._relative is not None and self._row is not None:
            self._row['relative'] = self._relative.strip()
            self._relative = None
        if tag == 'td' and self._row is not None and self._cell is not None:
            self._row['cells'].append(self._cell.strip())
            self._cell = None
        if tag == 'tr':
            self._row = None

    def handle_data(self, data: str) -> None:
        self.text.append(data)
        if self._relative is not None:
            self._relative += data
        elif self._cell is not None:
            self._cell += data


def _page(html: str) -> _Page:
    page = _Page()
    page.feed(html)
    page.close()
    return page


def _decimals(text: str) -> int:
    return len(text.split('.')[1]) if '.' in text and 'e' not in text else 0


def _half_digit(text: str) -> float:
    """Half a unit of the last printed digit of ``text`` (fixed or e-notation)."""
    if 'e' in text:
        mantissa, exponent = text.split('e')
        places = len(mantissa.split('.')[1]) if '.' in mantissa else 0
        return 0.5 * 10.0 ** (int(exponent) - places)
    return 0.5 * 10.0 ** -_decimals(text)


@pytest.mark.parametrize('name', SCENARIO_BAGS)
def test_certificate_of_each_committed_bag_holds_the_hand_off_values_k_and_U(name: str) -> None:
    record, evidence = _run(name)
    if name in NOTHING_MEASURED:
        assert record is None
        return
    assert record is not None, f'{name} measured nothing: list it in NOTHING_MEASURED'
    cert = build_certificate(record, evidence, handoff_path=f'{name}.yaml')
    page = _page(render_html(cert))
    estimates = {k: e for m in evidence.methods for k, e in m.estimates.items()}
    uncertain = [k for k in record.values if k + '_std' in record.values]
    assert uncertain and set(uncertain) <= set(page.rows)
    for key in uncertain:
        row = page.rows[key]
        value, std = record.values[key], record.values[key + '_std']
        assert row['value_si'] == value and row['std_si'] == std  # exactly the hand-off's
        shown_value, shown_std, unit, n, dof, k, expanded = row['cells'][1:8]
        factor = user_unit(key).factor
        assert unit == (user_unit(key).label or user_unit(key).si)
        half_digit = 0.5 * 10.0 ** -_decimals(shown_value)
        assert abs(float(shown_value) - value * factor) <= half_digit * (1 + 1e-9)
        assert abs(float(shown_std) - std * factor) <= _half_digit(shown_std) * 1.001
        assert len(shown_std) <= 8  # 3.4e-9, not 0.0000000034
        est = estimates[key]  # the bag's own estimate: its dof give k
        assert int(n) == est.n_used
        assert dof in ('∞', '> 1000') or (len(dof) <= 4 and float(dof) <= est.n_used - 1)
        nu = min(est.dof, est.n_used - 1)  # ν: never more than the n measurements support
        k95 = float(scipy.stats.t.ppf(0.975, nu)) if nu >= 1 else math.nan
        if name.startswith('dither') and key.startswith('dither_misalignment'):
            assert dof != '—'  # Welch–Satterthwaite over statistical + rocking
            k95 = float(scipy.stats.t.ppf(0.975, float(dof)))
        widened = re.search(r'× Student t [0-9.]+ \((\d+) dof\)', est.basis)
        if widened:  # u = t₀.₈₄₁₃(ν)·s/√n: U = t₀.₉₇₅(ν)·s/√n, k = U/u (GUM G.3)
            k95 /= float(scipy.stats.t.ppf(ONE_SIGMA, int(widened.group(1))))
        assert float(k) == pytest.approx(k95, abs=0.006)
        assert float(expanded) == pytest.approx(float(k) * std * factor, rel=0.02,
                                                abs=2 * half_digit)
    for key, value in record.values.items():  # counts and mappings are on it too
        if key not in uncertain and not key.endswith(('_std', '_dof')):
            assert key in ''.join(page.text)
    assert not page.external and page.scripts == 0, 'the certificate must be self-contained'
    drawn = [f.name for m in evidence.methods for f in m.figures]
    assert page.figures == drawn
    if name in WITH_FIGURES:
        assert drawn, f'{name}: the method drew no figure'
    for src in page.images:
        assert base64.b64decode(src.split(',', 1)[1])[:8] == b'\x89PNG\r\n\x1a\n'
    for section in evidence.methods:  # what was not measured, and each rejection, is there
        for key in section.missing:
            if key not in record.values:
                assert key in ''.join(page.text)
        assert f'Rejections: {len(section.rejections)}' in ''.join(page.text)


def test_verdicts_follow_the_decision_rule() -> None:
    limit = Limit('x', '°/h', -1.0, 1.0)
    assert verdict(limit, 0.0, 0.4, None, 'guarded_k2') == PASS       # ±0.8 inside
    assert verdict(limit, 0.5, 0.4, None, 'guarded_k2') == CONDITIONAL  # 1.3 crosses
    assert verdict(limit, 2.0, 0.4, None, 'guarded_k2') == FAIL       # 1.2 … 2.8 outside
    assert verdict(limit, 0.5, 0.4, 0.3, 'guarded_k95') == PASS       # ±U = 0.3 inside
    assert verdict(limit, 0.9, 5.0, None, 'simple') == PASS
    assert verdict(Limit('x', '′', None, 5.0), 4.0, 1.0, None, 'guarded_k2') == CONDITIONAL


def test_certificate_verdicts_under_a_spec_pass_fail_conditional_and_the_unit() -> None:
    record, evidence = _run('k_tilde_bench')
    assert record is not None
    k_tilde = record.values['k_tilde_rad_per_pulse'] * user_unit('k_tilde_rad_per_pulse').factor
    bias = record.values['bias_rad_s'] * user_unit('bias_rad_s').factor
    u_bias = record.values['bias_rad_s_std'] * user_unit('bias_rad_s').factor
    spec = spec_from_dict({'quantities': {
        'k_tilde_rad_per_pulse': {'unit': '″/pulse', 'min': k_tilde - 1e-6, 'max': k_tilde + 1e-6},
        'bias_rad_s': {'unit': '°/h', 'max': bias + u_bias},  # value inside, 2u across
        'bias_plus_earth_rate_rad_s': {'max': 0.0},            # far outside
        'fog_bias_rad_s': {'max': 1.0},                        # method did not run
    }})
    cert = build_certificate(record, evidence, spec)
    verdicts = {r.key: r.verdict for r in cert.rows if r.verdict}
    assert verdicts == {'k_tilde_rad_per_pulse': PASS, 'bias_rad_s': CONDITIONAL,
                        'bias_plus_earth_rate_rad_s': FAIL}
    assert cert.overall == FAIL
    assert any('fog_bias_rad_s' in s and 'not applicable' in s for s in cert.spec_missing)
    del spec.limits['bias_plus_earth_rate_rad_s']
    assert build_certificate(record, evidence, spec).overall == CONDITIONAL
    unmeasured = spec_from_dict({'quantities': {'k_tilde_rad_per_pulse': {
        'min': k_tilde - 1e-6, 'max': k_tilde + 1e-6}, 'fix_error_angle_rad': {'max': 1000.0}}})
    cert = build_certificate(record, evidence, unmeasured)  # θ: rbrlg ran, did not measure it
    assert cert.overall == 'NO VERDICT (not measured: fix_error_angle_rad)'
    assert 'NOT MEASURED' in cert.spec_missing[0]
    html = render_html(build_certificate(record, evidence))
    assert 'this certificate states no verdicts' in html
    assert '<span class="verdict' not in html and '<span class="overall' not in html


def test_hand_off_alone_gives_k_from_the_dof_it_states_else_2_said_in_the_row(
        tmp_path: Path) -> None:
    record, evidence = _run('fog_turntable')
    assert record is not None
    cert = build_certificate(record, None)
    with_bags = {r.key: r.k for r in build_certificate(record, evidence).rows if r.in_handoff}
    assert {r.key: r.k for r in cert.rows} == with_bags  # the file's ν: the same k
    assert 'k = 2 is assumed' in cert.evidence_note
    assert {r.key for r in cert.rows} == {k for k in record.values if k + '_std' in record.values}
    older = {k: v for k, v in record.values.items() if not k.endswith('_dof')}
    cert = build_certificate(Calibration(older, record.methods, record.gyro_id), None)
    assert {r.k for r in cert.rows} == {'2.00'}
    assert all('k = 2 assumed' in r.note for r in cert.rows)


def test_hand_off_alone_of_a_noise_run_still_shows_the_curves_it_stores() -> None:
    """Without the bag the noise curves come from the hand-off file's deviations."""
    record, _ = _run('noise_rlg_static')
    assert record is not None and record.methods['noise'].deviations
    page = _Page()
    page.feed(render_html(build_certificate(record, None)))
    assert page.figures == ['stored_deviations']
    png = base64.b64decode(page.images[-1].split(',', 1)[1])
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 10_000
    fog, _ = _run('fog_turntable')  # a method that stores no curves draws nothing
    assert fog is not None
    page = _Page()
    page.feed(render_html(build_certificate(fog, None)))
    assert page.figures == []


def test_values_read_generically_so_added_keys_appear() -> None:
    """A key the hand-off gains later (value with _std, _n, _dof twins) is shown as it is."""
    record, _ = _run('k_tilde_bench')
    assert record is not None
    values = {**record.values, 'future_gain_ppm': 3.0, 'future_gain_ppm_std': 0.5,
              'future_gain_ppm_dof': 4}
    cert = build_certificate(Calibration(values, record.methods, record.gyro_id), None)
    row = next(r for r in cert.rows if r.key == 'future_gain_ppm')
    assert (row.value, row.std, row.unit, row.dof) == ('3.00', '0.50', 'ppm', '4')
    assert float(row.k) == pytest.approx(scipy.stats.t.ppf(0.975, 4), abs=0.006)


def _chromium() -> str:
    for name in ('chromium', 'chromium-browser', 'google-chrome'):
        path = shutil.which(name)
        if path:
            return path
    raise AssertionError('headless Chromium is needed: ./run.sh setup installs Debian\'s '
                         'chromium')


def render_png(html_path: Path, png: Path) -> list[str]:
    """Render ``html_path`` in headless Chromium to ``png``; the console messages it logged."""
    run = subprocess.run(
        [_chromium(), '--headless', '--no-sandbox', '--disable-gpu', '--hide-scrollbars',
         '--no-first-run', '--enable-logging=stderr', '--v=0', f'--screenshot={png}',
         '--window-size=1000,1400', f'--user-data-dir={png.parent / "chromium-profile"}',
         html_path.as_uri()], check=False, capture_output=True, text=True, timeout=120,
        env={**os.environ, 'HOME': str(png.parent)})
    assert png.exists(), run.stderr[-2000:]
    return [line for line in run.stderr.splitlines() if 'CONSOLE' in line]


def _ink_fraction(png: Path) -> float:
    import matplotlib.image

    pixels = matplotlib.image.imread(png)[..., :3]
    return float((pixels.min(axis=2) < 0.9).mean())


def test_certificate_renders_in_headless_chromium_and_its_pdf_holds_the_values(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / 'spec.yaml'
    spec.write_text(yaml.safe_dump({'quantities': {'fog_nonlinearity_ppm': {'max': 20.0}}}),
                    encoding='utf-8')
    handoff = tmp_path / 'F-7.yaml'
    status = main(['calibrate', str(BAGS / 'fog_turntable'), '--gyro-id', 'F-7', '--out',
                   str(handoff), '--report', str(tmp_path / 'cert'), '--spec', str(spec)])
    assert status == 0
    assert 'certificate written' in capsys.readouterr().out
    html_path, pdf_path = tmp_path / 'cert' / 'F-7.html', tmp_path / 'cert' / 'F-7.pdf'
    record = load_calibration(handoff)
    page = _page(html_path.read_text(encoding='utf-8'))
    assert {k for k in record.values if k + '_std' in record.values} <= set(page.rows)
    assert page.rows['fog_nonlinearity_ppm']['cells'][-1] == PASS
    assert page.figures == ['fog_turntable_nonlinearity']
    messages = render_png(html_path, tmp_path / 'cert.png')
    assert messages == [] and _ink_fraction(tmp_path / 'cert.png') > 0.01
    from pypdf import PdfReader

    text = re.sub(r'\s+', '', ''.join(p.extract_text() for p in PdfReader(pdf_path).pages))
    assert 'F-7' in text and 'PASS' in text
    for key, row in page.rows.items():
        assert key in text
        assert row['cells'][1] in text and row['cells'][2] in text  # value and u as printed


def test_the_render_check_sees_a_blank_page_and_a_console_error(tmp_path: Path) -> None:
    page = tmp_path / 'bad.html'
    page.write_text('<!DOCTYPE html><html><body><script>console.error("broken")</script>'
                    '</body></html>', encoding='utf-8')
    messages = render_png(page, tmp_path / 'bad.png')
    assert any('broken' in m for m in messages)
    assert _ink_fraction(tmp_path / 'bad.png') < 0.01


def test_pdf_renders_from_the_html_alone() -> None:
    record, evidence = _run('theta_four_position')
    assert record is not None
    pdf = render_pdf(render_html(build_certificate(record, evidence)))
    assert pdf[:5] == b'%PDF-' and len(pdf) > 10_000


@pytest.mark.parametrize('case', ['missing handoff', 'bad spec', 'spec without report',
                                  'unit mismatch'])
def test_report_bad_input_is_one_line_exit_2_nothing_written(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    record, _ = _run('k_tilde_bench')
    assert record is not None
    from gyro_calib.handoff import write_calibration

    handoff = write_calibration(tmp_path / 'h.yaml', record)
    spec = tmp_path / 'spec.yaml'
    out = tmp_path / 'out'
    if case == 'missing handoff':
        argv = ['report', str(tmp_path / 'nope.yaml'), '--out', str(out)]
    elif case == 'bad spec':
        spec.write_text('quantities: {bias_rad_s: {min: 2.0, max: 1.0}}\n', encoding='utf-8')
        argv = ['report', str(handoff), '--out', str(out), '--spec', str(spec)]
    elif case == 'unit mismatch':
        spec.write_text('quantities: {bias_rad_s: {unit: rad/s, max: 1.0}}\n', encoding='utf-8')
        argv = ['report', str(handoff), '--out', str(out), '--spec', str(spec)]
    else:
        spec.write_text('quantities: {bias_rad_s: {max: 1.0}}\n', encoding='utf-8')
        argv = ['calibrate', str(BAGS / 'k_tilde_bench'), '--spec', str(spec)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    assert len(captured.err.strip().splitlines()) == 1
    assert captured.err.startswith('gyro-calib: error:')
    assert not out.exists()


def test_spec_file_loads_with_units_and_rule(tmp_path: Path) -> None:
    path = tmp_path / 'spec.yaml'
    path.write_text('decision_rule: simple\nquantities:\n'
                    '  dither_axis_misalignment_rad: {unit: ′, max: 5.0}\n', encoding='utf-8')
    spec = load_spec(path)
    assert spec.rule == 'simple'
    assert spec.limits['dither_axis_misalignment_rad'].text() == '≤ 5 ′'


def test_report_and_batch_are_front_doors_nothing_below_imports_them() -> None:
    """Report and batch are front doors: nothing below imports them.

    Data flows one way: bag I/O → sessions → methods → registry → front doors. Only the CLI
    (a front door too) and the two packages themselves import gyro_calib.report / .batch, and
    the certificate never imports the fleet.
    """
    import ast

    root = Path(__file__).resolve().parent.parent
    offenders = []
    for path in sorted((root / 'gyro_calib').rglob('*.py')) + sorted(
            (root / 'sim_nodes').rglob('*.py')):
        rel = path.relative_to(root).as_posix()
        imported: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.ImportFrom) and node.module:
                imported.add(node.module)
            elif isinstance(node, ast.Import):
                imported.update(a.name for a in node.names)
        text = path.read_text(encoding='utf-8')
        uses = {m for m in ('gyro_calib.report', 'gyro_calib.batch')
                if any(i == m or i.startswith(m + '.') for i in imported) or f"'{m}." in text}
        if rel.startswith(('gyro_calib/batch/', 'gyro_calib/cli/')):
            continue
        if rel.startswith('gyro_calib/report/'):
            uses.discard('gyro_calib.report')
        if uses:
            offenders.append(f'{rel}: {sorted(uses)}')
    assert offenders == []


def test_every_dither_angle_of_the_hand_off_is_quoted_in_arcminutes() -> None:
    """The dither limit is stated in ′: a, its components and a's interval and limit alike."""
    from gyro_calib.dither import keys as dither_keys
    from gyro_calib.report.units import user_unit

    for key in (dither_keys.KEY_A, dither_keys.KEY_Z, dither_keys.KEY_Y, dither_keys.KEY_LOWER,
                dither_keys.KEY_UPPER, dither_keys.KEY_LIMIT):
        assert user_unit(key).label == '′', key


def test_an_imu_section_with_nothing_measured_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A hand-off whose imu: section names the channels only: nothing to certify, exit 2.

    (A triad's certificate is test/test_certificate_imu.py.)
    """
    import dataclasses

    from gyro_calib.handoff import Provenance, method_calibration, write_calibration
    from gyro_calib.imu_calibration import ImuCalibration

    handoff = tmp_path / 'imu.yaml'
    record = method_calibration('triad', {}, Provenance('bench', 1, 2))
    write_calibration(handoff, dataclasses.replace(record, imu=ImuCalibration(('x', 'y', 'z'))))
    assert main(['report', str(handoff), '--out', str(tmp_path / 'certs'), '--no-pdf']) == 2
    run = capsys.readouterr()
    assert run.out == '' and len(run.err.strip().splitlines()) == 1
    assert 'no measured quantity' in run.err and 'calibrate the triad first' in run.err
    assert not (tmp_path / 'certs').exists()
