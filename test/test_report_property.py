"""Property: whatever a gyro measured, its certificate prints it faithfully and judges it right.

Generator (written here from what the estimators produce, not from the code under test): a
hand-off key of any method (so every quoted unit: ″/pulse, ″, ′, °/h, °/√h, ppm, counts/rad,
Hz …), a true value across the magnitudes gyros give (1e-12 … 1e6 in SI, either sign where
the key allows it), a measured value scattered about it by its standard uncertainty (1e-6 …
1 relative, or an absolute floor for values near zero), degrees of freedom 1 … 200 or
infinite, and limits placed anywhere around the value. For every example: the printed value
is the hand-off's to half its last printed digit, the printed u has two significant digits,
k is Student t₀.₉₇₅(ν) (scipy), U = k·u, and the verdict is the one the k = 2 interval gives.
Derandomized with a small count in CI; ``GYRO_CALIB_STRESS=1`` runs 2000 examples.
"""

from __future__ import annotations

import math
import os

import scipy.stats
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.handoff import Calibration, Provenance
from gyro_calib.registry import handoff_schema
from gyro_calib.report.certificate import build_certificate
from gyro_calib.report.spec import CONDITIONAL, FAIL, PASS, spec_from_dict
from gyro_calib.report.units import user_unit

STRESS = os.environ.get('GYRO_CALIB_STRESS', '') not in ('', '0')
KEYS = sorted(k.name for k in handoff_schema().values()
              if k.has_std and k.kind in ('float', 'positive', 'nonnegative'))


@st.composite
def measured(draw: st.DrawFn) -> dict[str, float | str]:
    key = draw(st.sampled_from(KEYS))
    magnitude = 10.0 ** draw(st.floats(-12, 6))
    signed = handoff_schema()[key].kind == 'float'
    truth = magnitude * (draw(st.sampled_from([-1.0, 1.0])) if signed else 1.0)
    relative = 10.0 ** draw(st.floats(-6, 0))
    std = magnitude * relative
    value = truth + std * draw(st.floats(-3, 3))
    if not signed:
        value = abs(value)
    dof = draw(st.one_of(st.integers(1, 200).map(float), st.just(math.inf)))
    lo_z, hi_z = sorted(draw(st.lists(st.floats(-6, 6), min_size=2, max_size=2)))
    return {'key': key, 'value': value, 'std': std, 'dof': dof,
            'low': value + lo_z * std, 'high': value + hi_z * std}


def _half_digit(text: str) -> float:
    if 'e' in text:
        mantissa, exponent = text.split('e')
        places = len(mantissa.split('.')[1]) if '.' in mantissa else 0
        return 0.5 * 10.0 ** (int(exponent) - places)
    return 0.5 * 10.0 ** -(len(text.split('.')[1]) if '.' in text else 0)


@settings(max_examples=2000 if STRESS else 40, deadline=None, derandomize=not STRESS,
          database=None, suppress_health_check=[HealthCheck.too_slow])
@given(measured())
def test_certificate_prints_and_judges_any_measured_quantity(case: dict[str, float | str]) -> None:
    key, value, std = str(case['key']), float(case['value']), float(case['std'])
    dof = float(case['dof'])
    values = {key: value, key + '_std': std}
    if math.isfinite(dof):
        values[key + '_dof'] = dof
    method = handoff_schema()[key].method
    cal = Calibration(values, {method: Provenance('generated', 0, 1)}, 'P-1')
    f = user_unit(key).factor
    low, high = float(case['low']) * f, float(case['high']) * f
    spec = spec_from_dict({'quantities': {key: {'min': low, 'max': high}}})
    row = next(r for r in build_certificate(cal, None, spec).rows if r.key == key)
    assert abs(float(row.value) - value * f) <= _half_digit(row.value) * (1 + 1e-9) + 1e-300
    assert abs(float(row.std) - std * f) <= 0.05 * std * f
    # no degrees of freedom recorded (ν = ∞ not written): k = 2, as the certificate states
    k95 = float(scipy.stats.t.ppf(0.975, dof)) if math.isfinite(dof) else 2.0
    assert row.k_value is not None and row.expanded_si is not None
    assert abs(row.k_value - k95) <= 1e-6 * k95
    assert abs(row.expanded_si - k95 * std) <= 1e-9 * k95 * std
    v, half = value * f, 2.0 * std * f
    expected = (PASS if v - half >= low and v + half <= high
                else FAIL if v + half < low or v - half > high else CONDITIONAL)
    assert row.verdict == expected
