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
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate
from gyro_calib.rbrlg.calibrator import CalibrationUpdate, RateBiasCalibrator
from gyro_calib.rbrlg.config import KTildeConfig
from gyro_calib.rbrlg.scale_factor import scale_factor
from gyro_calib.rbrlg.stations import Station, StationCalibrator
from gyro_calib.units import EARTH_RATE_DEG_H, RAD_PER_ARCSEC

if TYPE_CHECKING:

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
    prior_k_tilde: Estimate | None = None
    """K̃ (″/pulse) from an earlier run's hand-off file, for θ and K when this run's own K̃
    phase gives none (its own K̃, once measured, is used instead)."""
    prior_k_tilde_source: str = ''
    """Where :attr:`prior_k_tilde` came from (file and run), for the hand-off conditions."""
    _position_angle_rad: float | None = None
    """χ of the position table at rest (first still sample): where the K̃ phase ran."""
    _position_table_seen: bool = False
    """Any position-table sample at all (else the rate table is taken as a plain, vertical one)."""

    def conditions(self) -> dict[str, float | int | str]:
        """The bench settings the results rest on.

        The bench settings the results rest on (the bias: latitude and heading), for the
        hand-off file (NaN: not given).
        """
        out: dict[str, float | int | str] = {
            'latitude_deg': self.latitude_deg, 'heading_deg': self.heading_deg,
            'position_table_revolutions': self.position_table_revolutions}
        if self.prior_k_tilde is not None and self.k_tilde_own() is None:
            out['k_tilde_for_theta_from'] = self.prior_k_tilde_source
        return out

    def k_tilde_own(self) -> Estimate | None:
        """This run's own K̃ (″/pulse), or None while its K̃ phase has not given it."""
        try:
            return self.k_tilde.k_tilde()
        except InsufficientDataError:
            return None

    def not_measurable(self) -> dict[str, str]:
        """θ and K of a bench without a position table, with why.

        θ and K of a bench without a position table (a plain rate table gives K̃ only),
        with why; {} once any position-table sample came.
        """
        if self._position_table_seen:
            return {}
        keys = ('fix_error_angle_rad', 'scale_factor_rad_per_pulse', 'stations')
        return {k: v for k, v in self.missing().items() if k in keys}

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
        self._position_table_seen = True
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
        """Many samples of any streams at once.

        Many samples of any streams at once (batch or bag replay); same as adding them
        one by one. Joint states are (t_ns, angle rad, rate rad/s); pulses (t_ns, count).
        """
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
        if np.size(position_table[0]):
            self._position_table_seen = True
        if self._position_angle_rad is None and np.size(position_table[0]):
            still = np.abs(np.asarray(position_table[2])) < 1e-6
            if np.any(still):
                self._position_angle_rad = float(np.asarray(position_table[1])[still][0])

    def process(self, *, flush: bool = False) -> tuple[CalibrationUpdate, list[Station]]:
        """Resolve what the streams allow: new K̃ windows/pairs and new stations."""
        return self.k_tilde.process(flush=flush), self.stations.process(flush=flush)

    def results(self) -> RbrlgResults:
        """K̃, θ, K, ω′ₑ + ω_B and ω_B as far as measured."""
        k_tilde: Estimate | None
        earth_bias: Estimate | None
        try:
            k_tilde = self.k_tilde.k_tilde()
            earth_bias = self.k_tilde.earth_plus_bias_deg_h()
        except InsufficientDataError:
            k_tilde = earth_bias = None
        fix_error, problem = None, ''
        k_for_theta = k_tilde if k_tilde is not None else self.prior_k_tilde
        if self.stations.stations and k_for_theta is None:
            problem = ('θ waits for K̃ (the K̃ phase has not given enough window pairs yet; '
                       'a hand-off file holding K̃ can give it: --calibration FILE, node '
                       'parameter calibration_file).')
        elif self.stations.stations and k_for_theta is not None:
            try:
                fix_error = self.stations.fix_error_angle(k_for_theta.value)
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
        if k_for_theta is not None and fix_error is not None:
            k = scale_factor(k_for_theta, fix_error.fix_error_angle_rad)
        bias = None
        tilt = self._table_axis_tilt_rad(fix_error)
        if earth_bias is not None and tilt is not None and math.isfinite(self.latitude_deg):
            earth = earth_rate_along_table_axis_deg_h(
                latitude_deg=self.latitude_deg, heading_deg=self.heading_deg,
                tilt_rad=tilt, position_table_angle_rad=self._position_angle_rad or 0.0)
            bias = dataclasses.replace(earth_bias, value=earth_bias.value - earth)
        return RbrlgResults(k_tilde, fix_error, k, earth_bias, bias, problem)

    def _table_axis_tilt_rad(self, fix_error: FixErrorAngleResult | None) -> float | None:
        """Tilt of the rate-table axis from the vertical, rad.

        Tilt of the rate-table axis from the vertical: α from the stations, 0 for a plain
        rate table (no position table in the data), None while a two-axis bench has no α.
        """
        if fix_error is not None:
            return fix_error.tilt_rad.value
        return None if self._position_table_seen else 0.0

    @property
    def position_table_seen(self) -> bool:
        """True once a position-table sample or mark arrived (the four-position procedure)."""
        return self._position_table_seen

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet), for every RBRLG quantity."""
        res = self.results()
        out: dict[str, str] = {}
        cal = self.k_tilde
        if res.k_tilde_arcsec_per_pulse is None:
            why = (f'K̃ needs {cal.config.min_pairs} forward/reverse window pairs; '
                   f'{len(cal.pairs)} accepted from {len(cal.windows)} windows '
                   f'({len(cal.rejections)} rejections): {self.limiting_factor()}')
            out['k_tilde_rad_per_pulse'] = why
            out['bias_plus_earth_rate_rad_s'] = why
        if res.fix_error is None:
            if res.fix_error_problem:
                why = res.fix_error_problem
            elif not self._position_table_seen:
                why = ('θ needs the position-table stations of the four-position procedure; the '
                       'data hold no position-table samples (a plain rate table gives K̃ only).')
            else:
                why = (f'θ needs at least 3 position-table stations spread in β; '
                       f'{len(self.stations.stations)} measured.')
            out['fix_error_angle_rad'] = why
            out['scale_factor_rad_per_pulse'] = f'K = K̃·cos θ needs θ: {why}'
        if res.bias_deg_h is None:
            if not math.isfinite(self.latitude_deg):
                out['bias_rad_s'] = ('the bias needs the site latitude (--latitude-deg, node '
                                     'parameter latitude_deg) to remove the Earth rate; '
                                     'bias_plus_earth_rate_rad_s holds both.')
            elif res.earth_plus_bias_deg_h is None:
                out['bias_rad_s'] = 'the bias needs the K̃ windows (see k_tilde_rad_per_pulse).'
            else:
                out['bias_rad_s'] = ('the bias needs the tilt α of the rate-table axis, which '
                                     'the θ stations give (see fix_error_angle_rad).')
        return out

    def data_span_ns(self) -> tuple[int, int] | None:
        """First accepted K̃ window start to the last window end or station end, or None."""
        stamps = [w.start_ns for w in self.k_tilde.windows] + [w.end_ns for w in
                                                                self.k_tilde.windows]
        stamps += [s.start_ns for s in self.stations.stations]
        stamps += [s.end_ns for s in self.stations.stations]
        return (min(stamps), max(stamps)) if stamps else None

    def limiting_factor(self) -> str:
        """One line saying what limits the result most.

        One line saying what limits the result most, as something the user can change
        (issue 9 part 5).
        """
        cal = self.k_tilde
        m = cal.config.revolutions_per_window
        reasons = [r.reason for r in cal.rejections]
        accel = sum('table accelerating' in r for r in reasons)
        short = [r for r in reasons if 'no window in the constant-rate cruise' in r]
        missing_ev = sum('missing zero-index event' in r for r in reasons)
        gaps = sum('gap' in r for r in reasons)
        if len(cal.pairs) < cal.config.min_pairs:
            if not cal.windows and short:
                return (f'no cruise held m = {m} revolutions between usable zero-index events: '
                        f'give the table at least m + 1 revolutions of cruise between reversals '
                        f'(or lower revolutions_per_window); {accel} event(s) fell in '
                        'accelerations.')
            if missing_ev:
                return (f'{missing_ev} missing zero-index event(s): check the index detector and '
                        'its cabling.')
            if gaps:
                return f'{gaps} window(s) lost to gaps in the streams: check the data link.'
            if len(cal.windows) < 2 * cal.config.min_pairs:
                return (f'{len(cal.windows)} window(s) in the data: record at least '
                        f'{cal.config.min_pairs} forward/reverse cycles.')
            return ('windows did not pair (same direction, or too far apart in time): alternate '
                    'the direction each cruise.')
        runs = _windows_per_run(cal.windows)
        res = self.results()
        if runs and max(runs) == 1 and len(cal.pairs) < 10:
            return (f'one window per cruise ({len(cal.pairs)} pairs): give the table ≥ {2 * m} '
                    f'revolutions of cruise for two windows per cruise, or record more cycles.')
        if res.fix_error is None and self._position_table_seen:
            return res.fix_error_problem or 'θ: fewer than 3 stations spread in β.'
        k = res.k_tilde_arcsec_per_pulse
        assert k is not None
        if k.dof < 4:
            return (f'K̃ rests on {k.n_used} pairs ({k.dof} degrees of freedom; uncertainty: '
                    f'{k.basis}): record more reversal cycles, or give '
                    'angle_random_walk_deg_sqrt_h so the prediction is complete.')
        if res.fix_error is not None and res.fix_error.fix_error_angle_rad.dof < 4:
            th = res.fix_error.fix_error_angle_rad
            return (f'θ rests on {th.n_used} stations ({th.dof} degree(s) of freedom; '
                    f'uncertainty: {th.basis}): add stations (e.g. 8 at 45° steps).')
        return (f'K̃ from {k.n_used} pairs, relative uncertainty '
                f'{k.relative_uncertainty:.2g} ({k.basis}).')


def _windows_per_run(windows: list[Any]) -> list[int]:
    """Windows cut in each direction run (consecutive windows of one direction)."""
    out: list[int] = []
    last = 0
    for w in windows:
        if out and w.direction == last:
            out[-1] += 1
        else:
            out.append(1)
        last = w.direction
    return out


def calibrate_rbrlg(recording: object, *, latitude_deg: float = math.nan,
                    heading_deg: float = 0.0, position_table_revolutions: int = 1,
                    k_config: KTildeConfig | None = None) -> tuple[RbrlgResults, RbrlgCalibrator]:
    """Batch calibration of a two-axis recording.

    Batch calibration of a two-axis recording (``sim_nodes.rbrlg.bench.TwoAxisRecording``
    or anything with the same array attributes).
    """
    cal = RbrlgCalibrator(k_config or KTildeConfig(), position_table_revolutions,
                          latitude_deg, heading_deg)
    rec: Any = recording
    cal.extend(pulses=(rec.pulse_t_ns, rec.pulse_counts), rate_table=rec.rate_table,
               rate_zero_index_ns=rec.rate_zero_index_ns, position_table=rec.position_table,
               position_zero_index_ns=rec.position_zero_index_ns)
    cal.process(flush=True)
    return cal.results(), cal



def handoff_values(results: RbrlgResults, calibrator: RbrlgCalibrator) -> dict[str, Any]:
    """The RBRLG hand-off keys of whatever was measured.

    The RBRLG hand-off keys of whatever was measured, in SI (rad/pulse, rad, rad/s), each
    with its ``_std``, plus the window-pair and station counts; {} when neither K̃ nor θ
    is measured (θ and K without this run's K̃ rest on a calibration file's K̃).
    """
    if results.k_tilde_arcsec_per_pulse is None and results.fix_error is None:
        return {}
    deg_h = math.radians(1.0) / 3600.0  # rad/s per °/h
    out: dict[str, Any] = {}

    def put(key: str, est: Estimate | None, scale: float) -> None:
        if est is not None:
            out[key] = est.value * scale
            out[key + '_std'] = est.std_uncertainty * scale
            out[key + '_dof'] = est.supported_dof

    put('k_tilde_rad_per_pulse', results.k_tilde_arcsec_per_pulse, RAD_PER_ARCSEC)
    put('scale_factor_rad_per_pulse', results.scale_factor_arcsec_per_pulse, RAD_PER_ARCSEC)
    put('fix_error_angle_rad',
        results.fix_error.fix_error_angle_rad if results.fix_error else None, 1.0)
    put('bias_plus_earth_rate_rad_s', results.earth_plus_bias_deg_h, deg_h)
    put('bias_rad_s', results.bias_deg_h, deg_h)
    if results.k_tilde_arcsec_per_pulse is not None:
        out['window_pairs'] = results.k_tilde_arcsec_per_pulse.n_used
    if results.fix_error:  # absent with θ: no stations measured nothing
        out['stations'] = results.fix_error.fix_error_angle_rad.n_used
    return out
