"""The triad method behind the shared front door: /imu/pulses and the tables → K, s_i, M, b.

Whole-revolution windows are cut per channel by the shared §A machinery
(:mod:`gyro_calib.windows`: a local fit of each channel's counts and of the encoder at every
zero-index event, §A eq. (2a)), on the rate table (inner axis, u = F·e_z, or u = ±e_j of the
mount on a single-axis table) and on the position table (outer axis, u = F·u_T(β) of METHODS
§F eq. (1), β the rate-table encoder angle held at the station + ψ₀). Consecutive forward and
reverse windows about one direction form a :class:`~gyro_calib.triad.estimator.TriadPair`
(eqs. (5)–(6)); :func:`~gyro_calib.triad.estimator.triad_calibration` solves the rows with the
tilt α fitted (its stated uncertainty as prior) and the biases with the Earth rate removed
(eqs. (13)–(14)). A channel's window is rejected for that channel alone, with a line (too few
samples, a glitch, or a count rate below ``min_pulse_rate_hz``: a rate-biased RLG locked in
about that direction); a channel whose directions do not span 3-D is not measurable.

The remount variant (single-axis table) is several bags, one mount each, fed one after the
other (:meth:`TriadSession.start_bag`; the bench setting ``mount_axis`` stored per bag).

The pieces: :mod:`~gyro_calib.triad.settings` (settings, bench), :mod:`~gyro_calib.triad.intake`
(the bench topics, per bag), :mod:`~gyro_calib.triad.cutting` (windows per channel),
:mod:`~gyro_calib.triad.pairing` (forward/reverse pairs), :mod:`~gyro_calib.triad.solve` (the
rows with the tilt fitted), :mod:`~gyro_calib.triad.results` (estimates, rows, ``imu:``); this
module runs them as the shared session and re-exports their names.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.config import field_defaults, read_method_file
from gyro_calib.errors import ConfigError
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.triad.cutting import (
    INNER,
    MIN_COUNT_STD_PULSES,
    OUTER,
    TriadWindow,
    combine_windows,
    cut_windows,
)
from gyro_calib.triad.intake import HEADER, JOINT_STATE, TOPICS, Segment, add_batch
from gyro_calib.triad.keys import METHOD
from gyro_calib.triad.kinematics import REMOUNT_AXES, inner_axis_direction
from gyro_calib.triad.pairing import pair_windows
from gyro_calib.triad.quantisation import quantisation_floor
from gyro_calib.triad.results import (
    DEG_H,
    count_walk_line,
    dof_line,
    estimates,
    imu_section,
    missing_of,
    not_measurable_of,
    summary_rows,
)
from gyro_calib.triad.settings import Bench, TriadSettings, triad_settings_from_mapping
from gyro_calib.triad.solve import solve_pairs
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S, RAD_PER_ARCSEC

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection
    from gyro_calib.handoff import Calibration
    from gyro_calib.imu_calibration import ImuCalibration
    from gyro_calib.triad.count_noise import CountWalk
    from gyro_calib.triad.records import TriadPair, TriadResult

__all__ = ['DEG_H', 'HEADER', 'INNER', 'JOINT_STATE', 'MIN_COUNT_STD_PULSES', 'NODE_NAME',
           'OUTER', 'TOPICS', 'Bench', 'TriadSession', 'TriadSettings', 'TriadWindow',
           'combine_windows', 'cut_windows', 'imu_section', 'pair_windows',
           'quantisation_floor', 'triad_settings_from_mapping']

NODE_NAME = 'triad_calibration_node'


class TriadSession(MethodSession):
    """K_i, sense axes s_i, M and biases of a gyro triad (METHODS §F)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Settings: config file, node parameters; bench: flags, config, stored, default."""
        values: dict[str, Any] = {k: v for k, v in options.settings.items()
                                  if k in {f.name for f in dataclasses.fields(TriadSettings)}}
        if options.config_file is not None:
            from_file, _ = read_method_file(options.config_file, node_name=NODE_NAME,
                                            fields=field_defaults(TriadSettings))
            values.update(from_file)
        source = str(options.config_file) if options.config_file is not None else 'settings'
        settings = triad_settings_from_mapping(values, source=source)
        stored_m = options.bench('revolutions_per_window', None)
        if stored_m is not None and 'revolutions_per_window' not in values:
            settings = dataclasses.replace(settings, revolutions_per_window=int(stored_m))
        self.settings = settings
        self.options = options
        tilt = float(options.setting('tilt_deg', math.nan))
        fixture = options.bench('fixture_rotation', None)
        try:
            f = np.eye(3) if fixture is None else np.asarray(fixture, dtype=np.float64)
            inner_axis_direction(f)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f'fixture_rotation {fixture!r:.80} is invalid: {exc}') from None
        self.bench = Bench(
            tilt_rad=math.radians(tilt),
            tilt_std_rad=float(options.setting('tilt_std_arcsec', 60.0)) * RAD_PER_ARCSEC,
            station_offset_rad=math.radians(float(options.setting('station_offset_deg', 0.0))),
            fixture=f, latitude_deg=options.latitude,
            heading_deg=float(options.setting('heading_deg', 0.0)))
        self.channels: tuple[str, str, str] = ('x', 'y', 'z')
        self._segments = [Segment('the bag', self._mount_of(0))]
        self._rejections: list[Rejection] = []
        self._lines: list[str] = []
        self._pairs: list[tuple[TriadPair, str]] = []
        self._result: TriadResult | None = None
        self._walk: CountWalk | None = None
        self._problem = ''
        self._analysed_to_ns: int | None = None
        self._newest_ns: int | None = None
        self._dirty = self._fed = False
        self._last_end_ns = 0

    # -- input ------------------------------------------------------------------------------
    def _mount_of(self, index: int) -> str:
        benches = self.options.stored_benches
        if benches:
            bench = benches[index][1] if index < len(benches) else {}
        else:
            bench = self.options.scenario.get('bench', {}) if isinstance(
                self.options.scenario, dict) else {}
        axis = bench.get('mount_axis', '') if isinstance(bench, dict) else ''
        given_axis = self.options.config_bench.get('mount_axis') or self.options.settings.get(
            'mount_axis')
        axis = str(given_axis or axis or '')
        if axis and axis not in REMOUNT_AXES:
            raise ConfigError(f'mount_axis = {axis!r} is invalid: it must be one of '
                              f'{", ".join(REMOUNT_AXES)}.')
        return axis

    def _check_one_procedure(self, first: Path) -> None:
        """Two-axis and remount bags are not one calibration: refused before their data.

        Raises:
            ConfigError: the bags mix a remount (``mount_axis``) and a two-axis bench.
        """
        benches = self.options.stored_benches
        mounts = [self._mount_of(i) for i in range(len(benches))] if benches else []
        if any(mounts) and not all(mounts):
            at = next(i for i, m in enumerate(mounts) if m)
            two_axis = next(benches[i][0] for i, m in enumerate(mounts) if not m)
            raise ConfigError(f'{benches[at][0]} is a remount bag (mount_axis {mounts[at]}) and '
                              f'{two_axis} is not (no mount_axis: the two-axis bench); the two '
                              'procedures are calibrated separately: give the remount bags '
                              'together, and the two-axis bag alone.')

    def topics(self) -> dict[str, str]:
        """/imu/pulses and both tables' streams."""
        return dict(TOPICS)

    def start_bag(self, index: int, path: Path) -> None:
        """Bag ``index`` is a new mount (remount variant): its windows are cut on their own."""
        seg = self._segments[-1]
        if index == 0:
            seg.label = str(path)
            seg.mount_axis = self._mount_of(0)
            self._check_one_procedure(path)
            return
        self._segments.append(Segment(str(path), self._mount_of(index)))
        self._dirty = True

    def feed(self, batch: SampleBatch) -> None:
        """The samples of the batch (3-channel /imu/pulses, tables, zero-index events)."""
        names, newest = add_batch(self._segments[-1], batch)
        if names is not None:
            self.channels = names
        if newest is not None:
            self._seen(newest)
        if any(len(c) for c in batch.columns.values()):
            self._dirty = self._fed = True

    def _seen(self, stamp: int) -> None:
        self._newest_ns = stamp if self._newest_ns is None else max(self._newest_ns, stamp)
        self._dirty = self._fed = True

    # -- processing -------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Cut windows and pairs and solve (at the end, and live).

        Live: every ``analysis_period_s`` of data, and whenever the input paused (nothing fed
        since the last call), so the numbers at the end of the data are the offline ones.
        """
        fed, self._fed = self._fed, False
        if not self._dirty:
            return []
        if not flush and fed and self._analysed_to_ns is not None \
                and self._newest_ns is not None and self._newest_ns - self._analysed_to_ns \
                < self.settings.analysis_period_s * NS_PER_S:
            return []
        self._analyse(flush)
        self._dirty = False
        self._analysed_to_ns = self._newest_ns
        lines, self._lines = self._lines, []
        return lines

    def _analyse(self, final: bool) -> None:
        rejections: list[Rejection] = []
        pairs: list[tuple[TriadPair, str]] = []
        last_end = 0
        s = self.settings
        for seg in self._segments:
            p = seg.pulses.arrays(3)
            rate = seg.rate.arrays(2)
            position = seg.position.arrays(2)
            r_idx = seg.rate_index.arrays(1)[0]
            p_idx = seg.position_index.arrays(1)[0]
            windows: list[TriadWindow] = []
            if len(p[0]) and len(rate[0]) and len(r_idx):
                cut, rej = cut_windows(s, s.revolutions_per_window, self.channels, p, rate,
                                       r_idx, axis=INNER)
                got, rej2 = combine_windows(s, self.channels, cut, axis=INNER, other=position,
                                            pulses=p)
                windows += got
                rejections += rej + rej2
            if len(p[0]) and len(position[0]) and len(p_idx) and not seg.mount_axis:
                n = int(self.options.setting('position_table_revolutions', 1))
                cut, rej = cut_windows(s, n, self.channels, p, position, p_idx, axis=OUTER)
                got, rej2 = combine_windows(s, self.channels, cut, axis=OUTER, other=rate,
                                            pulses=p)
                windows += got
                rejections += rej + rej2
            made, rej3, end = pair_windows(s, self.bench, windows, mount_axis=seg.mount_axis,
                                      final=final or seg is not self._segments[-1])
            pairs += made
            last_end = max(last_end, end)
            rejections += rej3
        new = [r for r in rejections if r not in self._rejections]
        self._lines += [f'rejected: {r.reason}' for r in new]
        self._rejections = rejections
        self._pairs = pairs
        self._last_end_ns = last_end
        self._result, self._problem = None, ''  # no stale result should the solve raise
        self._result, self._problem, self._walk = solve_pairs(
            pairs, self.channels, self.bench.tilt_std_rad, s.stated_arw_rad_sqrt_s())

    # -- results ----------------------------------------------------------------------------
    @property
    def triad_result(self) -> TriadResult | None:
        """The estimator's result (None before any pair)."""
        return self._result

    @property
    def pairs(self) -> list[tuple[TriadPair, str]]:
        """The pairs used, each with its direction's label."""
        return list(self._pairs)

    def plot(self, out_dir: Path) -> list[Path]:
        """Each pair's residual of eq. (8) per channel (:mod:`gyro_calib.triad.plots`)."""
        from gyro_calib.triad.plots import plot_triad

        return plot_triad(self._result, self.pairs, out_dir)

    def results(self) -> dict[str, Estimate]:
        """K and the bias of each channel, by ``imu.<channel>.<key>``."""
        return estimates(self._result)


    def missing(self) -> dict[str, str]:
        """Why K, s, M or b are not measured."""
        return missing_of(self._result, self._problem)

    def not_measurable(self) -> dict[str, str]:
        """The rows whose directions do not span 3-D (no more data of this bench helps)."""
        return not_measurable_of(self._result)

    def rejections(self) -> list[Rejection]:
        """Windows, events and pairs rejected, with reasons."""
        return list(self._rejections)

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the start of the first paired window to the end of the last."""
        if not self._pairs:
            return None
        return min(p.stamp_ns for p, _ in self._pairs), self._last_end_ns

    def conditions(self) -> dict[str, Any]:
        """The bench settings the result rests on."""
        b = self.bench
        return {'latitude_deg': b.latitude_deg, 'heading_deg': b.heading_deg,
                'tilt_deg': math.degrees(b.tilt_rad),
                'tilt_std_arcsec': b.tilt_std_rad * ARCSEC_PER_RAD,
                'station_offset_deg': math.degrees(b.station_offset_rad),
                'revolutions_per_window': self.settings.revolutions_per_window,
                'mount_axis': ','.join(s.mount_axis for s in self._segments if s.mount_axis)}

    def handoff_values(self) -> dict[str, Any]:
        """None at the top level: the results are the ``imu:`` section (:meth:`handoff`)."""
        return {}

    def imu_calibration(self) -> ImuCalibration | None:
        """The hand-off's ``imu:`` section from the result (None before any result)."""
        r = self._result
        if r is None:
            return None
        return imu_section(r, self.channels, self.bench.fixture)

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's record: no top-level keys, the ``imu:`` section (format 4)."""
        import dataclasses as dc

        from gyro_calib.handoff import Provenance, method_calibration

        imu = self.imu_calibration()
        span = self.data_span_ns()
        if imu is None or span is None:
            return None
        conditions = {k: v for k, v in self.conditions().items()
                      if isinstance(v, str) and v or isinstance(v, (int, float))
                      and not isinstance(v, bool) and math.isfinite(v)}
        cal = method_calibration(self.name, {}, Provenance(
            source, span[0], span[1], conditions=conditions,
            settings=dict(self.run_settings)), gyro_id=gyro_id)
        return dc.replace(cal, imu=imu)

    # -- presentation -----------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """K_i (″/pulse, u in ppm), misalignments (″), M (rad/pulse), biases (°/h)."""
        return summary_rows(self._result)

    def summary_lines(self) -> list[str]:
        """Pairs per direction, the uncertainty's basis, what is not measured."""
        labels: dict[str, int] = {}
        for _, label in self._pairs:
            labels[label] = labels.get(label, 0) + 1
        lines = [f'pairs: {len(self._pairs)} (' + ', '.join(f'{k}: {v}' for k, v in
                                                            labels.items()) + ')'
                 + f'; rejected: {len(self._rejections)}']
        r = self._result
        if r is not None and r.basis:
            lines.append(f'uncertainty: {r.basis}; Birge ratio {r.birge_ratio:.3g}')
        if r is not None and self._walk is not None:
            lines.append(count_walk_line(self._walk, self.channels))
        if r is not None:
            dof = dof_line(r)
            if dof:
                lines.append(dof)
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def json_section(self) -> dict[str, Any]:
        """The shared results and rejections, and the ``imu:`` section."""
        out = super().json_section()
        imu = self.imu_calibration()
        if imu is not None:
            out['imu'] = imu.to_section()
        return out
