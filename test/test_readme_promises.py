"""What the README promises, as a user would try it (issue 35 §5).

- ``gyro-calib methods`` and ``info`` list ``/imu/pulses`` (a triad's channels) as a noise
  input, with what it needs (``--calibration``: each channel's K_i);
- ``calibrate --method triad --plot DIR`` draws the triad (``DIR/triad_pairs.png``);
- ``calibrate --report DIR`` takes ``--no-pdf`` (and, like ``--spec``, only with
  ``--report``);
- a bench setting given that differs from the one stored with the bags: ``batch`` prints the
  note ``calibrate`` prints, and the certificate (of either) carries it.

``main`` runs in-process; output is captured with capsys.
"""

from __future__ import annotations

import html
import re
from pathlib import Path

import pytest
import yaml
from cli_helpers import run

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
PNG = b'\x89PNG\r\n\x1a\n'
NOTE = (r"latitude_deg: {who} gives 60\.0 ° but the bench settings stored in \S+k_tilde_bench "
        r"says 28\.2 °; using 60\.0 ° \(check which is right\)\.")
"""The note for a latitude of 60° given against the k_tilde_bench bag's stored 28.2°."""


def test_methods_lists_a_triads_pulses_as_a_noise_input(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, 'methods')
    assert code == 0
    noise = out[out.index('\nnoise '):out.index('\ntriad ')]
    line = next(x for x in noise.splitlines() if x.split()[:1] == ['/imu/pulses'])
    assert 'sensor_msgs/msg/JointState' in line and 'one of these' in line
    assert '--calibration' in line


def test_info_offers_noise_on_a_triad_bag(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, 'info', BAGS / 'triad_two_axis_bench')
    assert code == 0, err
    noise = next(x for x in out.splitlines() if x.startswith('  noise '))
    assert re.match(r'  noise +yes +gyro-calib noise BAG --topic T, T one of /imu/pulses '
                    r'\(needs --calibration FILE', noise), noise


def test_calibrate_triad_plot_draws_the_pairs(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    figures = tmp_path / 'figs'
    code, out, err = run(capsys, 'calibrate', BAGS / 'triad_two_axis_bench', '--method',
                         'triad', '--plot', figures, '--no-progress')
    assert code == 0, err
    drawn = figures / 'triad_pairs.png'
    assert drawn.read_bytes()[:8] == PNG
    assert f'figure written: {drawn.resolve()}' in out.splitlines()
    assert sorted(p.name for p in figures.iterdir()) == ['triad_pairs.png']


def test_calibrate_report_takes_no_pdf(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    certs = tmp_path / 'certs'
    code, out, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--out',
                         tmp_path / 'A.yaml', '--gyro-id', 'A-1', '--report', certs, '--no-pdf',
                         '--no-progress')
    assert code == 0, err
    assert sorted(p.name for p in certs.iterdir()) == ['A-1.html']
    assert f'certificate written: {certs / "A-1.html"}' in out
    code, out, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--no-pdf')
    assert (code, out) == (2, '')
    assert err.strip() == ('gyro-calib: error: --no-pdf applies only with --report DIR (the '
                           'certificate).')


def _settings_cell(certificate: Path, name: str) -> str:
    """The 'where it came from' cell of the bench setting ``name``, as text."""
    page = certificate.read_text(encoding='utf-8')
    row = re.search(rf'<td class="key">{name}</td><td>[^<]*</td><td class="small">([^<]*)</td>',
                    page)
    assert row is not None, name
    return html.unescape(row.group(1))


def test_calibrate_prints_the_stored_bench_note_and_its_certificate_carries_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--latitude-deg', '60',
                         '--gyro-id', 'A-1', '--report', tmp_path, '--no-pdf', '--no-progress')
    assert code == 0, err
    note = NOTE.format(who='--latitude-deg')
    assert re.search(rf'^rbrlg: note: {note}$', out, re.M), out
    assert re.search(rf'; note: {note}$', _settings_cell(tmp_path / 'A-1.html',
                                                         'latitude_deg'))


def test_batch_prints_the_stored_bench_note_and_its_certificate_carries_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / 'fleet.yaml'
    manifest.write_text(yaml.safe_dump([
        {'id': 'A-1', 'bags': [str(BAGS / 'k_tilde_bench')], 'settings': {'latitude_deg': 60.0}},
    ]))
    out_dir = tmp_path / 'line1'
    code, out, err = run(capsys, 'batch', manifest, '--out', out_dir, '--workers', '1',
                         '--no-pdf', '--no-progress')
    assert code == 0, err
    note = NOTE.format(who="the manifest's latitude_deg")
    lines = out.splitlines()
    assert lines[0] == 'A-1: ok'
    assert re.fullmatch(rf'  rbrlg: note: {note}', lines[1]), lines[1]
    assert re.search(rf'; note: {note}$', _settings_cell(out_dir / 'A-1' / 'A-1.html',
                                                         'latitude_deg'))
