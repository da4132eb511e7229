"""The window and fit settings of whole-revolution windows (METHODS §A.2), declared once.

:class:`WindowFields` holds the fields with their defaults and range checks (the base of the
rbrlg ``KTildeConfig`` and the triad ``TriadSettings``); :class:`WindowSettings` is what the
window machinery reads of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from gyro_calib.config import RangeCheck

TWO_PI = 2.0 * math.pi


class WindowSettings(Protocol):
    """The window and fit settings the cutter reads (rbrlg KTildeConfig, triad TriadSettings).

    The fields of :class:`WindowFields` and ``window_angle_source``.
    """

    @property
    def revolutions_per_window(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def fit_half_width_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def fit_order(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def min_fit_samples_per_side(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def max_fit_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_fit_residual_pulses(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def rate_tolerance(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def min_rate_deg_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def window_angle_tolerance_arcsec(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def index_angle_tolerance_arcsec(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_table_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_pulse_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def pulse_jump_tolerance_pulses(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def window_angle_source(self) -> str:
        """'encoder' or 'nominal' (see rbrlg KTildeConfig)."""


@dataclass(frozen=True, slots=True)
class WindowFields:
    """The window and fit settings of whole-revolution windows (METHODS §A.2), declared once.

    The base of the rbrlg ``KTildeConfig`` and the triad ``TriadSettings``: these fields come
    first in both, in this order, with these defaults; each method adds its own fields and
    checks them all at once with :meth:`window_checks` first.
    """

    revolutions_per_window: int = 5
    """m: whole revolutions in one window."""
    fit_half_width_s: float = 0.1
    """Half-width of the local least-squares fit of counts around an index instant, s."""
    fit_order: int = 1
    """Polynomial order of that fit (1 = line; 2 absorbs slow rate ripple)."""
    min_fit_samples_per_side: int = 20
    """Pulse samples needed on each side of an index instant."""
    max_fit_gap_s: float = 0.01
    """Largest gap between pulse samples allowed inside a fit span, s."""
    max_fit_residual_pulses: float = 5.0
    """Largest residual of the local fit before the index event is rejected, pulses."""
    rate_tolerance: float = 0.005
    """Allowed relative deviation of the table rate from its window median."""
    min_rate_deg_s: float = 1.0
    """Slowest table rate a window may be cut at, °/s."""
    window_angle_tolerance_arcsec: float = 60.0
    """Allowed |encoder angle of a window − m·360°|, ″ (encoder resolution + index jitter)."""
    index_angle_tolerance_arcsec: float = 30.0
    """Allowed distance of an index event's encoder angle from the reference mark, ″."""
    max_table_gap_s: float = 0.1
    """Largest gap in joint_states inside a window, s."""
    max_pulse_gap_s: float = 0.5
    """Largest gap in the pulse stream inside a window, s."""
    pulse_jump_tolerance_pulses: float = 10.0
    """Allowed step of a pulse increment from the window's median rate, pulses.

    Plus rate_tolerance.
    """

    def window_checks(self, *, angle_within_half_turn: bool,
                      jump_may_be_zero: bool) -> list[RangeCheck]:
        """The range checks of these fields, in field order (for ``check_ranges``).

        ``angle_within_half_turn``: window_angle_tolerance_arcsec must stay below half a
        revolution (else only positive); ``jump_may_be_zero``: pulse_jump_tolerance_pulses
        may be 0 (else positive).
        """
        angle: RangeCheck = (
            ('window_angle_tolerance_arcsec', 0 < self.window_angle_tolerance_arcsec < 648000,
             'between 0 and 648000 (half a revolution)') if angle_within_half_turn else
            ('window_angle_tolerance_arcsec', self.window_angle_tolerance_arcsec > 0,
             'positive'))
        jump: RangeCheck = (
            ('pulse_jump_tolerance_pulses', self.pulse_jump_tolerance_pulses >= 0,
             'non-negative') if jump_may_be_zero else
            ('pulse_jump_tolerance_pulses', self.pulse_jump_tolerance_pulses > 0, 'positive'))
        return [
            ('revolutions_per_window', self.revolutions_per_window >= 1, 'at least 1'),
            ('fit_half_width_s', self.fit_half_width_s > 0, 'positive'),
            ('fit_order', self.fit_order in (1, 2), '1 or 2'),
            ('min_fit_samples_per_side', self.min_fit_samples_per_side >= 2, 'at least 2'),
            ('max_fit_gap_s', self.max_fit_gap_s > 0, 'positive'),
            ('max_fit_residual_pulses', self.max_fit_residual_pulses > 0, 'positive'),
            ('rate_tolerance', 0 < self.rate_tolerance < 1, 'between 0 and 1'),
            ('min_rate_deg_s', self.min_rate_deg_s > 0, 'positive'),
            angle,
            ('index_angle_tolerance_arcsec', self.index_angle_tolerance_arcsec > 0, 'positive'),
            ('max_table_gap_s', self.max_table_gap_s > 0, 'positive'),
            ('max_pulse_gap_s', self.max_pulse_gap_s > 0, 'positive'),
            jump,
        ]

