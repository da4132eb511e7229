"""Was the bench's input rate constant? The table gate of a noise record (METHODS §E.1).

Noise characterisation (IEEE Std 952 Allan analysis) needs the gyro's input rate to be
*constant*: its output is then the noise plus a constant, and every Allan-family deviation
removes a constant rate (a linear phase cancels in every difference of eq. E.1-2). A rate
table turning at a constant rate Ω is therefore as good as one at rest — a rate-biased RLG
is operated, and its noise measured, that way — but a table that *changes* rate puts its
profile into the Allan variance: reversals between ±Ω every D seconds give σ(τ = D) ≈ 0.8·Ω
(a square wave: σ² = 2Ω²/3), and the fit reports the profile as "noise terms".

When the bag (or the live graph) carries a table's joint states (``/rate_table/joint_states``:
unwrapped encoder angle, rad; rate, rad/s), :class:`TableMotion` splits them into *steady
segments* — spans at one constant rate (rest is the rate 0) — and the calibrator analyses the
gyro samples inside each steady segment as a segment of its own, leaving out those between
(acceleration, reversal, stop), as a gap would split a record.

A table state joins the current steady segment when

- its rate lies within ``table_rest_rate_rad_s`` of the segment's mean rate
  (|ω − ω̄| ≤ ω_tol), and
- its angle lies within ``table_rest_angle_rad`` + |ω̂|·``table_stamp_jitter_s`` of the
  straight line fitted (least squares) through the segment's angles so far, extrapolated to
  its stamp (|θ − θ̂(t)| ≤ θ_tol): a rate change too slow for the rate test bends the angle
  away from the line (a constant acceleration a leaves the line by a·T²/12 after T), and
  a stamp jitter σ_t moves a turning table's angle off the line by |ω|·σ_t.

A state that does not join ends the segment and starts the next one. A segment is *steady*
once it spans ``table_min_steady_s`` (confirmed); a shorter one is part of the change around
it (a slow acceleration can look steady for a few states). The thresholds sit above the noise
of a table encoder: ±1 count is 0.75 µrad for the 2²³-count encoder of our benches and 6 µrad
for a coarse 2²⁰-count one, so θ_tol = 2·10⁻⁵ rad (4.1″) is more than three counts of the
coarsest; a rate differentiated from such an encoder flickers by one count per sample
interval at any constant rate, 0.75 µrad × 200 Hz = 1.5·10⁻⁴ rad/s up to 6 µrad × 1 kHz =
6·10⁻³ rad/s, so ω_tol = 10⁻² rad/s (0.57 °/s) is above it. Changes below both thresholds
are not detected (the summary states them).

The position table of the two-axis bench (``/position_table/joint_states``) carries the
tilted mount: its rotation sweeps the sense axis round a cone, so the Earth rate's projection
on the sense axis changes with the position angle — a signal, not a constant. Its steady
segments must therefore be *at rest* (``turning=False``: rate and line tested against rest,
the line flat through where the table came to rest), as the gate always required. Only the
rate table turns the sense axis about itself. :class:`TableGate` classifies every recorded
table from its own states and a gyro sample is analysed only when it lies in a steady
segment of every recorded table; a table never recorded holds nothing back.

A gyro sample lies in a steady segment when its stamp lies between (or on) two states of the
segment; before the first state the table is taken as in the first state, after the last as
in the last (zero-order hold). Samples are decided once a table state at or after their stamp
has arrived and the segment they fall in is confirmed or broken; the calibrator holds the
others (at most ``table_wait_s``). Before any table state has arrived there is no table on
the graph and every sample is analysed, as without one.

The rate table's encoder angle can also be subtracted from the gyro's angle (``table_reference
= gyro_minus_table``: K·counts − encoder angle, the sense axis along the table's axis, both
counting the same way): :meth:`TableMotion.angle_at` interpolates the angle linearly between
the states at each gyro stamp (along the segment's line beyond the first or last state), which
removes table-rate wander (servo wobble) that a constant rate does not.

Built from :mod:`~gyro_calib.noise.table_spans` (steady segments, the changes between, the
segment being built) and :mod:`~gyro_calib.noise.table_motion` (:class:`TableMotion`); this
module holds the topics and :class:`TableGate` and re-exports their names.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.table_motion import TableMotion
from gyro_calib.noise.table_spans import MotionSpan, SteadySegment

if TYPE_CHECKING:
    import numpy.typing as npt

    IntArray = npt.NDArray[np.int64]

RATE_TABLE_JOINT_STATES = '/rate_table/joint_states'
"""The rate table's joint states (the topic contract's name, repeated here so the noise
method imports no other)."""
POSITION_TABLE_JOINT_STATES = '/position_table/joint_states'
"""The two-axis bench's position table (topic contract; the same fields as the rate table's)."""
TABLE_NAMES = {RATE_TABLE_JOINT_STATES: 'rate table',
               POSITION_TABLE_JOINT_STATES: 'position table'}
"""Every table that gates the gyro samples, by topic, with the name the lines give it."""
TURNING_ALLOWED = {RATE_TABLE_JOINT_STATES: True, POSITION_TABLE_JOINT_STATES: False}
"""Whether a constant rotation of the table leaves the gyro's input rate constant (the rate
table turns the sense axis about itself; the position table sweeps it round a cone)."""

__all__ = ['POSITION_TABLE_JOINT_STATES', 'RATE_TABLE_JOINT_STATES', 'TABLE_NAMES',
           'TURNING_ALLOWED', 'MotionSpan', 'SteadySegment', 'TableGate', 'TableMotion']


@dataclass(slots=True)
class TableGate:
    """Every table the bench records (:data:`TABLE_NAMES`).

    A sample is analysed when it lies in a steady segment of each.

    Attributes:
        tables: each table's :class:`TableMotion`, by topic (rate table first).
    """

    tables: dict[str, TableMotion]

    @classmethod
    def create(cls, rest_rate_rad_s: float, rest_angle_rad: float, *,
               min_steady_s: float = 1.0, stamp_jitter_s: float = 0.0,
               keep_angles: bool = False) -> TableGate:
        """A gate over every table of :data:`TABLE_NAMES`, each with the same thresholds.

        The rate table keeps its angles when ``keep_angles`` (gyro minus table angle).
        """
        return cls({topic: TableMotion(rest_rate_rad_s, rest_angle_rad, min_steady_s,
                                       stamp_jitter_s, TURNING_ALLOWED[topic],
                                       keep_angles and topic == RATE_TABLE_JOINT_STATES)
                    for topic in TABLE_NAMES})

    def recorded(self) -> list[tuple[str, TableMotion]]:
        """The tables a state arrived from, as (topic, motion), rate table first."""
        return [(topic, tm) for topic, tm in self.tables.items() if tm.seen]

    @property
    def seen(self) -> bool:
        """A state of some table has arrived: the gate is active."""
        return any(tm.seen for tm in self.tables.values())

    def decide(self, t_ns: IntArray, *, final: bool,
               hold_unseen: bool = False) -> tuple[int, IntArray]:
        """:meth:`TableMotion.decide` over every table.

        Returns (n, seg): the first n stamps every recorded table decides are decided;
        seg[k, j] is the steady segment of table j (in :attr:`tables` order) stamp k lies in
        (−1: a change, −2: table j not recorded). A stamp is analysed when no entry is −1.
        With ``hold_unseen`` nothing is decided before a table state arrives (unless final).
        """
        n = 0 if hold_unseen and not final and not self.seen else len(t_ns)
        cols = []
        for tm in self.tables.values():
            k, seg = tm.decide(t_ns, final=final)
            n = min(n, k)
            cols.append(seg)
        return n, np.stack([c[:n] for c in cols], axis=1)

    def moved_within(self, start_ns: int, end_ns: int) -> list[tuple[str, float]]:
        """The tables with a stretch left out within [start_ns, end_ns].

        As (topic, largest |rate| rad/s).
        """
        return [(topic, tm.span_max_rate(start_ns, end_ns)) for topic, tm in self.recorded()
                if tm.overlaps(start_ns, end_ns)]
