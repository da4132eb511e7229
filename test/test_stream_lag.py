"""A lagging stream is waited for, however far behind; a stopped one is declared dead."""

from __future__ import annotations

import numpy as np

from gyro_calib.rbrlg.calibrator import RateBiasCalibrator
from gyro_calib.rbrlg.config import KTildeConfig
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import simulate_rate_bias_bench
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig


def _feed(pulse_delay_s: float, stop_pulses_at_s: float | None = None) -> RateBiasCalibrator:
    """Stream 1 s chunks; the pulse stream arrives ``pulse_delay_s`` late (and may stop)."""
    run = simulate_rate_bias_bench(RateTableConfig(duration_s=150.0), RingLaserGyroConfig())
    cal = RateBiasCalibrator(KTildeConfig(stall_timeout_s=20.0))
    for second in range(0, 151 + int(pulse_delay_s)):
        lo, hi = second * 1_000_000_000, (second + 1) * 1_000_000_000
        t = run.table_t_ns
        m = (t >= lo) & (t < hi)
        cal.extend_table_states(t[m], run.table_angle_rad[m], run.table_rate_rad_s[m])
        cal.extend_zero_index(run.zero_index_ns[(run.zero_index_ns >= lo)
                                                & (run.zero_index_ns < hi)])
        plo, phi = lo - int(pulse_delay_s * 1e9), hi - int(pulse_delay_s * 1e9)
        if stop_pulses_at_s is not None:
            phi = min(phi, int(stop_pulses_at_s * 1e9))
        p = (run.pulse_t_ns >= plo) & (run.pulse_t_ns < phi)
        cal.extend_pulses(run.pulse_t_ns[p], run.pulse_counts[p])
        cal.process()
    return cal


def test_pulses_lagging_far_behind_the_table_change_nothing() -> None:
    on_time, late = _feed(0.0), _feed(70.0)  # 70 s late: beyond stall_timeout_s = 20 s
    assert len(on_time.pairs) == 5 and not late.rejections
    assert [p.k_tilde_arcsec_per_pulse for p in late.pairs] == [
        p.k_tilde_arcsec_per_pulse for p in on_time.pairs]


def test_pulse_stream_that_stops_is_declared_dead_and_events_get_a_reason() -> None:
    cal = _feed(0.0, stop_pulses_at_s=80.0)
    assert 1 <= len(cal.pairs) < 5
    assert any('pulse samples' in r.reason for r in cal.rejections)
    assert np.all(np.isfinite([p.k_tilde_arcsec_per_pulse for p in cal.pairs]))
