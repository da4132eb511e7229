"""The noise terms as the method reports them: results, missing, lines, table, ``--json``.

Every output here reads the per-axis results (:mod:`gyro_calib.noise.axis`): the measured
terms by axis and key, a sentence per term not measured, one line per term in SI and the
units people quote (°/√h, °/h, µg), the summary table, the hand-off entries and the
``--json`` section (METHODS §E).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.noise.axis import AxisAnalysis

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.estimate import Estimate
    from gyro_calib.noise.axis import AxisResult


class ResultAssembly(AxisAnalysis):
    """Results, missing terms, lines, table and ``--json`` (a base of the calibrator)."""

    def result_lines(self) -> list[str]:
        """One line per measured term (or per axis without terms): value ± std, SI and quoted."""
        return [line for axis, res in self.axis_results().items()
                for line in self._result_lines(axis, res)]

    @staticmethod
    def _result_lines(axis: str, res: AxisResult) -> list[str]:
        if res.fit is None:
            return [f'{axis}: {res.reason}']
        out = []
        for k, key in enumerate(res.units.keys):
            est = res.fit.estimates.get(key)
            if est is not None:
                q = res.units.quoted_factors[k]
                out.append(f'{axis}: {res.units.names[k]} = {est.value:.4g} ± '
                           f'{est.std_uncertainty:.2g} {res.units.si_units[k]} '
                           f'({est.value * q:.4g} ± {est.std_uncertainty * q:.2g} '
                           f'{res.units.quoted_units[k]})')
        return out

    def results(self) -> dict[str, dict[str, Estimate]]:
        """Measured terms so far: axis → term key → Estimate (only resolved terms)."""
        out: dict[str, dict[str, Estimate]] = {}
        for axis, res in self.axis_results().items():
            if res.fit is not None and res.fit.estimates:
                out[axis] = dict(res.fit.estimates)
        return out

    def missing(self) -> dict[str, dict[str, str]]:
        """Terms not measured (yet): axis → term key → why, a whole sentence."""
        out: dict[str, dict[str, str]] = {}
        for axis, res in self.axis_results().items():
            if res.fit is None:
                out[axis] = {key: res.reason for key in res.units.keys}
            elif res.fit.missing:
                out[axis] = dict(res.fit.missing)
        return out

    # -- outputs ----------------------------------------------------------------------------
    def json_section(self) -> dict[str, Any]:
        """The ``--json`` section of the noise method (issue 11 Part 2 item 4).

        Shape: ``{"axes": {AXIS: {"tau_s": [...], "adev": [...], "adev_std": [...],
        "results": {KEY: {"value": v, "std": s, "n": k}}}}}`` — AXIS ``gyro`` for a single
        gyro, ``gyro_x`` … ``accel_z`` for an Imu; adev in rad/s (gyro) or m/s² (accel);
        only resolved terms under "results". Axes with no Allan deviation in SI units
        (no samples, no scale factor, constant, too short) are absent; :meth:`missing`
        says why. With table states (rate or position table) in the record,
        ``"table_motion"``: whether each table moved, for how long, its largest rate and
        the samples left out (:meth:`table_record`).
        """
        axes: dict[str, Any] = {}
        for axis, res in self.axis_results().items():
            if res.curve is None or res.adev_std is None:
                continue
            results = {}
            if res.fit is not None:
                for key, est in res.fit.estimates.items():
                    results[key] = {'value': float(est.value), 'std': float(est.std_uncertainty),
                                    'n': int(est.n_used)}
            c = res.curve
            record: dict[str, Any] = {'tau_s': _floats(c.tau_s), 'adev': _floats(c.adev),
                                      'adev_std': _floats(res.adev_std), 'results': results}
            record['m'] = [int(v) for v in c.m]
            if c.clusters is not None:
                record['clusters'] = _floats(c.clusters)
            if res.alpha is not None and res.edf is not None:
                record['noise_alpha'] = [int(v) for v in res.alpha]
                record['adev_edf'] = _floats(res.edf)
            for name, (dev, std, nu) in (res.others or {}).items():
                record[name] = _floats(dev)
                record[f'{name}_std'] = _floats(std)
                record[f'{name}_edf'] = _floats(nu)
            if res.fit is not None:
                record['fit'] = res.fit.json_record(c)
            if res.outliers is not None:
                record['outliers'] = res.outliers.record()
            axes[axis] = record
        out: dict[str, Any] = {'axes': axes}
        table = self.table_record()
        if table is not None:
            out['table_motion'] = table
        return out

    def summary_table(self) -> str:
        """The noise terms as a table, in SI and the units people quote (°/√h, °/h, µg)."""
        rows = [f'{"axis":8s} {"term":28s} {"value (SI)":>24s} {"quoted":>24s}']
        notes: list[str] = []
        for axis, res in self.axis_results().items():
            if res.fit is None:
                notes.append(f'{axis}: {res.reason}')
                continue
            u = res.units
            for k, key in enumerate(u.keys):
                est = res.fit.estimates.get(key)
                if est is None:
                    rows.append(f'{axis:8s} {u.names[k]:28s} {"not resolved":>24s}')
                    notes.append(f'{axis}: {res.fit.missing[key]}')
                    continue
                q = u.quoted_factors[k]
                si = f'{est.value:.4g} ± {est.std_uncertainty:.2g} {u.si_units[k]}'
                quoted = (f'{est.value * q:.4g} ± {est.std_uncertainty * q:.2g} '
                          f'{u.quoted_units[k]}')
                rows.append(f'{axis:8s} {u.names[k]:28s} {si:>24s} {quoted:>24s}')
            notes.extend(f'{axis}: {n}' for n in res.fit.notes)
            for key, (lo, hi, _) in res.fit.tau_ranges.items():
                notes.append(f'{axis}: {key} rests on τ = {lo:.3g} … {hi:.3g} s.')
        return '\n'.join(rows + [''] + notes if notes else rows)

    def handoff_entries(self, axis: str = 'gyro') -> dict[str, float]:
        """Measured terms of one axis as hand-off entries: ``key`` and ``key_std`` (SI)."""
        out: dict[str, float] = {}
        for key, est in self.results().get(axis, {}).items():
            out[key] = float(est.value)
            out[f'{key}_std'] = float(est.std_uncertainty)
        return out


def _floats(values: npt.ArrayLike) -> list[float | None]:
    """JSON numbers (None where a statistic has no value at that τ)."""
    return [float(v) if math.isfinite(float(v)) else None for v in np.asarray(values).ravel()]
