"""The work of one gyro, as Dask tasks: plan, one calibration per method, finish.

Every task takes and returns plain picklable values and never raises for a bad gyro: a bad
bag or setting comes back as the gyro's ``error`` (one line), so the fleet goes on. The
finish task renders the hand-off file and the certificate and returns them as bytes; the
parent writes them (the output directory need not be visible to remote workers).
"""

from __future__ import annotations

import hashlib
import json
import traceback
from dataclasses import dataclass, field
from typing import Any

from gyro_calib import __version__
from gyro_calib.batch.manifest import GyroJob
from gyro_calib.errors import GyroCalibError


@dataclass(frozen=True, slots=True)
class Plan:
    """What to do for one gyro.

    Attributes:
        gyro_id: the gyro.
        inputs: bag path → ((file, SHA-256), ...).
        hashed: the same hashes by the path the bag reader gives the bag (``str(info.path)``),
            for the certificate's evidence: each bag is hashed once per run.
        fingerprint: SHA-256 of inputs, settings, methods, spec and gyro_calib version.
        methods: the methods to run.
        skip: True when the fingerprint equals the previous run's (results exist).
        error: why the gyro cannot be calibrated ('' if it can).
    """

    gyro_id: str
    inputs: dict[str, tuple[tuple[str, str], ...]] = field(default_factory=dict)
    fingerprint: str = ''
    methods: tuple[str, ...] = ()
    skip: bool = False
    error: str = ''
    hashed: dict[str, tuple[tuple[str, str], ...]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class MethodRun:
    """One method's run on one gyro: its hand-off part and evidence, or the error.

    ``notes``: the lines ``calibrate`` prints under its summary (a manifest setting that
    differs from the bench settings stored with the bags, the namespace read).
    """

    gyro_id: str
    method: str
    part: Any = None
    evidence: Any = None
    error: str = ''
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class GyroResult:
    """A finished gyro: the files to write (relative path → bytes) and its record.

    ``certificate``: the certificate built but not yet issued nor rendered (a finish task
    under a lab: the parent reserves its number, then :func:`issue_gyro` renders it).
    """

    gyro_id: str
    files: dict[str, bytes]
    record: dict[str, Any]
    certificate: Any = None


def reason(exc: BaseException) -> str:
    """One line for a failed gyro: the domain error's message, else type and message."""
    text = ' '.join(str(exc).split())
    if isinstance(exc, GyroCalibError):
        return text
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f' (at {where.filename.rsplit("/", 1)[-1]}:{where.lineno})' if where else ''
    return f'internal error {type(exc).__name__}: {text}{at}'


def plan_gyro(job: GyroJob, previous_fingerprint: str, spec_digest: str, force: bool) -> Plan:
    """Hash the gyro's bags, decide whether it must run, and pick its methods."""
    try:
        from gyro_calib.bag_calibration import select_methods
        from gyro_calib.bagio import bag_info
        from gyro_calib.bagio.duplicates import refuse_repeated_bags
        from gyro_calib.report.evidence import sha256_files

        refuse_repeated_bags([bag_info(b) for b in job.bags])  # a repaired copy beside it
        inputs, hashed = {}, {}
        for bag in job.bags:
            info = bag_info(bag)  # checks the path is a bag
            inputs[bag] = hashed[str(info.path)] = sha256_files(info.path)
        fingerprint = hashlib.sha256(json.dumps(
            {'version': __version__, 'inputs': inputs, 'settings': job.settings,
             'methods': job.methods, 'spec': spec_digest, 'gyro_id': job.gyro_id,
             **({'customer': job.customer} if job.customer else {})},
            sort_keys=True).encode()).hexdigest()
        if fingerprint == previous_fingerprint and not force:
            return Plan(job.gyro_id, inputs, fingerprint, (), True, hashed=hashed)
        infos = [bag_info(b) for b in job.bags]
        methods = tuple(m.name for m in select_methods(infos, job.methods or None))
        return Plan(job.gyro_id, inputs, fingerprint, methods, hashed=hashed)
    except Exception as exc:  # noqa: BLE001  (a bad gyro is a row, not the end of the fleet)
        return Plan(job.gyro_id, error=reason(exc))


def run_method(job: GyroJob, method: str,
               hashed: dict[str, tuple[tuple[str, str], ...]] | None = None) -> MethodRun:
    """Calibrate the gyro's bags with one method (streaming, as ``gyro-calib calibrate``).

    ``hashed``: the plan's hashes of the bags (:attr:`Plan.hashed`), stated in the evidence
    instead of hashing every bag a second time (None: hashed here).
    """
    try:
        from gyro_calib.bag_calibration import calibrate_bags
        from gyro_calib.report.evidence import evidence_from_outcome

        options = job.options()
        outcome = calibrate_bags(list(job.bags), methods=[method], options=options)
        session = outcome.sessions[method]
        part = session.handoff(outcome.source, gyro_id=job.gyro_id)
        if part is None:
            why = next(iter(session.missing().values()), 'nothing measured')
            return MethodRun(job.gyro_id, method, error=f'{method}: nothing measured: {why}')
        return MethodRun(job.gyro_id, method, part,
                         evidence_from_outcome(outcome, options, hashes=hashed),
                         notes=tuple(outcome.notes))
    except Exception as exc:  # noqa: BLE001  (as above)
        return MethodRun(job.gyro_id, method, error=f'{method}: {reason(exc)}')


def finish_gyro(job: GyroJob, plan: Plan, spec: Any, pdf: bool, stem: str,
                *runs: MethodRun, issue: Any = None, defer_issue: bool = False) -> GyroResult:
    """Merge the methods' hand-off parts, render the hand-off file and the certificate.

    ``issue``: the laboratory and certificate number the parent reserved (None: a draft).
    ``defer_issue``: build the certificate, and return it unrendered in the result's
    ``certificate`` (every check that can refuse the gyro done) for the parent to reserve
    its number and :func:`issue_gyro` to render it: a gyro that fails burns no number.
    """
    errors = [r.error for r in runs if r.error]
    done = [r for r in runs if not r.error]
    notes = list(dict.fromkeys(n for r in done for n in r.notes))
    base = {'gyro_id': job.gyro_id, 'stem': stem, 'fingerprint': plan.fingerprint,
            'inputs': {b: [list(f) for f in files] for b, files in plan.inputs.items()},
            'settings': job.settings, 'methods': list(plan.methods), 'errors': errors,
            **({'notes': notes} if notes else {})}
    try:
        if not done:
            return GyroResult(job.gyro_id, {}, {**base, 'status': 'failed',
                                                'reason': '; '.join(errors) or 'no method'})

        from gyro_calib.handoff import calibration_text
        from gyro_calib.registry import handoff_schema
        from gyro_calib.report.certificate import build_certificate
        from gyro_calib.report.evidence import RunEvidence

        schema = handoff_schema()
        record = None
        for run in done:
            record = run.part if record is None else run.part.merged_into(record, schema)
        assert record is not None  # a run without error carries its part
        evidence = RunEvidence(
            tuple(m for r in done for m in r.evidence.methods),
            tuple({b.path: b for r in done for b in r.evidence.bags}.values()),
            done[0].evidence.settings)
        handoff_name = f'{stem}/{stem}.yaml'
        handoff_bytes = calibration_text(record, schema).encode('utf-8')
        cert = build_certificate(record, evidence, spec, handoff_path=handoff_name,
                                 issue=issue, customer=job.customer)
        cert = _with_stem(cert, stem)
        status = 'partial' if errors else 'ok'
        record_ = {**base, 'status': status, 'reason': '; '.join(errors)}
        if defer_issue:
            return GyroResult(job.gyro_id, {handoff_name: handoff_bytes}, record_, cert)
        return _rendered(GyroResult(job.gyro_id, {handoff_name: handoff_bytes}, record_),
                         cert, spec, pdf)
    except Exception as exc:  # noqa: BLE001  (as above)
        return GyroResult(job.gyro_id, {}, {**base, 'status': 'failed', 'reason': reason(exc)})


def _rendered(result: GyroResult, cert: Any, spec: Any, pdf: bool) -> GyroResult:
    """``result`` with the certificate's HTML (and PDF) among its files and its rows."""
    from gyro_calib.batch.fleet import spc_quantity
    from gyro_calib.report.certificate import certificate_record, render_html, render_pdf
    from gyro_calib.report.spec import limit_for

    stem = cert.file_stem
    html = render_html(cert)
    files = {**result.files, f'{stem}/{stem}.html': html.encode('utf-8')}
    if pdf:
        files[f'{stem}/{stem}.pdf'] = render_pdf(html)
    cert_record = certificate_record(cert)
    limits = spec.limits if spec is not None else {}
    cert_record['quantities'] = [spc_quantity(q, limit_for(limits, q['key']))
                                 for q in cert_record['quantities']]
    return GyroResult(result.gyro_id, files, {**result.record, 'certificate': cert_record})


def burned(number: str, why: str) -> str:
    """The reason of a gyro whose reserved certificate number stays unused."""
    return (f'certificate number {number} was reserved, then {why}; it stays reserved in the '
            'register, unused (numbers are never reused)')


def issue_gyro(result: GyroResult, issue: Any, spec: Any, pdf: bool) -> GyroResult:
    """Issue the certificate a deferred finish task built under ``issue`` and render it.

    A failure here (after the number was reserved) is the gyro's row naming that number.
    """
    try:
        from gyro_calib.report.certificate import with_issue

        return _rendered(GyroResult(result.gyro_id, result.files, result.record),
                         with_issue(result.certificate, issue), spec, pdf)
    except Exception as exc:  # noqa: BLE001  (as above)
        return GyroResult(result.gyro_id, {}, {
            **result.record, 'status': 'failed',
            'reason': burned(issue.number, f'the certificate could not be made: {reason(exc)}')})


def _with_stem(cert: Any, stem: str) -> Any:
    import dataclasses

    return dataclasses.replace(cert, file_stem=stem)
