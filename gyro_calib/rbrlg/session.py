"""The RBRLG method behind the shared front door (registry, CLI, bag calibration, hand-off).

Feeds :class:`~gyro_calib.rbrlg.calibration.RbrlgCalibrator` exactly as the calibration node
does from DDS, so a bag gives the same K̃, θ, K and bias offline as when it is replayed into
the node.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from gyro_calib import topics
from gyro_calib.config import field_defaults, read_method_file
from gyro_calib.errors import ConfigError
from gyro_calib.estimate import Estimate
from gyro_calib.rbrlg.calibration import RbrlgCalibrator, RbrlgResults, handoff_values
from gyro_calib.rbrlg.config import KTildeConfig, k_tilde_config_from_mapping
from gyro_calib.rbrlg.keys import METHOD
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.units import ARCSEC_PER_RAD, RAD_PER_ARCSEC

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Rejection

TOPICS = {topics.GYRO_PULSES: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_JOINT_STATES: 'sensor_msgs/msg/JointState',
          topics.RATE_TABLE_ZERO_INDEX: 'std_msgs/msg/Header',
          topics.POSITION_TABLE_JOINT_STATES: 'sensor_msgs/msg/JointState',
          topics.POSITION_TABLE_ZERO_INDEX: 'std_msgs/msg/Header'}

NODE_NAME = 'calibration_node'
MOUNT_SETTINGS = ('nominal_tilt_deg', 'tilt_tolerance_deg')
"""calibration_node parameters of the mount that are no K̃ window setting (RbrlgCalibrator)."""

DEG_H = math.radians(1.0) / 3600.0
"""rad/s per °/h."""


def rbrlg_calibrator(options: CalibrationOptions) -> RbrlgCalibrator:
    """The RBRLG calibrator with the user's settings.

    The calibrator with the user's settings: flags first, then the bench settings stored in
    the bag, then the defaults.
    """
    k_config = KTildeConfig()
    mount: dict[str, Any] = {}  # float values of MOUNT_SETTINGS
    if options.config_file is not None:
        values, _ = read_method_file(options.config_file, node_name=NODE_NAME,
                                     fields={**field_defaults(KTildeConfig),
                                             **dict.fromkeys(MOUNT_SETTINGS)})
        for name in MOUNT_SETTINGS:
            if name in values:
                value = values.pop(name)
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not 0 <= value <= 90:
                    raise ConfigError(f'{name} = {value!r} ° (config file '
                                      f'{options.config_file}) is invalid: it must be a number '
                                      'between 0 and 90 °.')
                mount[name] = float(value)
        k_config = k_tilde_config_from_mapping(values, source=str(options.config_file))
    prior, source = (prior_k_tilde(options.calibration_file)
                     if options.calibration_file is not None else (None, ''))
    return RbrlgCalibrator(
        k_config=k_config,
        position_table_revolutions=int(options.setting('position_table_revolutions', 1)),
        latitude_deg=options.latitude,
        heading_deg=float(options.setting('heading_deg', 0.0)), prior_k_tilde=prior,
        prior_k_tilde_source=source, **mount)


def prior_k_tilde(path: Path) -> tuple[Estimate, str]:
    """K̃ (″/pulse) from a hand-off file, for the θ phase of a run without a K̃ phase.

    Returns:
        The estimate (value, standard uncertainty, the window pairs it rests on) and where
        it came from (file, run and its source), for the hand-off conditions.

    Raises:
        HandoffError: the file cannot be read or holds no K̃.
    """
    from gyro_calib.handoff import load_calibration

    cal = load_calibration(path)
    value, std = cal.require('k_tilde_rad_per_pulse', why='θ and K of a run without a K̃ '
                             'phase take K̃ from the calibration file')
    pairs = int(cal.get('window_pairs') or 0)
    run = cal.methods.get(METHOD)
    where = f'{path}' + (f' (run {run.source})' if run is not None and run.source else '')
    return Estimate(value * ARCSEC_PER_RAD, std * ARCSEC_PER_RAD, pairs, max(pairs - 1, 0),
                    basis=f'from the calibration file {where}'), where


def feed_calibrator(calibrator: RbrlgCalibrator, batch: SampleBatch) -> None:
    """Hand a batch's streams to the calibrator.

    Pulses, both tables' joint_states and zero-index events: the one way offline sessions
    and calibration_node feed it.
    """
    pulses = batch.joint_state(topics.GYRO_PULSES)
    calibrator.extend(
        pulses=pulses[:2] if pulses is not None else None,
        rate_table=batch.joint_state(topics.RATE_TABLE_JOINT_STATES),
        rate_zero_index_ns=batch.stamps(topics.RATE_TABLE_ZERO_INDEX),
        position_table=batch.joint_state(topics.POSITION_TABLE_JOINT_STATES),
        position_zero_index_ns=batch.stamps(topics.POSITION_TABLE_ZERO_INDEX))


class RbrlgSession(MethodSession):
    """K̃, θ, K = K̃·cos θ and bias of a rate-biased RLG (METHODS §A)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Build the calibrator from the options."""
        self.calibrator = rbrlg_calibrator(options)
        self._rejections: list[Rejection] = []
        self._notices: list[str] = []

    @classmethod
    def around(cls, calibrator: RbrlgCalibrator) -> RbrlgSession:
        """A session view of a calibrator fed elsewhere (calibration_node's progress)."""
        session = cls.__new__(cls)
        session.calibrator = calibrator
        session._rejections, session._notices = [], []
        return session

    def topics(self) -> dict[str, str]:
        """The two-axis bench's streams."""
        return dict(TOPICS)

    def feed(self, batch: SampleBatch) -> None:
        """Pulses, both tables' joint_states and zero-index events of the batch."""
        feed_calibrator(self.calibrator, batch)

    def process(self, *, flush: bool = False) -> list[str]:
        """Resolve windows and stations; new rejections and notices as lines."""
        cal = self.calibrator
        n_station = len(cal.stations.rejections)
        update, _ = cal.process(flush=flush)
        new = list(update.rejections) + cal.stations.rejections[n_station:]
        self._rejections.extend(new)
        self._notices.extend(update.notices)
        return [f'rejected: {r.reason}' for r in new] + list(update.notices)

    @property
    def rbrlg_results(self) -> RbrlgResults:
        """K̃, θ, K, ω′ₑ + ω_B and bias as far as measured (″/pulse, rad, °/h)."""
        return self.calibrator.results()

    def results(self) -> dict[str, Estimate]:
        """By hand-off key, in SI."""
        r = self.rbrlg_results
        out: dict[str, Estimate] = {}

        def put(key: str, est: Estimate | None, scale: float) -> None:
            if est is not None:
                out[key] = _scaled(est, scale)

        put('k_tilde_rad_per_pulse', r.k_tilde_arcsec_per_pulse, RAD_PER_ARCSEC)
        put('scale_factor_rad_per_pulse', r.scale_factor_arcsec_per_pulse, RAD_PER_ARCSEC)
        put('fix_error_angle_rad', r.fix_error.fix_error_angle_rad if r.fix_error else None, 1.0)
        put('bias_plus_earth_rate_rad_s', r.earth_plus_bias_deg_h, DEG_H)
        put('bias_rad_s', r.bias_deg_h, DEG_H)
        return out

    def missing(self) -> dict[str, str]:
        """Why each RBRLG key is not measured (yet)."""
        return self.calibrator.missing()

    def needs(self) -> dict[str, str]:
        """K̃: how many more window pairs (and about how long); θ: how many more stations."""
        cal, res = self.calibrator, self.rbrlg_results
        k = cal.k_tilde
        out: dict[str, str] = {}
        if res.k_tilde_arcsec_per_pulse is None:
            more = max(k.config.min_pairs - len(k.pairs), 1)
            m = k.config.revolutions_per_window
            spent = [w.duration_s for w in k.windows]
            took = (f', about {2 * more * sum(spent) / len(spent):.0f} s of table motion'
                    if spent else '')
            out['k_tilde_rad_per_pulse'] = (
                f'K̃ needs {more} more forward/reverse window pair(s) ({m} revolutions each '
                f'way{took}); {len(k.pairs)} of {k.config.min_pairs} accepted')
        if res.fix_error is None and not self._theta_refused():
            n = len(cal.stations.stations)
            if n == 0 and not cal.position_table_seen:
                out['fix_error_angle_rad'] = ('θ needs 3 position-table stations of the '
                                              'four-position procedure; none seen yet')
            elif n < 3:
                out['fix_error_angle_rad'] = (f'θ needs {3 - n} more station(s) ({n} '
                                              'measured, 3 spread in β needed)')
            else:  # waits for K̃, or the stations are not spread in β yet
                out['fix_error_angle_rad'] = res.fix_error_problem
        if res.bias_deg_h is None and not math.isfinite(cal.latitude_deg):
            out['bias_rad_s'] = 'the bias needs latitude_deg (the Earth rate)'
        return out

    def _theta_refused(self) -> bool:
        """θ refused because the fitted tilt α is far from the mount's (a wrong set-up)."""
        return 'fitted tilt' in self.rbrlg_results.fix_error_problem

    def problems(self) -> list[str]:
        """Problems more data will not fix.

        θ refused by the stations' tilt (a wrong set-up: more data will not help), and the
        default (everything rejected).
        """
        refused = [self.rbrlg_results.fix_error_problem] if self._theta_refused() else []
        return refused + super().problems()

    def rejections(self) -> list[Rejection]:
        """Windows, events, pairs and stations rejected, with reasons."""
        return list(self._rejections)

    def notices(self) -> list[str]:
        """Stream restarts and the like."""
        return list(self._notices)

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first accepted K̃ window to the last station."""
        return self.calibrator.data_span_ns()

    def conditions(self) -> dict[str, Any]:
        """Latitude, heading (the bias rests on them) and n."""
        return self.calibrator.conditions()

    def not_measurable(self) -> dict[str, str]:
        """θ and K when the bench has no position table."""
        return self.calibrator.not_measurable()

    def handoff_values(self) -> dict[str, Any]:
        """The RBRLG hand-off keys (SI) with window and station counts."""
        return handoff_values(self.rbrlg_results, self.calibrator)

    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """K̃, θ, α, K, ω′ₑ + ω_B, bias in the units the bench uses (″/pulse, ″, °, °/h)."""
        r = self.rbrlg_results
        rows: list[tuple[str, str, str, str]] = []

        def add(name: str, est: Estimate | None, scale: float = 1.0, fmt: str = '.10f') -> None:
            if est is None:
                rows.append((name, '—', '', ''))
            else:
                rows.append((name, f'{est.value * scale:{fmt}}',
                             f'{est.std_uncertainty * scale:.3g}', str(est.n_used)))

        add('K̃ (″/pulse)', r.k_tilde_arcsec_per_pulse)
        add('θ (″)', r.fix_error.fix_error_angle_rad if r.fix_error else None,
            1.0 / RAD_PER_ARCSEC, '.3f')
        add('α (°)', r.fix_error.tilt_rad if r.fix_error else None, math.degrees(1.0), '.5f')
        add('K (″/pulse)', r.scale_factor_arcsec_per_pulse)
        add('ω′ₑ+ω_B (°/h)', r.earth_plus_bias_deg_h, fmt='.5f')
        add('bias ω_B (°/h)', r.bias_deg_h, fmt='.5f')
        return rows

    def summary_lines(self) -> list[str]:
        """Windows, pairs, stations; the basis of each uncertainty; what is missing."""
        cal = self.calibrator
        r = self.rbrlg_results
        lines = [f'K̃ windows accepted: {len(cal.k_tilde.windows)}, pairs: '
                 f'{len(cal.k_tilde.pairs)}; stations: {len(cal.stations.stations)}; '
                 f'rejected: {len(self._rejections)}']
        for name, est in (('K̃', r.k_tilde_arcsec_per_pulse), ('ω′ₑ+ω_B', r.earth_plus_bias_deg_h),
                          ('θ', r.fix_error.fix_error_angle_rad if r.fix_error else None)):
            if est is not None and est.basis:
                lines.append(f'{name} uncertainty: {est.basis}, {est.dof} degrees of freedom')
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def info_lines(self) -> list[str]:
        """The windows and stations the calibration would use."""
        cal = self.calibrator
        lines = [f'K̃ windows it would use: {len(cal.k_tilde.windows)} '
                 f'({len(cal.k_tilde.pairs)} forward/reverse pairs)']
        for w in cal.k_tilde.windows:
            lines.append(f'  t={w.start_ns / 1e9:.6f} s → {w.end_ns / 1e9:.6f} s  '
                         f'{w.direction * w.revolutions:+d} rev  N = {w.pulses:.3f} pulses')
        lines.append(f'θ stations it would use: {len(cal.stations.stations)}')
        for s in cal.stations.stations:
            lines.append(f'  β = {math.degrees(s.rate_table_angle_rad):.4f}°  '
                         f'N_og = {s.half_difference_pulses:.3f} pulses')
        return lines

    def limiting(self) -> str:
        """What limits the result most, as an action (issue 9 part 5)."""
        return self.calibrator.limiting_factor()

    def plot(self, out_dir: Path) -> list[Path]:
        """K̃ per pair with the running mean; the station fit N_og(β) with residuals."""
        from gyro_calib.rbrlg.plots import plot_rbrlg

        return plot_rbrlg(self.calibrator, out_dir)


def _scaled(est: Estimate, scale: float) -> Estimate:
    import dataclasses

    return dataclasses.replace(est, value=est.value * scale,
                               std_uncertainty=est.std_uncertainty * scale)
