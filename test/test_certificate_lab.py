"""Certificates issued by a laboratory (``lab.yaml``) and drafts, as ISO/IEC 17025 7.8.2 asks.

A FOG bench (``bags/fog_turntable``) recorded beside a bag of gyro temperatures is reported
twice: with a lab file in the output directory, the HTML and the PDF text each hold the
laboratory's name, address and accreditation, the certificate number (on every PDF page),
the customer, the date of calibration and of issue, the recorded temperatures and the
latitude, the traceability statements, the signatory block, the end of the certificate and
"page x of y" on every page; without one, "DRAFT — not issued by a laboratory" heads the page
and every PDF page, and none of the laboratory's items appear. Certificate numbers come from a
locked register: two processes reserving at once never get the same number, and two
``report`` runs at once get two numbers. A malformed lab file (unknown key → nearest known
one, missing key, bad pattern) or a lab certificate without customer is refused in one line,
exit 2, before any work, by ``report``, ``calibrate --report`` and ``batch``. The manifest's
``customer`` column reaches each gyro's certificate of a fleet, each under its own number.
An issued certificate in the output directory is never replaced nor mixed with another run's
files (``report`` with or without bags, lab or PDF, ``calibrate --report``: one line, exit 2,
before any work, no number taken); a draft is replaced with a line saying so (its PDF removed
under ``--no-pdf``). A run refused for a contradicted hand-off takes no number; a write that
fails after the number was reserved names the number that stays reserved, unused.
"""

from __future__ import annotations

import re
import struct
import subprocess
import sys
import zlib
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from dask_helpers import in_process_client

from gyro_calib.bagio import TEMPERATURE, BagMessage, bag_info, typestore, write_bag
from gyro_calib.batch.manifest import load_manifest
from gyro_calib.cli import main
from gyro_calib.report.evidence import recorded_temperature
from gyro_calib.report.lab import load_lab, reserve_number
from gyro_calib.topics import GYRO_TEMPERATURE

ROOT = Path(__file__).resolve().parent.parent
FOG = ROOT / 'bags' / 'fog_turntable'
CUSTOMER = 'ACME Navigation, 2 Gyro St, Springfield'
TRACEABILITY = {
    'rate_table': 'Rate table RT-3 encoder against the national angle standard, cert. A-42.',
    'encoder': 'Encoder interpolation error from autocollimator AC-1 and polygon P-24.',
    'clock': 'Bench clock disciplined to GPS, verified against a Rb standard, cert. T-778.',
    'temperature_sensors': 'Pt100 sensors calibrated in a fixed-point bath, cert. TS-11.',
}
LAB: dict[str, Any] = {
    'laboratory': {'name': 'Gyro Metrology Laboratory',
                   'address': '1 Bench Road\n12345 Testville'},
    'accreditation': {'body': 'DAkkS', 'number': 'D-K-99999-01-00', 'mark': 'mark.png'},
    'signatory': {'name': 'Dr A. Example', 'function': 'Head of calibration'},
    'traceability': TRACEABILITY,
    'certificate_number': 'GML-{year}-{seq:05d}',
}


def _png() -> bytes:
    rows = b''.join(b'\x00' + b'\x20\x40\xa0' * 8 for _ in range(4))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack('>I', len(data)) + kind + data
                + struct.pack('>I', zlib.crc32(kind + data)))
    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', 8, 4, 8, 2, 0, 0, 0))
            + chunk(b'IDAT', zlib.compress(rows)) + chunk(b'IEND', b''))


def write_lab(folder: Path, **changes: Any) -> Path:
    """``folder/lab.yaml`` (+ its mark): :data:`LAB` with ``changes`` (None removes a key)."""
    folder.mkdir(exist_ok=True)
    (folder / 'mark.png').write_bytes(_png())
    data = yaml.safe_load(yaml.safe_dump(LAB))
    for dotted, value in changes.items():
        *path, last = dotted.split('__')
        node = data
        for part in path:
            node = node[part]
        if value is None:
            del node[last]
        else:
            node[last] = value
    lab = folder / 'lab.yaml'
    lab.write_text(yaml.safe_dump(data, allow_unicode=True), encoding='utf-8')
    return lab


def temperature_bag(path: Path) -> Path:
    """Two sensors over the FOG bench's span, 1 Hz: cavity_a 23.000 + 0.001·i, shell + 0.5 °C."""
    info = bag_info(FOG)
    store = typestore()
    temp, header = store.types[TEMPERATURE], store.types['std_msgs/msg/Header']
    stamp = store.types['builtin_interfaces/msg/Time']
    messages = []
    for i, t in enumerate(range(info.start_ns, info.end_ns, 10**9)):
        for j, name in enumerate(('cavity_a', 'shell')):
            sec, ns = divmod(t, 10**9)
            msg = temp(header=header(stamp=stamp(sec=sec, nanosec=ns), frame_id=name),
                       temperature=23.0 + 0.5 * j + 0.001 * i, variance=0.0)
            messages.append(BagMessage(GYRO_TEMPERATURE, t,
                                       bytes(store.serialize_cdr(msg, TEMPERATURE))))
    write_bag(path, messages)
    return path


@pytest.fixture(scope='module')
def bench(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp('lab_bench')
    handoff = tmp / 'F-7.yaml'
    assert main(['calibrate', str(FOG), '--gyro-id', 'F-7', '--out', str(handoff)]) == 0
    return {'tmp': tmp, 'handoff': handoff, 'temperature': temperature_bag(tmp / 'temp_bag')}


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: dict[str, str] = {}
        self.order: list[str] = []
        self.text: list[str] = []
        self._open: list[str | None] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        ident = dict(attrs).get('id')
        if tag in ('td', 'div', 'p', 'header', 'h1', 'table'):
            self._open.append(ident)
            if ident:
                self.ids[ident] = ''
        self.order.append(ident or tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in ('td', 'div', 'p', 'header', 'h1', 'table') and self._open:
            self._open.pop()

    def handle_data(self, data: str) -> None:
        if 'style' in self.order[-1:]:
            return
        self.text.append(data)
        for ident in self._open:
            if ident:
                self.ids[ident] += data


def _squash(text: str) -> str:
    return re.sub(r'\s+', '', text)


def _pdf_pages(path: Path) -> list[str]:
    from pypdf import PdfReader

    return [_squash(p.extract_text()) for p in PdfReader(path).pages]


@pytest.mark.parametrize('signed', [True, False], ids=['signed', 'draft'])
def test_certificate_holds_each_item_in_html_and_pdf_with_and_without_a_lab_file(
        signed: bool, bench: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'certs'
    out.mkdir()
    if signed:
        write_lab(out)
    assert main(['report', str(bench['handoff']), str(FOG), str(bench['temperature']),
                 '--out', str(out), '--customer', CUSTOMER]) == 0
    assert capsys.readouterr().err == ''
    parser = _Text()
    parser.feed((out / 'F-7.html').read_text(encoding='utf-8'))
    html = _squash(''.join(parser.text))
    pages = _pdf_pages(out / 'F-7.pdf')
    pdf = ''.join(pages)
    number = f'GML-{parser.ids["issue-date"].strip()[:4]}-00001'
    common = [CUSTOMER, 'cavity_a23.00°C…23.34°C', 'shell23.50°C…23.84°C', '45.75°',
              'dateofcalibration', parser.ids['calibration-date'], 'certificateissued(UTC)',
              parser.ids['issue-date']]
    lab_items = ['GyroMetrologyLaboratory', '1BenchRoad', '12345Testville', 'DAkkS',
                 'D-K-99999-01-00', number, 'DrA.Example', 'Headofcalibration',
                 'Authorisedsignatory', 'Traceability',
                 *(_squash(s) for s in TRACEABILITY.values()),
                 'Theresultsrelateonlytotheitemcalibrated', f'Endofcalibrationcertificate{number}']
    for item in common:
        assert _squash(item) in html and _squash(item) in pdf, item
    for i, page in enumerate(pages, 1):
        assert f'page{i}of{len(pages)}' in page
    assert len(pages) >= 2
    if signed:
        for item in lab_items:
            assert item in html and item in pdf, item
        assert all(number in page for page in pages)
        assert 'DRAFT' not in html + pdf
        register = (out / 'certificate_numbers.tsv').read_text(encoding='utf-8')
        assert register.splitlines()[-1].split('\t')[:2] == ['1', number]
    else:
        assert parser.order.index('draft') < parser.order.index('h1')  # across the header
        assert parser.ids['draft'] == 'DRAFT — not issued by a laboratory'
        assert all('DRAFT—notissuedbyalaboratory' in page for page in pages)
        for item in lab_items:
            assert item not in html and item not in pdf, item
        assert not (out / 'certificate_numbers.tsv').exists()


def test_recorded_temperatures_per_sensor(bench: dict[str, Path]) -> None:
    rows = {r[0]: r[1:] for r in recorded_temperature(bag_info(bench['temperature']))}
    n = len(range(bag_info(FOG).start_ns, bag_info(FOG).end_ns, 10**9))
    ramp = 23.0 + 0.001 * np.arange(n)
    assert rows['cavity_a'] == pytest.approx((ramp.min(), ramp.mean(), ramp.max(), n))
    assert rows['shell'] == pytest.approx((ramp.min() + 0.5, ramp.mean() + 0.5,
                                           ramp.max() + 0.5, n))
    assert recorded_temperature(bag_info(FOG)) == ()


RESERVE = '''
import sys, time
from pathlib import Path
from gyro_calib.report.lab import load_lab, reserve_number
lab = load_lab(Path(sys.argv[1]))
go = Path(sys.argv[2])
while not go.exists():
    time.sleep(0.001)
for _ in range(int(sys.argv[3])):
    print(reserve_number(lab, sys.argv[4], 'c').number, flush=True)
'''


def test_two_processes_reserving_at_once_never_get_the_same_number(tmp_path: Path) -> None:
    import fcntl
    import time

    lab = write_lab(tmp_path, certificate_number='N{seq}')
    register = tmp_path / 'certificate_numbers.tsv'
    go, each = tmp_path / 'go', 60

    def reserve(count: int, gid: str) -> subprocess.Popen[str]:
        return subprocess.Popen([sys.executable, '-c', RESERVE, str(lab), str(go), str(count),
                                 gid], stdout=subprocess.PIPE, text=True)

    # a process that holds the register (here: this test, mid-reservation) makes the
    # next one wait until it has appended its line, and the next number follows it
    go.touch()
    with register.open('a+', encoding='utf-8') as held:
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        waiting = reserve(1, 'W')
        time.sleep(3.0)
        assert waiting.poll() is None  # blocked on the lock
        held.write('1\tN1\t2026-01-01T00:00:00Z\tT\t0\n')
        held.flush()
    assert waiting.communicate(timeout=60)[0].split() == ['N2']
    # two processes hammering the register at once: every number once, in sequence
    go.unlink()
    procs = [reserve(each, gid) for gid in ('A', 'B')]
    time.sleep(2.0)  # both are waiting on the start file
    go.touch()
    numbers = [line for p in procs for line in p.communicate(timeout=120)[0].split()]
    assert all(p.returncode == 0 for p in procs)
    assert sorted(numbers, key=lambda s: int(s[1:])) == [f'N{i}' for i in range(3, 2 * each + 3)]
    lines = [ln.split('\t') for ln in register.read_text(encoding='utf-8').splitlines()
             if not ln.startswith('#')]
    assert [int(ln[0]) for ln in lines] == list(range(1, 2 * each + 3))
    assert {ln[3] for ln in lines[2:]} == {'A', 'B'}


def test_two_report_runs_at_once_get_two_numbers(bench: dict[str, Path], tmp_path: Path) -> None:
    lab = write_lab(tmp_path / 'lab', customer='In-house line 1')
    outs = [tmp_path / 'a', tmp_path / 'b']
    cmd = [sys.executable, '-c', 'import sys; from gyro_calib.cli import main; '
           'sys.exit(main(sys.argv[1:]))', 'report', str(bench['handoff']), '--no-pdf',
           '--lab', str(lab), '--out']
    procs = [subprocess.Popen([*cmd, str(out)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for out in outs]
    for p in procs:
        p.communicate(timeout=180)
        assert p.returncode == 0
    numbers = set()
    for out in outs:
        parser = _Text()
        parser.feed((out / 'F-7.html').read_text(encoding='utf-8'))
        numbers.add(parser.ids['certificate-number'])
        assert parser.ids['customer'] == 'In-house line 1'  # the lab's default customer
    year = parser.ids['issue-date'][:4]
    assert numbers == {f'GML-{year}-00001', f'GML-{year}-00002'}


BAD_LABS: dict[str, tuple[dict[str, Any], str]] = {
    'unknown key': ({'signatory': None, 'signatry': {'name': 'x', 'function': 'y'}},
                    'unknown key "signatry"; did you mean "signatory"?'),
    'unknown nested key': ({'traceability__clock': None, 'traceability__clok': 'GPS'},
                           'unknown key "traceability.clok"; did you mean "traceability.clock"?'),
    'missing key': ({'signatory__function': None}, 'required key "signatory.function" is missing'),
    'pattern without seq': ({'certificate_number': 'GML-{year}'}, 'has no {seq}'),
    'unknown pattern field': ({'certificate_number': 'GML-{serial}'},
                              'unknown field {serial}; did you mean "seq"?'),
    'unbalanced pattern': ({'certificate_number': 'GML-{seq'}, 'is not a valid pattern'),
    'pattern format': ({'certificate_number': 'GML-{seq:.0e}'},
                       '{seq:.0e} is not a whole-number format'),
    'empty text': ({'laboratory__name': '  '}, 'laboratory.name must be a non-empty text'),
    'no customer': ({}, 'names its customer (ISO/IEC 17025 7.8.2.1 e)'),
}


@pytest.mark.parametrize('case', sorted(BAD_LABS))
def test_a_malformed_lab_file_is_refused_in_one_line_before_any_work(
        case: str, bench: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    changes, expected = BAD_LABS[case]
    lab = write_lab(tmp_path / 'lab', **changes)
    out = tmp_path / 'out'
    assert main(['report', str(bench['handoff']), '--out', str(out), '--lab', str(lab)]) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    assert captured.err.startswith('gyro-calib: error:') and expected in captured.err
    assert not out.exists()
    assert not (tmp_path / 'lab' / 'certificate_numbers.tsv').exists()


@pytest.mark.parametrize('command', ['calibrate', 'batch'])
def test_calibrate_report_and_batch_refuse_a_malformed_lab_file_before_any_work(
        command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'out'
    out.mkdir()
    write_lab(out, certificate_numbr='GML-{seq}')  # found in the output directory
    if command == 'calibrate':
        argv = ['calibrate', str(FOG), '--report', str(out), '--customer', CUSTOMER]
    else:
        manifest = tmp_path / 'fleet.csv'
        manifest.write_text(f'gyro_id,bags,customer\nF-1,{FOG},"{CUSTOMER}"\n', encoding='utf-8')
        argv = ['batch', str(manifest), '--out', str(out), '--workers', '1']
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    assert 'did you mean "certificate_number"?' in captured.err
    assert sorted(p.name for p in out.iterdir()) == ['lab.yaml', 'mark.png']


def test_batch_under_a_lab_requires_each_gyros_customer(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / 'fleet.csv'
    other = ROOT / 'bags' / 'fog_slow_loop_low_rate'  # one bag for two gyros is refused
    manifest.write_text(f'gyro_id,bags,customer\nF-1,{FOG},"{CUSTOMER}"\nF-2,{other},\n',
                        encoding='utf-8')
    lab = write_lab(tmp_path / 'lab')
    out = tmp_path / 'out'
    assert main(['batch', str(manifest), '--out', str(out), '--lab', str(lab)]) == 2
    err = capsys.readouterr().err
    assert 'gyro F-2:' in err and 'customer column' in err and not out.exists()


def test_manifest_customer_in_each_form(tmp_path: Path) -> None:
    (tmp_path / 'fleet.csv').write_text(
        f'gyro_id,bags,customer,latitude_deg\nF-1,{FOG},"ACME, Springfield",45.75\n'
        f'F-2,{FOG},,\n', encoding='utf-8')
    jobs = load_manifest(tmp_path / 'fleet.csv')
    assert [(j.customer, j.settings) for j in jobs] == [
        ('ACME, Springfield', {'latitude_deg': 45.75}), ('', {})]
    (tmp_path / 'fleet.yaml').write_text(yaml.safe_dump(
        [{'id': 'F-1', 'bags': [str(FOG)], 'customer': 'ACME'}]), encoding='utf-8')
    assert load_manifest(tmp_path / 'fleet.yaml')[0].customer == 'ACME'
    folder = tmp_path / 'dir' / 'F-3'
    folder.mkdir(parents=True)
    (folder / 'bag').symlink_to(FOG)
    (folder / 'settings.yaml').write_text('customer: ACME Nav\nlatitude_deg: 45.75\n',
                                          encoding='utf-8')
    job, = load_manifest(tmp_path / 'dir')
    assert (job.customer, job.settings) == ('ACME Nav', {'latitude_deg': 45.75})


def test_a_fleet_under_a_lab_gets_one_number_per_certificate_and_its_customer(
        tmp_path: Path) -> None:


    from gyro_calib.batch.run import run_batch
    from gyro_calib.cli.batch import lab_and_customers

    manifest = tmp_path / 'fleet.csv'
    manifest.write_text(f'gyro_id,bags,customer\nF-1,{FOG},ACME Nav\nF-2,{FOG},\n',
                        encoding='utf-8')
    out = tmp_path / 'out'
    out.mkdir()
    write_lab(out)

    class Args:
        lab = None
        customer = 'Default Customer'

    Args.out = out  # type: ignore[attr-defined]
    lab, jobs = lab_and_customers(Args(), load_manifest(manifest))  # type: ignore[arg-type]
    assert [j.customer for j in jobs] == ['ACME Nav', 'Default Customer']
    with in_process_client() as client:
        outcome = run_batch(jobs, out, client=client, pdf=False, lab=lab)
        assert not outcome.failed
        numbers = {}
        for gid, customer in (('F-1', 'ACME Nav'), ('F-2', 'Default Customer')):
            parser = _Text()
            parser.feed((out / gid / f'{gid}.html').read_text(encoding='utf-8'))
            assert parser.ids['customer'] == customer
            numbers[gid] = parser.ids['certificate-number']
            record = [r for r in outcome.records if r['gyro_id'] == gid][0]
            assert record['certificate']['certificate_number'] == numbers[gid]
        assert len(set(numbers.values())) == 2
        register = (out / 'certificate_numbers.tsv').read_text(encoding='utf-8')
        again = run_batch(jobs, out, client=client, pdf=False, lab=lab)
        assert sorted(again.skipped) == ['F-1', 'F-2']  # unchanged: certificates and numbers
        assert (out / 'certificate_numbers.tsv').read_text(encoding='utf-8') == register


def test_lab_file_loads_with_defaults_and_its_own_register(tmp_path: Path) -> None:
    from gyro_calib.errors import ConfigError

    lab = load_lab(write_lab(tmp_path, accreditation=None))
    assert (lab.accreditation_body, lab.accreditation_number, lab.accreditation_mark) == (
        '', '', '')
    assert lab.location == 'at the laboratory\'s address above'
    assert lab.counter == tmp_path / 'certificate_numbers.tsv'
    with pytest.raises(ConfigError, match='cannot be written'):
        load_lab(write_lab(tmp_path, counter='numbers/reg.tsv'))  # no such directory
    (tmp_path / 'numbers').mkdir()
    lab = load_lab(write_lab(tmp_path, counter='numbers/reg.tsv'))
    assert reserve_number(lab, 'G', 'c').number.endswith('-00001')
    assert reserve_number(lab, 'G', 'c').number.endswith('-00002')
    assert (tmp_path / 'numbers' / 'reg.tsv').exists()


def _register_lines(register: Path) -> list[str]:
    if not register.exists():
        return []
    return [ln for ln in register.read_text(encoding='utf-8').splitlines()
            if not ln.startswith('#')]


def test_an_issued_certificate_is_never_replaced_a_draft_is_said_replaced(
        bench: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    lab = write_lab(tmp_path / 'lab', customer=CUSTOMER)
    register = tmp_path / 'lab' / 'certificate_numbers.tsv'
    issued = tmp_path / 'certs'
    assert main(['report', str(bench['handoff']), '--out', str(issued), '--lab', str(lab)]) == 0
    before = {p.name: p.read_bytes() for p in issued.iterdir()}
    assert sorted(before) == ['F-7.html', 'F-7.pdf']
    capsys.readouterr()
    import gyro_calib.cli.report as report_cli

    def no_work(*_: Any, **__: Any) -> None:
        raise AssertionError('the bags were run before the refusal')
    monkeypatch.setattr(report_cli, 'evidence_from_bags', no_work)
    for argv in (['report', str(bench['handoff']), '--out', str(issued), '--no-pdf'],
                 ['report', str(bench['handoff']), str(FOG), '--out', str(issued)],
                 ['report', str(bench['handoff']), '--out', str(issued), '--lab', str(lab)],
                 ['calibrate', str(FOG), '--gyro-id', 'F-7', '--report', str(issued),
                  '--out', str(tmp_path / 'new.yaml')]):
        assert main(argv) == 2, argv
        captured = capsys.readouterr()
        assert captured.out == '' and len(captured.err.strip().splitlines()) == 1, argv
        assert f'{issued / "F-7.html"} is the issued certificate GML-' in captured.err
        assert 'give another --' in captured.err and 'or move F-7.html and F-7.pdf' in captured.err
        assert {p.name: p.read_bytes() for p in issued.iterdir()} == before
        assert len(_register_lines(register)) == 1  # no number burned
    assert not (tmp_path / 'new.yaml').exists()
    (issued / 'F-7.html').unlink()  # a PDF alone: issued or not cannot be told
    assert main(['report', str(bench['handoff']), '--out', str(issued), '--no-pdf']) == 2
    assert 'F-7.pdf is there without its F-7.html' in capsys.readouterr().err
    drafts = tmp_path / 'drafts'
    assert main(['report', str(bench['handoff']), '--out', str(drafts)]) == 0
    capsys.readouterr()
    assert main(['report', str(bench['handoff']), '--out', str(drafts), '--no-pdf']) == 0
    assert capsys.readouterr().out.splitlines() == [
        f'replaced the draft {drafts / "F-7.html"} of an earlier run',
        f'removed its {drafts / "F-7.pdf"} (--no-pdf: it would not match the new HTML)',
        f'certificate written: {drafts / "F-7.html"}']
    assert sorted(p.name for p in drafts.iterdir()) == ['F-7.html']
    assert main(['report', str(bench['handoff']), '--out', str(drafts), '--lab', str(lab),
                 '--no-pdf']) == 0  # a draft may be replaced by the issued certificate
    assert 'GML-' in (drafts / 'F-7.html').read_text(encoding='utf-8')
    assert len(_register_lines(register)) == 2


def test_a_refused_run_burns_no_number_a_failed_write_says_its_number_stays_reserved(
        bench: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / 'out'
    write_lab(out, customer=CUSTOMER)  # found in the output directory
    register = out / 'certificate_numbers.tsv'
    data = yaml.safe_load(bench['handoff'].read_text(encoding='utf-8'))
    key = next(k for k in data['gyro'] if f'{k}_std' in data['gyro'])
    data['gyro'][key] += 100 * data['gyro'][f'{key}_std']
    contradicted = tmp_path / 'F-7.yaml'
    contradicted.write_text(yaml.safe_dump(data, allow_unicode=True), encoding='utf-8')
    assert main(['report', str(contradicted), str(FOG), '--out', str(out), '--no-pdf']) == 2
    assert 'contradicted by the bags' in capsys.readouterr().err
    assert _register_lines(register) == []
    assert sorted(p.name for p in out.iterdir()) == ['lab.yaml', 'mark.png']

    def disk_full(documents: list[tuple[Path, bytes]]) -> list[Path]:
        raise OSError(28, 'No space left on device', str(documents[0][0]))
    monkeypatch.setattr('gyro_calib.report.certificate.write_all_or_none', disk_full)
    assert main(['report', str(bench['handoff']), '--out', str(out), '--no-pdf']) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    (line,) = _register_lines(register)
    number = line.split('\t')[1]
    assert 'No space left on device' in captured.err
    assert f'Certificate number {number} stays reserved in {register}, unused' in captured.err
    assert sorted(p.name for p in out.iterdir()) == ['certificate_numbers.tsv', 'lab.yaml',
                                                     'mark.png']


def test_ctrl_c_after_a_number_is_reserved_names_it_in_the_interrupt_line(
        bench: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A number is taken for good once reserved: the interrupt line says which, and where.

    (A new-user walk's Ctrl-C took numbers 4 and 5 while the line said 'nothing written'.)
    """
    import gyro_calib.cli.interrupt as interrupt

    def interrupted(*_: Any, **__: Any) -> None:
        raise KeyboardInterrupt
    monkeypatch.setattr('gyro_calib.report.certificate.write_certificate', interrupted)
    monkeypatch.setattr(interrupt, 'KEPT_AT_INTERRUPT', [])
    lab = write_lab(tmp_path / 'lab')
    out = tmp_path / 'certs'
    code = main(['report', str(bench['handoff']), '--out', str(out), '--lab', str(lab),
                 '--customer', CUSTOMER])
    err = capsys.readouterr().err
    register = (tmp_path / 'lab' / 'certificate_numbers.tsv').read_text(encoding='utf-8')
    number = register.strip().splitlines()[-1].split('\t')[1]
    assert code == 130
    assert err.strip().splitlines() == [
        f'gyro-calib: interrupted; nothing written; certificate number {number} stays reserved '
        f'in {tmp_path / "lab" / "certificate_numbers.tsv"}, unused (numbers are never reused).']
