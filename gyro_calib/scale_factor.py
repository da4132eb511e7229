"""Scale factor of a rate-biased RLG from forward/reverse window pairs (METHODS §A.2).

    K̃ = 2592000·m / (N⁺ − N⁻)                 eq. (3), ″/pulse
    K  = K̃·cos θ                               eq. (4)
    ω'_e + ω_B = K̃·(N⁺ + N⁻) / (T⁺ + T⁻)       from eqs. (1)+(2), ″/s = °/h

Forward minus reverse cancels Earth rate and bias; their sum measures them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gyro_calib.errors import InsufficientDataError, WindowError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.units import ARCSEC_PER_REV
from gyro_calib.windows import RevolutionWindow, format_stamp


@dataclass(frozen=True, slots=True)
class WindowPair:
    """One forward and one reverse window and what they measure.

    Attributes:
        forward, reverse: the two windows.
        k_tilde_arcsec_per_pulse: K̃ by eq. (3), ″/pulse.
        k_tilde_std: standard uncertainty of K̃ from the window end fits, ″/pulse.
        earth_plus_bias_deg_h: ω'_e + ω_B (projected on og), °/h.
    """

    forward: RevolutionWindow
    reverse: RevolutionWindow
    k_tilde_arcsec_per_pulse: float
    k_tilde_std: float
    earth_plus_bias_deg_h: float


def k_tilde_from_windows(forward: RevolutionWindow, reverse: RevolutionWindow) -> WindowPair:
    """K̃ and the Earth-rate + bias term from one forward/reverse pair (eq. 3).

    Raises:
        WindowError: if the windows are not one forward and one reverse of equal m, or
            N⁺ − N⁻ is zero.
    """
    if forward.direction != 1 or reverse.direction != -1:
        raise WindowError('a K̃ pair needs one forward (+1) and one reverse (−1) window.')
    if forward.revolutions != reverse.revolutions:
        raise WindowError(f'windows of {forward.revolutions} and {reverse.revolutions} '
                          'revolutions cannot be paired.')
    diff = forward.pulses - reverse.pulses
    if diff == 0.0:
        raise WindowError('N⁺ − N⁻ is zero: the gyro gave no pulses.')
    angle = 2.0 * ARCSEC_PER_REV * forward.revolutions
    k_tilde = angle / diff
    k_std = abs(k_tilde) * math.hypot(forward.pulses_std, reverse.pulses_std) / abs(diff)
    total_s = forward.duration_s + reverse.duration_s
    earth_bias = k_tilde * (forward.pulses + reverse.pulses) / total_s
    return WindowPair(forward, reverse, k_tilde, k_std, earth_bias)


def scale_factor(k_tilde: Estimate, fix_error_angle_rad: Estimate) -> Estimate:
    """K = K̃·cos θ (eq. 4) with the uncertainty of both propagated (first order).

    u(K)² = (cos θ·u(K̃))² + (K̃·sin θ·u(θ))², in the unit of ``k_tilde``.
    """
    c, s = math.cos(fix_error_angle_rad.value), math.sin(fix_error_angle_rad.value)
    value = k_tilde.value * c
    std = math.hypot(c * k_tilde.std_uncertainty,
                     k_tilde.value * s * fix_error_angle_rad.std_uncertainty)
    return Estimate(value, std, min(k_tilde.n_used, fix_error_angle_rad.n_used),
                    min(k_tilde.dof, fix_error_angle_rad.dof),
                    k_tilde.rejected + fix_error_angle_rad.rejected)


def mean_estimate(values: list[float], rejected: tuple[Rejection, ...] = ()) -> Estimate:
    """Mean with its Type A standard uncertainty s/√n (GUM 4.2).

    Raises:
        InsufficientDataError: with fewer than two values.
    """
    n = len(values)
    if n < 2:
        raise InsufficientDataError(f'{n} value(s) cannot give a mean with an uncertainty; '
                                    'need at least 2.')
    arr = np.asarray(values, dtype=np.float64)
    ref = float(arr[0])
    dev = arr - ref
    mean = ref + float(np.mean(dev))
    std = float(np.std(dev, ddof=1)) / math.sqrt(n)
    return Estimate(mean, std, n, n - 1, rejected)


@dataclass(slots=True)
class PairAccumulator:
    """Pairs consecutive opposite-direction windows and keeps every accepted pair.

    Attributes:
        max_pair_gap_s: longest time from the end of one window to the start of the next
            for the two to be paired, s.
        run_of: optional map from a stamp (ns) to the table run it belongs to; windows of
            different runs are never paired (position-table stations).
    """

    max_pair_gap_s: float
    run_of: Callable[[int], int] | None = None
    pairs: list[WindowPair] = field(default_factory=list)
    rejections: list[Rejection] = field(default_factory=list)
    _pending: RevolutionWindow | None = None

    def add_window(self, window: RevolutionWindow) -> WindowPair | None:
        """Take the next window in time order; return the pair it completes, if any."""
        pending = self._pending
        if pending is None:
            self._pending = window
            return None
        gap_s = (window.start_ns - pending.end_ns) / 1e9
        other_run = (self.run_of is not None
                     and self.run_of(pending.start_ns) != self.run_of(window.start_ns))
        if pending.direction == window.direction or gap_s > self.max_pair_gap_s or other_run:
            if pending.direction == window.direction:
                why = 'followed by another window in the same direction'
            elif other_run:
                why = 'the table run it belongs to ended before an opposite window'
            else:
                why = f'next window starts {gap_s:.1f} s later (limit {self.max_pair_gap_s:g} s)'
            self.rejections.append(Rejection(
                pending.start_ns, f'window at {format_stamp(pending.start_ns)} left unpaired: {why}.'))
            self._pending = window
            return None
        forward, reverse = (pending, window) if pending.direction == 1 else (window, pending)
        self._pending = None
        pair = k_tilde_from_windows(forward, reverse)
        self.pairs.append(pair)
        return pair

    def drop_pending(self) -> None:
        """Forget a window still waiting for its partner (stream restart)."""
        self._pending = None

    def k_tilde(self) -> Estimate:
        """Mean K̃ over the pairs, ″/pulse, with s/√n.

        Raises:
            InsufficientDataError: with fewer than two pairs.
        """
        return mean_estimate([p.k_tilde_arcsec_per_pulse for p in self.pairs],
                             tuple(self.rejections))

    def earth_plus_bias(self) -> Estimate:
        """Mean ω'_e + ω_B along og over the pairs, °/h.

        Raises:
            InsufficientDataError: with fewer than two pairs.
        """
        return mean_estimate([p.earth_plus_bias_deg_h for p in self.pairs])
