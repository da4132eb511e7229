"""Scale factor of a rate-biased RLG from forward/reverse window pairs (METHODS §A.2).

    K̃ = 2592000·m / (N⁺ − N⁻)                 eq. (3), ″/pulse
    K  = K̃·cos θ                               eq. (4)
    ω'_e + ω_B = K̃·(N⁺ + N⁻) / (T⁺ + T⁻)       from eqs. (1)+(2), ″/s = °/h

Forward minus reverse cancels Earth rate and bias; their sum measures them. The
windows' swept angles A± come from the encoder (the index synchronisation error P± of
eq. (5) is then measured, not ignored) and their durations T± may differ (a table whose
forward and reverse rates differ); eqs. (1)–(2) with A±, T± solve exactly to

    K̃ = (A⁺·T⁻ + A⁻·T⁺) / (N⁺·T⁻ − N⁻·T⁺),    ω'_e + ω_B = (K̃·(N⁺ + N⁻) − (A⁺ − A⁻)) / (T⁺ + T⁻)

which is eq. (3) when A⁺ = A⁻ = 1296000·m and T⁺ = T⁻.

Uncertainty (issue 9 part 4): each pair carries the standard uncertainty predicted from
its window-end fits (counts and encoder angles) and, when the gyro's angle random walk
is given, the ARW over the windows. A mean over pairs reports the larger of the scatter
s/√n and that prediction; when the prediction lacks a source (ARW unknown) the scatter
is widened by the Student-t factor of its n − 1 degrees of freedom, so ±1σ covers the
truth about 68 % of the time even from two pairs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gyro_calib.errors import InsufficientDataError, WindowError
from gyro_calib.estimate import Estimate, Rejection, student_t_factor
from gyro_calib.units import ARCSEC_PER_RAD, ARCSEC_PER_REV, format_stamp
from gyro_calib.windows import RevolutionWindow


@dataclass(frozen=True, slots=True)
class WindowPair:
    """One forward and one reverse window and what they measure.

    Attributes:
        forward, reverse: the two windows.
        k_tilde_arcsec_per_pulse: K̃ (eq. 3, generalised to A±, T±), ″/pulse.
        k_tilde_std: its standard uncertainty predicted from the window-end fits (and the
            ARW, when given), ″/pulse.
        earth_plus_bias_deg_h: ω'_e + ω_B (projected on og), °/h.
        earth_plus_bias_std: its predicted standard uncertainty, °/h.
        prediction_complete: True when the prediction covers every error source the model
            has (the ARW was given); False when only the fits are in it.
    """

    forward: RevolutionWindow
    reverse: RevolutionWindow
    k_tilde_arcsec_per_pulse: float
    k_tilde_std: float
    earth_plus_bias_deg_h: float
    earth_plus_bias_std: float = 0.0
    prediction_complete: bool = False


def k_tilde_from_windows(forward: RevolutionWindow, reverse: RevolutionWindow, *,
                         arw_arcsec_sqrt_s: float = math.nan) -> WindowPair:
    """K̃ and the Earth-rate + bias term from one forward/reverse pair (eq. 3, generalised).

    Args:
        forward: the forward window (encoder angle, counts, duration).
        reverse: the reverse window, likewise.
        arw_arcsec_sqrt_s: the gyro's angle random walk, ″/√s (NaN: unknown; then the
            predicted uncertainty holds the fits only).

    Raises:
        WindowError: if the windows are not one forward and one reverse of equal m, or
            N⁺ − N⁻ is zero.
    """
    if forward.direction != 1 or reverse.direction != -1:
        raise WindowError('a K̃ pair needs one forward (+1) and one reverse (−1) window.')
    if forward.revolutions != reverse.revolutions:
        raise WindowError(f'windows of {forward.revolutions} and {reverse.revolutions} '
                          'revolutions cannot be paired.')
    a_p = forward.swept_angle_rad * ARCSEC_PER_RAD
    a_m = reverse.swept_angle_rad * ARCSEC_PER_RAD
    if math.isnan(forward.angle_rad) or math.isnan(reverse.angle_rad):  # nominal windows
        a_p = a_m = ARCSEC_PER_REV * forward.revolutions
    t_p, t_m = forward.duration_s, reverse.duration_s
    n_p, n_m = forward.pulses, reverse.pulses
    denom = n_p * t_m - n_m * t_p
    if denom == 0.0:
        raise WindowError('N⁺ − N⁻ is zero: the gyro gave no pulses.')
    numer = a_p * t_m + a_m * t_p
    k_tilde = numer / denom
    total_s = t_p + t_m
    earth_bias = (k_tilde * (n_p + n_m) - (a_p - a_m)) / total_s
    complete = math.isfinite(arw_arcsec_sqrt_s)
    arw = arw_arcsec_sqrt_s if complete else 0.0
    var_n_p = forward.pulses_std**2 + arw * arw * t_p / k_tilde**2
    var_n_m = reverse.pulses_std**2 + arw * arw * t_m / k_tilde**2
    var_a_p = (forward.angle_std_rad * ARCSEC_PER_RAD) ** 2
    var_a_m = (reverse.angle_std_rad * ARCSEC_PER_RAD) ** 2
    k_var = ((t_m * t_m * var_a_p + t_p * t_p * var_a_m) / denom**2
             + numer**2 * (t_m * t_m * var_n_p + t_p * t_p * var_n_m) / denom**4)
    eb_var = (k_tilde**2 * (var_n_p + var_n_m) + var_a_p + var_a_m) / total_s**2
    return WindowPair(forward, reverse, k_tilde, math.sqrt(k_var), earth_bias,
                      math.sqrt(eb_var), complete)


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


def mean_estimate(values: list[float], rejected: tuple[Rejection, ...] = (), *,
                  predicted_std: list[float] | None = None,
                  prediction_complete: bool = True) -> Estimate:
    """Mean with an honest standard uncertainty (GUM 4.2, issue 9 part 4).

    Without ``predicted_std``: the Type A s/√n with n − 1 degrees of freedom. With it (the
    standard uncertainty of each value predicted from its own fits): the larger of s/√n and
    rms(predicted)/√n; when the prediction is incomplete the scatter is first widened by the
    Student-t factor of its n − 1 degrees of freedom. ``Estimate.basis`` says which.

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
    scatter = float(np.std(dev, ddof=1)) / math.sqrt(n)
    if predicted_std is None:
        return Estimate(mean, scatter, n, n - 1, rejected, f'scatter of {n}')
    predicted = math.sqrt(float(np.mean(np.square(predicted_std)))) / math.sqrt(n)
    widen = 1.0 if prediction_complete else student_t_factor(n - 1)
    if widen * scatter >= predicted:
        basis = (f'scatter of {n}' if widen == 1.0 else
                 f'scatter of {n} × Student t {widen:.3f} ({n - 1} dof)')
        return Estimate(mean, widen * scatter, n, n - 1, rejected, basis)
    return Estimate(mean, predicted, n, n - 1, rejected,
                    f'predicted from the fits of {n} (scatter {scatter:.3g} smaller)')


@dataclass(slots=True)
class PairAccumulator:
    """Pairs forward with reverse windows, oldest first, and keeps every accepted pair.

    Windows of one direction wait in a queue (a cruise long enough for several windows
    gives several); each opposite window pairs with the oldest waiting one, so every
    window of a balanced run is used.

    Attributes:
        max_pair_gap_s: longest time from the end of one window to the start of its partner,
            s; at least the two windows' own durations (slow tables have long windows).
        run_of: optional map from a stamp (ns) to the table run it belongs to; windows of
            different runs are never paired (position-table stations).
        arw_arcsec_sqrt_s: the gyro's angle random walk, ″/√s, for the predicted uncertainty
            (NaN: unknown).
    """

    max_pair_gap_s: float
    run_of: Callable[[int], int] | None = None
    arw_arcsec_sqrt_s: float = math.nan
    pairs: list[WindowPair] = field(default_factory=list)
    rejections: list[Rejection] = field(default_factory=list)
    _queue: list[RevolutionWindow] = field(default_factory=list)

    def _gap_limit_s(self, a: RevolutionWindow, b: RevolutionWindow) -> float:
        return max(self.max_pair_gap_s, a.duration_s + b.duration_s)

    def _unpaired(self, window: RevolutionWindow, why: str) -> None:
        self.rejections.append(Rejection(
            window.start_ns, f'window at {format_stamp(window.start_ns)} left unpaired: {why}.'))

    def add_window(self, window: RevolutionWindow) -> WindowPair | None:
        """Take the next window in time order; return the pair it completes, if any."""
        while self._queue:
            head = self._queue[0]
            gap_s = (window.start_ns - head.end_ns) / 1e9
            other_run = (self.run_of is not None
                         and self.run_of(head.start_ns) != self.run_of(window.start_ns))
            if other_run:
                self._unpaired(self._queue.pop(0), 'the table run it belongs to ended before '
                               'an opposite window')
            elif gap_s > self._gap_limit_s(head, window):
                self._unpaired(self._queue.pop(0), (
                    f'the next opposite window could start no earlier than {gap_s:.1f} s later '
                    f'(limit {self._gap_limit_s(head, window):.1f} s: max_pair_gap_s or the two '
                    'windows\' durations)'))
            elif head.direction == window.direction:
                break
            else:
                self._queue.pop(0)
                forward, reverse = (head, window) if head.direction == 1 else (window, head)
                pair = k_tilde_from_windows(forward, reverse,
                                            arw_arcsec_sqrt_s=self.arw_arcsec_sqrt_s)
                self.pairs.append(pair)
                return pair
        self._queue.append(window)
        return None

    def drop_pending(self) -> None:
        """Forget windows still waiting for a partner (stream restart)."""
        self._queue.clear()

    def k_tilde(self) -> Estimate:
        """Mean K̃ over the pairs, ″/pulse, with its honest uncertainty (see mean_estimate).

        Raises:
            InsufficientDataError: with fewer than two pairs.
        """
        return mean_estimate([p.k_tilde_arcsec_per_pulse for p in self.pairs],
                             tuple(self.rejections),
                             predicted_std=[p.k_tilde_std for p in self.pairs],
                             prediction_complete=all(p.prediction_complete for p in self.pairs))

    def earth_plus_bias(self) -> Estimate:
        """Mean ω'_e + ω_B along og over the pairs, °/h.

        Raises:
            InsufficientDataError: with fewer than two pairs.
        """
        return mean_estimate([p.earth_plus_bias_deg_h for p in self.pairs],
                             predicted_std=[p.earth_plus_bias_std for p in self.pairs],
                             prediction_complete=all(p.prediction_complete for p in self.pairs))
