"""FOG figures: the turntable nonlinearity curve and self-cal K against the range used."""

from __future__ import annotations

from pathlib import Path

from gyro_calib.fog import FogCalibrator, calibrate_fog
from gyro_calib.fog.plots import plot_fog
from sim_nodes.fog import SelfCalLadder, TableSettings, simulate_mapping_and_self_cal


def test_plot_fog_writes_both_figures(tmp_path: Path) -> None:
    rec = simulate_mapping_and_self_cal(
        mapping_rates_deg_s=(-30.0, 20.0, 20.01, 20.1, 21.0), mapping_hold_s=10.0,
        ladder=SelfCalLadder(plateau_count=12, plateau_s=2.0),
        table=TableSettings(output_rate_hz=200.0, lead_s=1.0))
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
                        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns)
    paths = plot_fog(cal, tmp_path / 'figs')
    assert [p.name for p in paths] == ['fog_turntable_nonlinearity.png', 'fog_self_cal_range.png']
    for p in paths:
        assert p.stat().st_size > 10_000
        assert p.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_plot_fog_without_results_writes_nothing(tmp_path: Path) -> None:
    assert plot_fog(FogCalibrator(), tmp_path) == []
