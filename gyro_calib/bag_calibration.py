"""Calibrate a recorded bag offline, streaming it through the same core as the live node.

:func:`calibrate_bag` decodes the bag batch by batch (:func:`gyro_calib.bag.iter_sample_batches`)
and feeds :class:`~gyro_calib.rbrlg.calibration.RbrlgCalibrator` exactly as the
calibration node does from DDS, so a bag gives the same K̃, θ, K and bias offline as
when it is replayed into the node.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from gyro_calib import topics
from gyro_calib.bag import BagInfo, bag_info, check_calibration_topics, iter_sample_batches
from gyro_calib.estimate import Rejection
from gyro_calib.rbrlg.calibration import RbrlgCalibrator, RbrlgResults


@dataclass(slots=True)
class BagCalibration:
    """The outcome of calibrating one bag.

    Attributes:
        info: the bag's topics, counts, span and scenario.
        results: K̃, θ, K, bias as far as measured.
        calibrator: the calibrator (windows, pairs, stations, rejections).
        rejections: every rejected window, event or station, with its reason.
        notices: stream events worth reporting (restarts...).
        messages: messages decoded.
    """

    info: BagInfo
    results: RbrlgResults
    calibrator: RbrlgCalibrator
    rejections: list[Rejection]
    notices: list[str]
    messages: int

    @property
    def windows_accepted(self) -> int:
        """Rate-table windows accepted for K̃."""
        return len(self.calibrator.k_tilde.windows)

    @property
    def calibrated_anything(self) -> bool:
        """True when at least K̃ was measured."""
        return self.results.k_tilde_arcsec_per_pulse is not None


def calibrate_bag(path: str | Path, calibrator: RbrlgCalibrator | None = None, *,
                  progress: Callable[[float], None] | None = None,
                  batch_messages: int = 50_000) -> BagCalibration:
    """Stream the bag at ``path`` through the calibration (METHODS §A: eqs. 3, 4, 15–18).

    ``calibrator`` carries the bench settings (m, n, site, tilt tolerance), as the node's
    parameters do; a default one is used when None. ``progress`` is called with the
    fraction of the bag's log-time span done.

    Raises:
        BagError (subclass): missing path, not a bag, damaged bag, missing topic, wrong
            message type, empty bag — before any result exists.
    """
    info = bag_info(path)
    check_calibration_topics(info)
    cal = calibrator if calibrator is not None else RbrlgCalibrator()
    rejections: list[Rejection] = []
    notices: list[str] = []
    span = max(info.end_ns - info.start_ns, 1)
    messages = 0
    for batch in iter_sample_batches(path, batch_messages=batch_messages):
        js, ev = batch.joint_states, batch.events
        pulses = js.get(topics.GYRO_PULSES)
        cal.extend(pulses=pulses[:2] if pulses is not None else None,
                   rate_table=js.get(topics.RATE_TABLE_JOINT_STATES),
                   rate_zero_index_ns=ev.get(topics.RATE_TABLE_ZERO_INDEX),
                   position_table=js.get(topics.POSITION_TABLE_JOINT_STATES),
                   position_zero_index_ns=ev.get(topics.POSITION_TABLE_ZERO_INDEX))
        _collect(cal, rejections, notices, flush=False)
        messages += batch.messages
        if progress is not None:
            progress(min(1.0, (batch.last_log_time_ns - info.start_ns) / span))
    _collect(cal, rejections, notices, flush=True)
    if progress is not None:
        progress(1.0)
    return BagCalibration(info, cal.results(), cal, rejections, notices, messages)


def _collect(cal: RbrlgCalibrator, rejections: list[Rejection], notices: list[str], *,
             flush: bool) -> None:
    n_station_rejections = len(cal.stations.rejections)
    update, _ = cal.process(flush=flush)
    rejections.extend(update.rejections)
    rejections.extend(cal.stations.rejections[n_station_rejections:])
    notices.extend(update.notices)
