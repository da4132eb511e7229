"""Property tests: the estimator on records our simulator did not make.

The generator below is written here from the small-angle physics of METHODS §C, in pulse
units: the cumulative count is the dither line D·sin(Ω_d·t + φ₀), a table line B·sin(Ω_z·t + p),
the sideband term c·∫ω_T·φ_p dt in closed form, a drift r·t (Earth rate + bias), quantised to
whole pulses with a random initial fraction. The table publishes (A/Ω_z)·sin(Ω_z·t + p).
Along Z the estimator's signed component is c, along Y it is −c (sign convention of
``sim_nodes.dither.kinematics``).

Frequencies and drift carry small irrational offsets: a bench never produces an exactly
round set (dither 300.000 Hz, vibration 53.5 Hz, drift 23.25 pulses/s at 2 kHz repeat every
4 s), for which the pulse quantisation is periodic and can line up with a sideband — a known
limitation, measured in benchmarks/dither_floor_monte_carlo.py (part 3).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib.dither.calibrator import DitherRecordingArrays, calibrate_dither
from gyro_calib.dither.misalignment import combine_components
from gyro_calib.dither.settings import DitherSettings

ARCMIN = math.pi / 180 / 60
SETTINGS = DitherSettings(rocking_treatment='none')


def small_angle_record(*, component_rad: float, frame: str, table_rate_rad_s: float,
                       table_hz: float, dither_hz: float, dither_pulses: float,
                       sample_rate_hz: int, table_line_pulses: float, drift_pulses_s: float,
                       duration_s: float, start_ns: int, seed: int) -> DitherRecordingArrays:
    """One orientation's record from eq. ω_IA ≈ φ̇ + ω_T·(b + c·φ) (METHODS §C), in pulses."""
    rng = np.random.default_rng(seed)
    period_ns = 1_000_000_000 // sample_rate_hz
    t_ns = start_ns + np.arange(int(duration_s * sample_rate_hz) + 1, dtype=np.int64) * period_ns
    t = (t_ns - start_ns) / 1e9
    wz, wd = 2 * math.pi * table_hz, 2 * math.pi * dither_hz
    p, ph0 = rng.uniform(0, 2 * math.pi, 2)
    sign = 1.0 if frame == 'z' else -1.0
    c = sign * component_rad
    # ∫ A cos(wz t + p) · D sin(wd t + ph0) dt
    sideband = -0.5 * table_rate_rad_s * dither_pulses * (
        np.cos((wd + wz) * t + ph0 + p) / (wd + wz) + np.cos((wd - wz) * t + ph0 - p) / (wd - wz))
    phase = (rng.uniform() + dither_pulses * np.sin(wd * t + ph0)
             + table_line_pulses * np.sin(wz * t + p) + c * sideband + drift_pulses_s * t)
    table_t = t_ns[::2]
    tt = (table_t - start_ns) / 1e9
    return DitherRecordingArrays(
        t_ns, np.floor(phase), table_t, table_rate_rad_s / wz * np.sin(wz * tt + p),
        table_rate_rad_s * np.cos(wz * tt + p), frame)


record_args = st.fixed_dictionaries({
    'table_rate_rad_s': st.floats(2.0, 30.0),
    'table_hz': st.floats(5.0, 60.0).map(lambda f: f + math.sqrt(2) * 1e-3),
    'dither_hz': st.floats(300.0, 550.0).map(lambda f: f + math.pi * 1e-3),
    'dither_pulses': st.floats(60.0, 600.0),
    'sample_rate_hz': st.sampled_from([2000, 2500, 4000]),
    'table_line_pulses': st.floats(0.0, 50.0),
    'drift_pulses_s': (st.floats(0.5, 30.0) | st.floats(-30.0, -0.5)).map(
        lambda r: r + math.e * 1e-3),
    'duration_s': st.floats(10.0, 14.0),
    'seed': st.integers(0, 2**32 - 1),
})


@settings(max_examples=12, deadline=None)
@given(args=record_args, component_arcmin=st.floats(-60.0, 60.0),
       frame=st.sampled_from(['z', 'y']))
def test_component_lies_within_its_stated_uncertainty_near_the_floor(
        args: dict, component_arcmin: float, frame: str) -> None:
    rec = small_angle_record(component_rad=component_arcmin * ARCMIN, frame=frame, start_ns=0,
                             **args)
    comps, missing = calibrate_dither(rec, settings=SETTINGS).components()
    assert frame in comps, missing
    c = comps[frame]
    assert abs(c.signed_rad - component_arcmin * ARCMIN) <= 4.0 * c.statistical_std_rad
    # σ comes from the residuals, widened by the block-scatter and null-sideband checks
    assert 0.5 <= c.statistical_std_rad / c.floor.component_std_rad <= 2.5


@settings(max_examples=5, deadline=None)
@given(args=record_args, a_arcmin=st.floats(0.0, 60.0), psi=st.floats(0.0, 2 * math.pi))
def test_a_from_two_orientations_lies_within_its_stated_uncertainty(
        args: dict, a_arcmin: float, psi: float) -> None:
    a = a_arcmin * ARCMIN
    z = small_angle_record(component_rad=a * math.sin(psi), frame='z', start_ns=0, **args)
    y = small_angle_record(component_rad=a * math.cos(psi), frame='y', start_ns=0,
                           **{**args, 'seed': args['seed'] ^ 1})
    comps, _ = calibrate_dither(z, y, settings=SETTINGS).components()
    m = combine_components(comps['z'], comps['y'])
    assert abs(m.value_rad - a) <= 4.0 * m.statistical_std_rad + 1e-12
