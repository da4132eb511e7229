"""The complete RBRLG calibration: K̃, θ, K = K̃·cos θ and bias (METHODS §A.2–A.3).

:class:`RbrlgCalibrator` routes the streams of the two-axis bench: rate-table windows
(the rate table spinning, the position table still) give K̃ and ω′ₑ + ω_B; position-
table stations (the rate table held still, the position table turning) give θ, β₀,
α. Which phase the bench is in is read from the streams alone: a table only yields
windows while it turns at constant rate, and a station only counts while the rate
table holds still.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.rbrlg.calibrator import CalibrationUpdate, RateBiasCalibrator
from gyro_calib.rbrlg.config import KTildeConfig
from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate
from gyro_calib.rbrlg.scale_factor import scale_factor
from gyro_calib.rbrlg.stations import Station, StationCalibrator
from gyro_calib.handoff import GyroCalibration
from gyro_calib.units import EARTH_RATE_DEG_H, RAD_PER_ARCSEC

if TYPE_CHECKING:
    from typing import Any

    from numpy.typing import ArrayLike

    from gyro_calib.rbrlg.fix_error_angle import FixErrorAngleResult


def earth_rate_along_table_axis_deg_h(*, latitude_deg: float, heading_deg: float,
                                      tilt_rad: float, position_table_angle_rad: float) -> float:
    """Earth rate along the rate-table axis oZ, °/h.

    oZ = (sin α·cos χ, sin α·sin χ, cos α) in the position-table base, which is
    East-North-Up turned by ``heading_deg`` about Up (χ: position-table angle).
    """
    lat, h = math.radians(latitude_deg), math.radians(heading_deg)
    east, north, up = 0.0, EARTH_RATE_DEG_H * math.cos(lat), EARTH_RATE_DEG_H * math.sin(lat)
    x = math.cos(h) * east + math.sin(h) * north
    y = -math.sin(h) * east + math.cos(h) * north
    s, c = math.sin(tilt_rad), math.cos(tilt_rad)
    chi = position_table_angle_rad
    return x * s * math.cos(chi) + y * s * math.sin(chi) + up * c


@dataclass(frozen=True, slots=True)
class RbrlgResults:
    """Everything measured so far; None where a quantity is not measured yet.

    Attributes:
        k_tilde_arcsec_per_pulse: K̃ (eq. 3), ″/pulse.
        fix_error: θ, β₀, α with uncertainties (eqs. 10, 15–17), rad.
        scale_factor_arcsec_per_pulse: K = K̃·cos θ (eq. 4), ″/pulse.
        earth_plus_bias_deg_h: ω′ₑ + ω_B along og from the K̃ windows, °/h.
        bias_deg_h: ω_B, with the Earth rate along oZ removed (needs the site), °/h.
        fix_error_problem: why θ (and so K) is not reported although stations exist, or ''.
    """

    k_tilde_arcsec_per_pulse: Estimate | None
    fix_error: FixErrorAngleResult | None
    scale_factor_arcsec_per_pulse: Estimate | None
    earth_plus_bias_deg_h: Estimate | None
    bias_deg_h: Estimate | None
    fix_error_problem: str = ''


@dataclass(slots=True)
class RbrlgCalibrator:
    """K̃ and θ from the two-axis bench streams, and K from both.

    Attributes:
        k_config: rate-table window settings (m).
        position_table_revolutions: n, position-table revolutions each way per station.
        latitude_deg, heading_deg: site, for the bias (NaN: bias not separated from Earth rate).
        nominal_tilt_deg, tilt_tolerance_deg: the mount's α and how far the fitted α may be
            from it before θ is refused as coming from a wrong set-up, °.
    """

    k_config: KTildeConfig = field(default_factory=KTildeConfig)
    position_table_revolutions: int = 1
    latitude_deg: float = math.nan
    heading_deg: float = 0.0
    nominal_tilt_deg: float = 45.0
    tilt_tolerance_deg: float = 5.0
    k_tilde: RateBiasCalibrator = field(init=False)
    stations: StationCalibrator = field(init=False)
    _position_angle_rad: float | None = None
    """χ of the position table at rest (first still sample): where the K̃ phase ran."""

    def __post_init__(self) -> None:
        """Create the K̃ and the station stages."""
        self.k_tilde = RateBiasCalibrator(self.k_config)
        self.stations = StationCalibrator(dataclasses.replace(
            self.k_config, revolutions_per_window=self.position_table_revolutions))

    def add_pulses(self, t_ns: int, count: float) -> None:
        """One gyro sample (stamp ns, cumulative pulses)."""
        self.k_tilde.add_pulses(t_ns, count)
        self.stations.add_pulses(t_ns, count)

    def add_rate_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One rate-table joint_states sample."""
        self.k_tilde.add_table_state(t_ns, angle_rad, rate_rad_s)
        self.stations.add_rate_table_state(t_ns, angle_rad, rate_rad_s)

    def add_rate_zero_index(self, t_ns: int) -> None:
        """One rate-table zero-index stamp."""
        self.k_tilde.add_zero_index(t_ns)

    def add_position_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One position-table joint_states sample."""
        self.stations.add_position_table_state(t_ns, angle_rad, rate_rad_s)
        if self._position_angle_rad is None and abs(rate_rad_s) < 1e-6:
            self._position_angle_rad = angle_rad

    def add_position_zero_index(self, t_ns: int) -> None:
        """One position-table zero-index stamp."""
        self.stations.add_position_zero_index(t_ns)

    def extend(self, *, pulses: tuple[ArrayLike, ArrayLike] | None = None,
               rate_table: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
               rate_zero_index_ns: ArrayLike | None = None,
               position_table: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
               position_zero_index_ns: ArrayLike | None = None) -> None:
        """Many samples of any streams at once (batch or bag replay); same as adding them
        one by one. Joint states are (t_ns, angle rad, rate rad/s); pulses (t_ns, count)."""
        empty3 = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
        pulses = pulses if pulses is not None else empty3[:2]
        rate_table = rate_table if rate_table is not None else empty3
        position_table = position_table if position_table is not None else empty3
        no_events = np.zeros(0, np.int64)
        self.k_tilde.extend_pulses(*pulses)
        self.k_tilde.extend_table_states(*rate_table)
        self.k_tilde.extend_zero_index(
            rate_zero_index_ns if rate_zero_index_ns is not None else no_events)
        self.stations.extend(pulses, position_table, position_zero_index_ns
                             if position_zero_index_ns is not None else no_events, rate_table)
        if self._position_angle_rad is None and len(position_table[0]):
            still = np.abs(np.asarray(position_table[2])) < 1e-6
            if np.any(still):
                self._position_angle_rad = float(np.asarray(position_table[1])[still][0])

    def process(self, *, flush: bool = False) -> tuple[CalibrationUpdate, list[Station]]:
        """Resolve what the streams allow: new K̃ windows/pairs and new stations."""
        return self.k_tilde.process(flush=flush), self.stations.process(flush=flush)

    def results(self) -> RbrlgResults:
        """K̃, θ, K, ω′ₑ + ω_B and ω_B as far as measured."""
        try:
            k_tilde = self.k_tilde.k_tilde()
            earth_bias = self.k_tilde.earth_plus_bias_deg_h()
        except InsufficientDataError:
            k_tilde = earth_bias = None
        fix_error, problem = None, ''
        if self.stations.stations and k_tilde is None:
            problem = 'θ waits for K̃ (the K̃ phase has not given enough window pairs yet).'
        elif self.stations.stations:
            try:
                fix_error = self.stations.fix_error_angle(k_tilde.value)  # type: ignore[union-attr]
            except InsufficientDataError as exc:
                problem = f'θ not reported: {exc}'
            else:
                alpha = math.degrees(fix_error.tilt_rad.value)
                if abs(alpha - self.nominal_tilt_deg) > self.tilt_tolerance_deg:
                    problem = (f'θ not reported: the fitted tilt α = {alpha:.3f}° is far from the '
                               f'nominal {self.nominal_tilt_deg:g}° (tolerance '
                               f'{self.tilt_tolerance_deg:g}°): wrong mounting, wrong K or '
                               'stations from another set-up.')
                    fix_error = None
        k = None
        if k_tilde is not None and fix_error is not None:
            k = scale_factor(k_tilde, fix_error.fix_error_angle_rad)
        bias = None
        if earth_bias is not None and fix_error is not None and math.isfinite(self.latitude_deg):
            earth = earth_rate_along_table_axis_deg_h(
                latitude_deg=self.latitude_deg, heading_deg=self.heading_deg,
                tilt_rad=fix_error.tilt_rad.value,
                position_table_angle_rad=self._position_angle_rad or 0.0)
            bias = Estimate(earth_bias.value - earth, earth_bias.std_uncertainty,
                            earth_bias.n_used, earth_bias.dof)
        return RbrlgResults(k_tilde, fix_error, k, earth_bias, bias, problem)


def calibrate_rbrlg(recording: object, *, latitude_deg: float = math.nan,
                    heading_deg: float = 0.0, position_table_revolutions: int = 1,
                    k_config: KTildeConfig | None = None) -> tuple[RbrlgResults, RbrlgCalibrator]:
    """Batch calibration of a two-axis recording (``sim_nodes.rbrlg.bench.TwoAxisRecording``
    or anything with the same array attributes)."""
    cal = RbrlgCalibrator(k_config or KTildeConfig(), position_table_revolutions,
                          latitude_deg, heading_deg)
    rec: Any = recording
    cal.extend(pulses=(rec.pulse_t_ns, rec.pulse_counts), rate_table=rec.rate_table,
               rate_zero_index_ns=rec.rate_zero_index_ns, position_table=rec.position_table,
               position_zero_index_ns=rec.position_zero_index_ns)
    cal.process(flush=True)
    return cal.results(), cal



def handoff_calibration(results: RbrlgResults, calibrator: RbrlgCalibrator, *,
                        source: str) -> GyroCalibration | None:
    """The INS hand-off record of a complete calibration (K̃, θ, K, bias), else None.

    Values are converted to SI (rad/pulse, rad, rad/s); the data span runs from the
    first accepted K̃ window to the last station.
    """
    if (results.k_tilde_arcsec_per_pulse is None or results.fix_error is None
            or results.scale_factor_arcsec_per_pulse is None or results.bias_deg_h is None):
        return None
    k_t, k = results.k_tilde_arcsec_per_pulse, results.scale_factor_arcsec_per_pulse
    theta = results.fix_error.fix_error_angle_rad
    stamps = [w.start_ns for w in calibrator.k_tilde.windows]
    stamps += [s.end_ns for s in calibrator.stations.stations]
    deg_h = math.radians(1.0) / 3600.0  # rad/s per °/h
    return GyroCalibration(
        k_tilde_rad_per_pulse=k_t.value * RAD_PER_ARCSEC,
        k_tilde_rad_per_pulse_std=k_t.std_uncertainty * RAD_PER_ARCSEC,
        bias_rad_s=results.bias_deg_h.value * deg_h,
        bias_rad_s_std=results.bias_deg_h.std_uncertainty * deg_h,
        window_pairs=k_t.n_used, stations=theta.n_used,
        data_start_stamp_ns=min(stamps), data_end_stamp_ns=max(stamps), source=source,
        scale_factor_rad_per_pulse=k.value * RAD_PER_ARCSEC,
        scale_factor_rad_per_pulse_std=k.std_uncertainty * RAD_PER_ARCSEC,
        fix_error_angle_rad=theta.value, fix_error_angle_rad_std=theta.std_uncertainty)
