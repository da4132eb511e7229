"""Certificates, one writer (issue 35 §3): no issued certificate lost, no number misreported.

- Two ``gyro-calib report HANDOFF --out DIR --lab LAB`` at once (customers X and Y): one
  certificate is issued and stays, the other run is refused in one line; every number the
  register holds is the one of the certificate in DIR (none reserved for a certificate a
  second run then replaced).
- A run that finds DIR held by another certificate run (``report`` or ``calibrate
  --report``) is refused in one line, exit 2, before it reserves a number.
- Drafts (no ``--lab``) alike: two ``report`` runs writing a draft into one DIR at once
  never leave one run's HTML beside the other's PDF.
- A disk that fills while the PDF is written leaves neither document: the number the line
  says "stays reserved, unused" is in no file, and the next run issues the next number.
- A hand-edited zero (or missing) standard uncertainty is refused in one line; nothing
  written, no number reserved.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from cli_helpers import run
from test_certificate_lab import write_lab

from gyro_calib.cli import main
from gyro_calib.cli.report import certificate_lock

ROOT = Path(__file__).resolve().parents[1]
BAG = ROOT / 'bags' / 'k_tilde_bench'
REGISTER = 'certificate_numbers.tsv'


@pytest.fixture(scope='module')
def handoff(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The hand-off of gyro A-1 from the committed K̃ bench."""
    path = tmp_path_factory.mktemp('handoff') / 'A-1.yaml'
    assert main(['calibrate', str(BAG), '--out', str(path), '--gyro-id', 'A-1',
                 '--no-progress']) == 0
    return path


def numbers(register: Path) -> list[str]:
    """The certificate numbers the register holds, in order."""
    if not register.exists():
        return []
    return [line.split('\t')[1] for line in register.read_text(encoding='utf-8').splitlines()
            if line and not line.startswith('#')]


def test_two_reports_at_once_issue_one_certificate_and_lose_none(
        handoff: Path, tmp_path: Path) -> None:
    labs = tmp_path / 'lab'
    lab = write_lab(labs)
    out = tmp_path / 'cc'
    runs = {customer: subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'report', str(handoff), '--out', str(out),
         '--lab', str(lab), '--customer', customer],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for customer in ('Customer X Navigation', 'Customer Y Navigation')}
    ended = {c: (p.wait(timeout=120), *p.communicate()) for c, p in runs.items()}
    won = [c for c, (code, _, _) in ended.items() if code == 0]
    assert len(won) == 1, ended  # never both "certificate written"
    (lost,) = set(ended) - set(won)
    code, stdout, stderr = ended[lost]
    assert (code, stdout) == (2, ''), ended[lost]
    assert len(stderr.strip().splitlines()) == 1, stderr
    assert ('being written by another certificate run' in stderr
            or 'is the issued certificate' in stderr), stderr
    (number,) = numbers(labs / REGISTER)  # the refused run reserved none
    page = (out / 'A-1.html').read_text(encoding='utf-8')
    assert number in page and won[0] in page and lost not in page
    assert f'certificate written: {out / "A-1.html"}' in ended[won[0]][1]
    assert sorted(p.name for p in out.iterdir()) == ['A-1.html', 'A-1.pdf']


@pytest.mark.parametrize('command', ['report', 'calibrate --report'])
def test_a_directory_held_by_another_certificate_run_is_refused_before_any_number(
        command: str, handoff: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    labs = tmp_path / 'lab'
    lab = write_lab(labs, customer='X')
    out = tmp_path / 'cc'
    other = certificate_lock(out, 'report')
    other.acquire()  # another run, in the middle of its write
    try:
        argv = (['report', handoff, '--out', out] if command == 'report' else
                ['calibrate', BAG, '--gyro-id', 'A-1', '--report', out, '--no-progress'])
        code, stdout, stderr = run(capsys, *argv, '--lab', lab, '--no-pdf')
    finally:
        other.release()
    assert (code, stdout) == (2, '')
    flag = '--out' if command == 'report' else '--report'
    assert stderr.strip().splitlines() == [
        f'gyro-calib: error: {flag} {out} is being written by another certificate run '
        f'(gyro-calib report, pid {os.getpid()} on {os.uname().nodename}, started '
        + stderr.split(', started ')[1].split(')')[0]
        + f'): wait for it to end (then see whether its certificate is the one you want) or '
        f'give another {flag} DIR; nothing was written and no certificate number was '
        'reserved.']
    assert numbers(labs / REGISTER) == []
    assert not out.exists()  # the other run created it and, empty, removed it


def _pdf_text(path: Path) -> str:
    from pypdf import PdfReader

    return ' '.join(' '.join(page.extract_text().split()) for page in PdfReader(path).pages)


def _draft(handoff: Path, out: Path, customer: str, *bags: Path) -> subprocess.Popen[str]:
    """``gyro-calib report HANDOFF [BAG] --out OUT --customer CUSTOMER``: a draft, started."""
    return subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'report', str(handoff), *map(str, bags),
         '--out', str(out), '--customer', customer],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_a_draft_writer_holds_its_directory_and_a_second_draft_is_refused(
        handoff: Path, tmp_path: Path) -> None:
    """Drafts too (no --lab): while one report writes DIR, another is refused in one line.

    The first run re-runs the bag (seconds) with DIR held; the second, started once the
    lock file is there, exits 2 with one line and writes nothing; the first's HTML and PDF
    are both its own (customer X), whole.
    """
    out = tmp_path / 'cc'
    first = _draft(handoff, out, 'Customer X Navigation', BAG)
    deadline = time.monotonic() + 60
    while not (out / '.certificates.lock').exists() and first.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.01)
    second = _draft(handoff, out, 'Customer Y Navigation')
    code, stdout, stderr = second.wait(timeout=120), *second.communicate()
    assert first.wait(timeout=120) == 0, first.communicate()
    assert (code, stdout) == (2, ''), stderr
    (line,) = stderr.strip().splitlines()
    assert line.startswith(f'gyro-calib: error: --out {out} is being written by another '
                           'certificate run (gyro-calib report, pid '), line
    assert f'pid {first.pid} on ' in line and line.endswith('nothing was written and no '
                                                            'certificate number was reserved.')
    assert sorted(p.name for p in out.iterdir()) == ['A-1.html', 'A-1.pdf']
    page = (out / 'A-1.html').read_text(encoding='utf-8')
    assert 'Customer X Navigation' in page and 'Customer Y' not in page
    pdf = _pdf_text(out / 'A-1.pdf')
    assert 'Customer X Navigation' in pdf and 'Customer Y' not in pdf


def test_two_drafts_at_once_never_leave_one_runs_html_beside_the_others_pdf(
        handoff: Path, tmp_path: Path) -> None:
    """Two draft reports into one DIR at once: one after the other, or one refused; never mixed.

    Either both end 0 (the second replaced the first's draft, and said so) or one is refused
    in one line (exit 2); either way the HTML and the PDF in DIR are one run's.
    """
    out = tmp_path / 'cc'
    runs = {c: _draft(handoff, out, c, BAG) for c in ('Customer X Navigation',
                                                       'Customer Y Navigation')}
    ended = {c: (p.wait(timeout=120), *p.communicate()) for c, p in runs.items()}
    codes = sorted(code for code, _, _ in ended.values())
    assert codes in ([0, 0], [0, 2]), ended
    for code, stdout, stderr in ended.values():
        if code == 2:
            assert stdout == '' and len(stderr.strip().splitlines()) == 1, stderr
            assert 'is being written by another certificate run' in stderr
    assert sorted(p.name for p in out.iterdir()) == ['A-1.html', 'A-1.pdf']
    page, pdf = (out / 'A-1.html').read_text(encoding='utf-8'), _pdf_text(out / 'A-1.pdf')
    (customer,) = [c for c in runs if c in page]
    assert customer in pdf and not [c for c in runs if c != customer and c in pdf]
    if codes == [0, 0]:  # the later run replaced the earlier's draft and said so
        assert any('draft' in stdout for _, stdout, _ in ended.values()), ended


def test_a_disk_that_fills_at_the_pdf_leaves_neither_document(
        handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    labs = tmp_path / 'lab'
    lab = write_lab(labs, customer='X')
    out = tmp_path / 'cc'
    real_fsync = os.fsync

    def full_at_the_pdf(fd: int) -> None:
        """The disk fills while the PDF (its temporary beside A-1.pdf) is written."""
        if os.path.basename(os.readlink(f'/proc/self/fd/{fd}')).startswith('.A-1.pdf.'):
            raise OSError(errno.ENOSPC, 'No space left on device')
        real_fsync(fd)
    monkeypatch.setattr(os, 'fsync', full_at_the_pdf)
    code, stdout, stderr = run(capsys, 'report', handoff, '--out', out, '--lab', lab)
    monkeypatch.undo()
    (number,) = numbers(labs / REGISTER)
    assert (code, stdout) == (2, '')
    (line,) = stderr.strip().splitlines()
    assert 'No space left on device' in line and 'nothing was written' in line
    assert f'Certificate number {number} stays reserved in {labs / REGISTER}, unused' in line
    # the disk is as the line says: no document carries the number said to be unused
    assert not out.exists() or sorted(p.name for p in out.iterdir()) == []
    code, stdout, stderr = run(capsys, 'report', handoff, '--out', out, '--lab', lab)
    assert code == 0, stderr  # not refused as an issued certificate
    first, second = numbers(labs / REGISTER)
    assert first == number and second in (out / 'A-1.html').read_text(encoding='utf-8')
    assert number not in (out / 'A-1.html').read_text(encoding='utf-8')


@pytest.mark.parametrize('edit', ['zero', 'missing'])
def test_a_zero_or_missing_uncertainty_is_refused(
        edit: str, handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    labs = tmp_path / 'lab'
    lab = write_lab(labs, customer='X')
    data = yaml.safe_load(handoff.read_text(encoding='utf-8'))
    if edit == 'zero':
        data['gyro']['k_tilde_rad_per_pulse_std'] = 0
    else:
        del data['gyro']['k_tilde_rad_per_pulse_std']
    edited = tmp_path / 'A-1.yaml'
    edited.write_text(yaml.safe_dump(data, allow_unicode=True, sort_keys=False),
                      encoding='utf-8')
    out = tmp_path / 'cc'
    code, stdout, stderr = run(capsys, 'report', edited, '--out', out, '--lab', lab)
    assert (code, stdout) == (2, '')
    (line,) = stderr.strip().splitlines()
    assert 'k_tilde_rad_per_pulse_std' in line, line
    if edit == 'zero':
        assert 'k_tilde_rad_per_pulse_std = 0' in line and 'positive' in line, line
    assert numbers(labs / REGISTER) == [] and not out.exists()
