"""A compensated recording and how it reads: its figures as text and as a JSON document.

:class:`BagCompensation` is what :func:`gyro_calib.bag_compensation.compensate_bags` gives
(the figures of :func:`gyro_calib.thermal.compensate.compensate_reduced`, METHODS §D, §E,
with the model applied); :func:`summary_text` and :func:`json_document` are what
``gyro-calib compensate`` prints (rates in °/h and rad/s; the document in rad/s, NaN → null).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.estimate import Estimate
from gyro_calib.thermal.compensate import CompensationReport
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.site import RAD_S_PER_DEG_H
from gyro_calib.units import format_stamp

RESULT_KEYS = ('bias_stability_raw_rad_s', 'bias_stability_compensated_rad_s',
               'bias_stability_noise_floor_rad_s', 'mean_rate_compensated_rad_s')


@dataclasses.dataclass(frozen=True, slots=True)
class BagCompensation:
    """A compensated recording: the figures, the model, and what the file gave.

    Attributes:
        report: the figures (:class:`CompensationReport`).
        model: the thermal model applied.
        pulse_calibration: K, ARW and the model as the Imu conversion uses them.
        gyro_id: the recording's gyro id ('' = unknown).
        bags: the bag paths.
    """

    report: CompensationReport
    model: ThermalBiasModel
    pulse_calibration: Any
    gyro_id: str
    bags: tuple[Path, ...]

def _est(e: Estimate) -> dict[str, Any]:
    return {'value': e.value, 'std': e.std_uncertainty, 'n': e.n_used}


def json_document(result: BagCompensation) -> dict[str, Any]:
    """The ``--json`` document of ``compensate``.

    The ``--json`` document, in the shape every command shares (docs/howto/offline.md,
    ``gyro_calib/schema/result.schema.json``): ``methods.thermal.{results, missing,
    rejections}`` plus the compensation's figures, model and notes (rates in rad/s; NaN → null).
    """
    from gyro_calib.thermal.session import finite_json

    r = result.report
    fl = r.noise_floor
    m = result.model
    document: dict[str, Any] = finite_json({'command': 'compensate', 'methods': {'thermal': {
        'results': {k: _est(e) for k, e in r.results().items()},
        'missing': {},
        'rejections': [f'{format_stamp(x.stamp_ns)}: {x.reason}' for x in r.rejections],
        'earth_rate_along_axis_rad_s': r.earth_rate_along_axis_rad_s,
        'improvement': r.improvement,
        'noise_floor': {'bias_stability_rad_s': _est(fl.floor),
                        'angle_random_walk_rad_per_sqrt_s': fl.angle_random_walk_rad_per_sqrt_s,
                        'quantisation_rad': fl.quantisation_rad, 'block_s': fl.block_s},
        'allan_deviation': {'tau_s': r.adev_tau_s.tolist(), 'raw_rad_s': r.adev_raw_rad_s.tolist(),
                            'compensated_rad_s': r.adev_compensated_rad_s.tolist()},
        'block_s': r.block_s,
        'model': {'gyro_id': m.gyro_id, 'terms': list(m.terms),
                  'calibrated_h_c': list(m.h_range_c),
                  'extrapolation_margin_c': m.extrapolation_margin_c,
                  'scale_factor_rad_per_pulse': m.scale_factor_rad_per_pulse},
        'gyro_id': result.gyro_id,
        'notes': list(r.notes)}},
        'bags': [str(b) for b in result.bags],
    })
    return document


def summary_text(result: BagCompensation, calibration_file: Path) -> str:
    """The human summary: figures in °/h and rad/s, the Allan deviation, notes, rejections."""
    r, m = result.report, result.model
    d = RAD_S_PER_DEG_H
    lines = [f'== compensate: {", ".join(str(b) for b in result.bags)} with the thermal model of '
             f'gyro {m.gyro_id or "(unnamed)"} from {calibration_file}',
             'model: bias = b0' + (f' + Σ c_k·x_k over x = {", ".join(m.terms)} (b0, c_k: '
                                   f"the file's thermal_model)" if m.terms else ' (constant)')
             + f'; calibrated H {m.h_range_c[0]:.2f}…{m.h_range_c[1]:.2f} °C, used to '
             f'± {m.extrapolation_margin_c:g} °C beyond; '
             f'K = {m.scale_factor_rad_per_pulse!r} rad/pulse']
    rows = [('quantity', '°/h', 'rad/s', 'std (°/h)', 'n')]
    for key, est in r.results().items():
        rows.append((key, f'{est.value / d:.5f}', f'{est.value:.6g}',
                     f'{est.std_uncertainty / d:.2g}', str(est.n_used)))
    widths = [max(len(row[i]) for row in rows) for i in range(5)]
    lines += ['  '.join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    raw, comp = r.bias_stability_raw.value, r.bias_stability_compensated.value
    floor = r.noise_floor.floor.value
    arw_deg_sqrt_h = r.noise_floor.angle_random_walk_rad_per_sqrt_s / (math.pi / 10800)
    excess = 1 - math.sqrt(max(comp**2 - floor**2, 0.0)) / math.sqrt(max(raw**2 - floor**2,
                                                                          1e-300))
    lines.append(f'Earth rate along the sense axis: {r.earth_rate_along_axis_rad_s / d:.5f} °/h '
                 f'(the compensated mean rate on a static base).')
    lines.append(f'bias stability ({r.block_s:g} s means of the unfiltered rate): '
                 f'{raw / d:.4f} → {comp / d:.4f} °/h, {r.improvement:.1%} better; the noise '
                 f'floor (ARW {arw_deg_sqrt_h:.4f} °/√h and pulse quantisation) allows '
                 f'{floor / d:.4f} °/h, so {excess:.1%} of the thermal excess above it was '
                 'removed.')
    if len(r.adev_tau_s):
        lines.append('Allan deviation (°/h):   τ (s)      raw   compensated')
        for target in (1.0, 10.0, 100.0, 1000.0, 3000.0):
            i = int(np.argmin(np.abs(np.log(r.adev_tau_s / target))))
            if abs(math.log(r.adev_tau_s[i] / target)) < 0.5:
                lines.append(f'  {r.adev_tau_s[i]:20.0f} {r.adev_raw_rad_s[i] / d:9.4f} '
                             f'{r.adev_compensated_rad_s[i] / d:9.4f}')
    lines += [f'note: {n}' for n in r.notes]
    for rej in r.rejections:
        lines.append(f'  rejected at {format_stamp(rej.stamp_ns)}: {rej.reason}')
    return '\n'.join(lines)
