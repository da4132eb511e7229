"""The issuing laboratory (``lab.yaml``) and its certificate numbers.

A certificate is issued by a laboratory only when a lab file is given (``--lab``, or
``lab.yaml`` in the output directory); it then carries what ISO/IEC 17025:2017 7.8.2.1 and
7.8.4.1 ask beyond the measurement: the laboratory's name and address (b), the location of
the work (c), a unique number on every page and the end marked (d), the customer (e), the
authorised signatory (o) and how the measurements are traceable (7.8.4.1 c). Without one
the certificate is a draft and says so on every page.

The file (every text a non-empty string; ``accreditation``, ``location``, ``customer`` and
``counter`` optional)::

    laboratory:
      name: Gyro Metrology Laboratory
      address: 1 Bench Road, 12345 Testville
      location: at the laboratory's address        # where the calibrations are made
    accreditation: {body: DAkkS, number: D-K-00000-01-00, mark: mark.png}
    signatory: {name: Dr A. Example, function: Head of calibration}
    traceability:
      rate_table: ...
      encoder: ...
      clock: ...
      temperature_sensors: ...
    certificate_number: GC-{year}-{seq:05d}
    customer: In-house production line 1                # when --customer is not given
    counter: certificate_numbers.tsv                     # relative to this file

Certificate numbers come from a register (the ``counter`` file, beside the lab file by
default): each number is reserved under an exclusive ``flock`` by appending one line
(sequence, number, UTC, gyro id, pid), so concurrent ``report``/``batch`` runs of one
laboratory never get the same number and a number is never handed out twice, even when a
certificate then fails to be made (its line stays; the number is not reused).
"""

from __future__ import annotations

import base64
import datetime
import difflib
import fcntl
import os
import re
import string
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.errors import ConfigError

LAB_FILE = 'lab.yaml'
"""The lab file looked for in the output directory when ``--lab`` is not given."""

REGISTER = 'certificate_numbers.tsv'
"""The default register of certificate numbers, beside the lab file."""

SCHEMA: dict[str, dict[str, bool] | bool] = {
    'laboratory': {'name': True, 'address': True, 'location': False},
    'accreditation': {'body': True, 'number': True, 'mark': False},
    'signatory': {'name': True, 'function': True},
    'traceability': {'rate_table': True, 'encoder': True, 'clock': True,
                     'temperature_sensors': True},
    'certificate_number': True,
    'customer': False,
    'counter': False,
}
"""Every key of the lab file: a section maps its keys to whether they are required; a plain
key to whether it is required (a whole optional section — ``accreditation`` — is required
complete when present)."""

OPTIONAL_SECTIONS = frozenset({'accreditation'})

TRACEABILITY = {'rate_table': 'rate table', 'encoder': 'encoder', 'clock': 'clock',
                'temperature_sensors': 'temperature sensors'}
"""The traceability statements, in the order printed, with their labels."""

NUMBER_FIELDS = ('seq', 'year', 'month', 'day')
"""Fields of the certificate-number pattern: the register's sequence number (required, so
every number is unique) and the issue date's year, month and day."""

MARK_TYPES = {b'\x89PNG\r\n\x1a\n': 'image/png', b'\xff\xd8\xff': 'image/jpeg'}

DEFAULT_LOCATION = 'at the laboratory\'s address above'


@dataclass(frozen=True, slots=True)
class Lab:
    """The issuing laboratory, as its lab file states it.

    Attributes:
        source: the lab file.
        name, address, location: the laboratory and where the calibrations are made.
        signatory_name, signatory_function: the person authorising the certificates.
        traceability: (label, statement) for the rate table, encoder, clock and
            temperature sensors.
        number_pattern: the certificate-number pattern (``str.format`` fields of
            :data:`NUMBER_FIELDS`).
        counter: the register of certificate numbers.
        accreditation_body, accreditation_number: '' when not accredited.
        accreditation_mark: the mark as a ``data:`` URI, or ''.
        customer: the customer named when none is given per certificate ('' none).
    """

    source: Path
    name: str
    address: str
    location: str
    signatory_name: str
    signatory_function: str
    traceability: tuple[tuple[str, str], ...]
    number_pattern: str
    counter: Path
    accreditation_body: str = ''
    accreditation_number: str = ''
    accreditation_mark: str = ''
    customer: str = ''


@dataclass(frozen=True, slots=True)
class Issue:
    """What makes a certificate issued: the laboratory, its number, customer and date."""

    lab: Lab
    number: str
    customer: str
    issued_utc: str


def _nearest(word: str, known: list[str]) -> str:
    close = difflib.get_close_matches(word, known, n=1, cutoff=0.0)
    return f'; did you mean "{close[0]}"?' if close else ''


def _text(path: Path, where: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f'lab file {path}: {where} must be a non-empty text, not '
                          f'{value!r}.')
    return value.strip()


def check_pattern(pattern: str, where: str = 'certificate_number') -> str:
    """The certificate-number pattern, checked (it must hold ``{seq}``).

    Raises:
        ConfigError: not a ``str.format`` pattern, a field other than
            :data:`NUMBER_FIELDS`, no ``{seq}``, or a number that is not one printable line.
    """
    shown = f'{where} {pattern!r}'
    try:
        fields = [(name, spec, conv) for _, name, spec, conv
                  in string.Formatter().parse(pattern) if name is not None]
    except ValueError as exc:
        raise ConfigError(f'{shown} is not a valid pattern ({exc}); write e.g. '
                          '"GC-{year}-{seq:05d}".') from None
    for name, spec, conv in fields:
        if name not in NUMBER_FIELDS or conv:
            raise ConfigError(f'{shown}: unknown field {{{name}{"!" + conv if conv else ""}}}'
                              f'{_nearest(name, list(NUMBER_FIELDS))} The fields are '
                              f'{", ".join("{" + f + "}" for f in NUMBER_FIELDS)}.')
        if not re.fullmatch(r'0?\d{0,2}d?', spec or ''):
            raise ConfigError(f'{shown}: {{{name}:{spec}}} is not a whole-number format (two '
                              'sequence numbers could print alike); write e.g. {seq:05d}.')
    if 'seq' not in [name for name, _, _ in fields]:
        raise ConfigError(f'{shown} has no {{seq}}: without the sequence number two '
                          'certificates could get the same number; write e.g. '
                          '"GC-{year}-{seq:05d}".')
    try:
        sample = format_number(pattern, 1, datetime.datetime(2026, 1, 2, tzinfo=datetime.UTC))
    except (ValueError, TypeError) as exc:
        raise ConfigError(f'{shown} cannot format a number ({exc}); the fields are integers, '
                          'e.g. {seq:05d}.') from None
    if not sample.strip() or not sample.isprintable() or len(sample) > 64:
        raise ConfigError(f'{shown} gives {sample!r}: a certificate number is one printable '
                          'line of at most 64 characters.')
    return pattern


def format_number(pattern: str, seq: int, when: datetime.datetime) -> str:
    """The certificate number of sequence ``seq`` issued at ``when``."""
    return pattern.format(seq=seq, year=when.year, month=when.month, day=when.day)


def _mark(path: Path, value: str) -> str:
    mark = (path.parent / value)
    try:
        data = mark.read_bytes()
    except OSError as exc:
        raise ConfigError(f'lab file {path}: accreditation.mark {mark} cannot be read '
                          f'({exc.strerror}).') from None
    for magic, mime in MARK_TYPES.items():
        if data.startswith(magic):
            return f'data:{mime};base64,{base64.b64encode(data).decode("ascii")}'
    if data.lstrip().startswith((b'<svg', b'<?xml')):
        return 'data:image/svg+xml;base64,' + base64.b64encode(data).decode('ascii')
    raise ConfigError(f'lab file {path}: accreditation.mark {mark} is not a PNG, JPEG or SVG '
                      'image.')


def _check_keys(path: Path, data: Mapping[str, Any]) -> None:
    """Unknown keys (with the nearest known one) and missing required keys, in one line."""
    for key, value in data.items():
        if key not in SCHEMA:
            raise ConfigError(f'lab file {path}: unknown key "{key}"'
                              f'{_nearest(str(key), list(SCHEMA))}')
        section = SCHEMA[key]
        if isinstance(section, dict):
            if not isinstance(value, Mapping):
                raise ConfigError(f'lab file {path}: {key} must be a mapping of '
                                  f'{", ".join(section)}.')
            for sub in value:
                if sub not in section:
                    known = [f'{key}.{s}' for s in section] + [
                        f'{k}.{s}' for k, sec in SCHEMA.items() if isinstance(sec, dict)
                        for s in sec if k != key]
                    raise ConfigError(f'lab file {path}: unknown key "{key}.{sub}"'
                                      f'{_nearest(f"{key}.{sub}", known)}')
    for key, section in SCHEMA.items():
        if isinstance(section, dict):
            if key not in data and key in OPTIONAL_SECTIONS:
                continue
            for sub, required in section.items():
                if required and sub not in (data.get(key) or {}):
                    raise ConfigError(f'lab file {path}: required key "{key}.{sub}" is '
                                      'missing.')
        elif section and key not in data:
            raise ConfigError(f'lab file {path}: required key "{key}" is missing.')


def load_lab(path: Path) -> Lab:
    """The laboratory of a lab file, checked before any work.

    Raises:
        ConfigError: unreadable, not a mapping, an unknown key (naming the nearest known
            one), a required key missing, an empty text, a bad number pattern, an unreadable
            mark, or a register that cannot be written — one line.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding='utf-8'))
    except OSError as exc:
        raise ConfigError(f'lab file {path} cannot be read ({exc.strerror}).') from None
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ConfigError(f'lab file {path} cannot be read as YAML: '
                          f'{" ".join(str(exc).split())}.') from None
    if not isinstance(data, Mapping):
        raise ConfigError(f'lab file {path} must be a mapping with laboratory, signatory, '
                          'traceability and certificate_number.')
    _check_keys(path, data)
    lab, sig, trace = data['laboratory'], data['signatory'], data['traceability']
    acc = data.get('accreditation') or {}
    counter = path.parent / _text(path, 'counter', data['counter']) if 'counter' in data \
        else path.parent / REGISTER
    result = Lab(
        source=path, name=_text(path, 'laboratory.name', lab['name']),
        address=_text(path, 'laboratory.address', lab['address']),
        location=(_text(path, 'laboratory.location', lab['location']) if 'location' in lab
                  else DEFAULT_LOCATION),
        signatory_name=_text(path, 'signatory.name', sig['name']),
        signatory_function=_text(path, 'signatory.function', sig['function']),
        traceability=tuple((label, _text(path, f'traceability.{key}', trace[key]))
                           for key, label in TRACEABILITY.items()),
        number_pattern=check_pattern(_text(path, 'certificate_number',
                                           data['certificate_number']),
                                     f'lab file {path}: certificate_number'),
        counter=counter.absolute(),
        accreditation_body=_text(path, 'accreditation.body', acc['body']) if acc else '',
        accreditation_number=_text(path, 'accreditation.number', acc['number']) if acc else '',
        accreditation_mark=_mark(path, _text(path, 'accreditation.mark', acc['mark']))
        if 'mark' in acc else '',
        customer=_text(path, 'customer', data['customer']) if 'customer' in data else '')
    check_register(result)
    return result


def find_lab(given: Path | None, out_dir: Path) -> Lab | None:
    """The lab of ``--lab``, else ``lab.yaml`` in the output directory, else None (a draft)."""
    if given is not None:
        return load_lab(given)
    found = Path(out_dir) / LAB_FILE
    return load_lab(found) if found.is_file() else None


def check_customer(customer: str | None, lab: Lab | None, what: str = '--customer') -> str:
    """The customer a certificate names ('' for a draft without one).

    Raises:
        ConfigError: an empty customer, or a lab's certificate without a customer
            (ISO/IEC 17025 7.8.2.1 e).
    """
    if customer is not None and not customer.strip():
        raise ConfigError(f'{what} is empty; give the customer\'s name (and contact).')
    chosen = (customer or '').strip() or (lab.customer if lab else '')
    if lab is not None and not chosen:
        raise ConfigError(f'a certificate issued by {lab.name} names its customer (ISO/IEC '
                          f'17025 7.8.2.1 e): give {what}, or customer: in {lab.source}.')
    return chosen


def check_register(lab: Lab) -> None:
    """The register of certificate numbers can be written (checked before any work).

    Raises:
        ConfigError: its directory is missing or not writable, or the file is not writable.
    """
    reg = lab.counter
    if reg.exists():
        ok = reg.is_file() and os.access(reg, os.R_OK | os.W_OK)
    else:
        ok = reg.parent.is_dir() and os.access(reg.parent, os.W_OK | os.X_OK)
    if not ok:
        raise ConfigError(f'the certificate-number register {reg} of lab file {lab.source} '
                          'cannot be written; make it writable or set counter: in the lab file '
                          'to a writable path.')


def _utc(when: datetime.datetime) -> str:
    return when.astimezone(datetime.UTC).strftime('%Y-%m-%dT%H:%M:%SZ')


def _last_seq(lines: list[str], register: Path) -> int:
    last = 0
    for i, line in enumerate(lines, 1):
        if not line.strip() or line.startswith('#'):
            continue
        head = line.split('\t', 1)[0]
        if not head.isdigit():
            raise ConfigError(f'the certificate-number register {register}, line {i}, is '
                              f'damaged ({line[:40]!r}); repair it by hand (numbers must never '
                              'be reused).')
        last = max(last, int(head))
    return last


def reserve_number(lab: Lab, gyro_id: str, customer: str, *,
                   now: datetime.datetime | None = None) -> Issue:
    """Reserve the next certificate number of ``lab`` for ``gyro_id``; the issue it makes.

    The register is locked (``flock``, exclusive) while the last sequence number is read and
    the new line is appended and fsynced, so concurrent processes get distinct numbers.

    Raises:
        ConfigError: the register cannot be opened or a line of it is damaged.
    """
    when = now or datetime.datetime.now(datetime.UTC)
    reg = lab.counter
    try:
        stream = reg.open('a+', encoding='utf-8')
    except OSError as exc:
        raise ConfigError(f'the certificate-number register {reg} cannot be opened '
                          f'({exc.strerror}).') from None
    with stream:
        fcntl.flock(stream.fileno(), fcntl.LOCK_EX)  # released when the file is closed
        stream.seek(0)
        lines = stream.read().splitlines()
        seq = _last_seq(lines, reg) + 1
        number = format_number(lab.number_pattern, seq, when)
        head = '' if lines else ('# certificate numbers of gyro_calib: sequence, number, '
                                 'reserved (UTC), gyro id, pid. Never edit a line out.\n')
        gid = ' '.join(gyro_id.split()) or '-'
        stream.write(f'{head}{seq}\t{number}\t{_utc(when)}\t{gid}\t{os.getpid()}\n')
        stream.flush()
        os.fsync(stream.fileno())
    return Issue(lab, number, customer, _utc(when))
