"""Per-interval reduction of the pulse and temperature streams, and the model variables.

Hours of 1 kHz pulses are not kept: each stream is reduced on the fly to one row per
averaging interval [k·T, (k+1)·T) of absolute stamp time (so the grid never depends on
where a recording or a chunk starts):

- pulses: the count difference between the last sample at or before each boundary and
  its duration (int ns), so a block of intervals gives the exact mean rate
  K·ΣΔN/ΣΔt of the raw pulses — quantisation included, nothing smoothed;
- each temperature sensor: the mean of its readings inside the interval.

Each stream is reduced independently once its own stamps have passed an interval's end
by ``reorder_window_s`` (samples within that window may arrive out of order), so streams
may lag each other by any amount and results do not depend on chunking. Memory: the held
samples span about one interval plus the reorder window; the reduced rows grow by a few
numbers per interval (about 1 MB per day at T = 1 s).

:func:`thermal_variables` turns the joined table into H, Ḣ, ΔT_ab, ΔT_cs; Ḣ is a
*causal* least-squares slope over the last ``hdot_window_s`` (so a live corrector can
compute it the same way, METHODS §D.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.streams import StampedBuffer
from gyro_calib.thermal.topics import SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL, SENSORS
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike


@dataclass(frozen=True, slots=True)
class IntervalSettings:
    """How the streams are reduced to intervals and checked.

    Attributes:
        averaging_interval_s: T, s.
        hdot_window_s: span of the causal slope giving Ḣ, s.
        reorder_window_s: samples may arrive this much later than newer ones, s.
        restart_backstep_s: a stamp this far back means the source restarted, s.
        max_pulse_gap_s: a larger gap between pulse samples invalidates its interval, s.
        max_rate_deg_s: a pulse step implying a faster rate is a count glitch, °/s.
        sensor_stuck_s: a sensor reading exactly constant this long while the others move
            is stuck, s.
        sensor_stuck_min_change_c: ... while the other cavity sensor (shell: H) moved at
            least this much, °C.
        max_temperature_gap_s: a temperature sensor is interpolated onto the intervals
            between two of its readings at most this far apart, s (METHODS §D.5).
    """

    averaging_interval_s: float = 1.0
    hdot_window_s: float = 60.0
    reorder_window_s: float = 1.0
    restart_backstep_s: float = 5.0
    max_pulse_gap_s: float = 1.0
    max_rate_deg_s: float = 100.0
    sensor_stuck_s: float = 300.0
    sensor_stuck_min_change_c: float = 0.5
    max_temperature_gap_s: float = 120.0

    @property
    def interval_ns(self) -> int:
        """T in int ns."""
        return int(round(self.averaging_interval_s * NS_PER_S))

    @property
    def hdot_window_n(self) -> int:
        """Intervals in the Ḣ window (at least 2)."""
        return max(2, int(round(self.hdot_window_s / self.averaging_interval_s)))


@dataclass(slots=True)
class _Rows:
    """Append-only columns, concatenated on demand."""

    parts: list[tuple[npt.NDArray[Any], ...]] = field(default_factory=list)
    _cache: tuple[npt.NDArray[Any], ...] | None = None

    def append(self, *cols: npt.NDArray[Any]) -> None:
        if len(cols[0]):
            self.parts.append(cols)
            self._cache = None

    def arrays(self, n_cols: int) -> tuple[npt.NDArray[Any], ...]:
        if self._cache is None:
            if not self.parts:
                self._cache = tuple(np.zeros(0) for _ in range(n_cols))
            else:
                self._cache = tuple(np.concatenate([p[i] for p in self.parts])
                                    for i in range(n_cols))
                self.parts = [self._cache]
        return self._cache


@dataclass(slots=True)
class _BadRun:
    """Consecutive bad intervals of one stream, merged into one rejection."""

    first_ns: int
    last_ns: int
    reason: str
    n: int


class PulseIntervals:
    """Reduces /gyro/pulses (stamp, cumulative count) to per-interval ΔN and Δt."""

    def __init__(self, settings: IntervalSettings, scale_factor_rad_per_pulse: float) -> None:
        """Create the stream buffer; ``scale_factor_rad_per_pulse`` only sets the glitch check."""
        self.settings = settings
        back = int(settings.restart_backstep_s * NS_PER_S)
        self.buffer = StampedBuffer(1, back)
        self._k_next: int | None = None
        self._rows = _Rows()
        self._bad: _BadRun | None = None
        self.rejections: list[Rejection] = []
        self.notices: list[str] = []
        self._max_pulses_per_s = (settings.max_rate_deg_s * math.pi / 180.0
                                  / scale_factor_rad_per_pulse)

    def extend(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many samples (bag chunk)."""
        if self.buffer.extend(t_ns, counts):
            self._restarted()

    def append(self, t_ns: int, count: float) -> None:
        """One sample (live)."""
        if self.buffer.append(t_ns, count):
            self._restarted()

    def _restarted(self) -> None:
        self.notices.append('/gyro/pulses restarted (stamps jumped back): the counter is '
                            're-anchored; reduced intervals are kept.')

    def reduce(self, *, flush: bool = False) -> int:
        """Reduce every interval the stream has passed; return how many rows were added."""
        t, v = self.buffer.arrays()
        if len(t) < 1:
            return 0
        c = v[:, 0]
        tint = self.settings.interval_ns
        first_k = int(t[0] // tint)
        self._k_next = first_k if self._k_next is None else max(self._k_next, first_k)
        newest = int(t[-1])
        if flush:  # the last interval ends at the newest sample (its end anchor)
            k_end = -(-newest // tint)
        else:
            k_end = (newest - int(self.settings.reorder_window_s * NS_PER_S)) // tint
        if k_end <= self._k_next:
            return 0
        ks = np.arange(self._k_next, k_end, dtype=np.int64)
        ends = np.minimum((ks + 1) * tint, newest)
        # ΔN and Δt between the last samples at or before consecutive boundaries; the first
        # start anchor is the oldest held sample (the previous end anchor)
        j = np.searchsorted(t, ends, side='right') - 1
        start = np.concatenate(([0], j[:-1]))
        dcount = c[j] - c[start]
        dt = t[j] - t[start]
        n = len(ks)
        has = j > start
        max_gap = np.zeros(n, np.int64)
        max_rate = np.zeros(n)
        if np.any(has):
            gaps = np.diff(t[:j[-1] + 1])
            step_rate = np.abs(np.diff(c[:j[-1] + 1])) / (gaps / NS_PER_S)
            idx = start[has]
            max_gap[has] = np.maximum.reduceat(gaps, idx)
            max_rate[has] = np.maximum.reduceat(step_rate, idx)
        gap_limit = int(self.settings.max_pulse_gap_s * NS_PER_S)
        # intervals with no sample at all lie inside a gap: their rate is unknown
        bad_gap = (~has) | (max_gap > gap_limit)
        bad_step = has & (max_rate > self._max_pulses_per_s)
        valid = ~(bad_gap | bad_step)
        self._rows.append(ks, np.where(valid, dcount, np.nan), np.where(valid, dt, 0))
        for i in range(n):
            if valid[i]:
                self._close_bad()
                continue
            reason = ('no pulse sample or a gap longer than max_pulse_gap_s = '
                      f'{self.settings.max_pulse_gap_s:g} s' if bad_gap[i] else
                      f'a pulse count step faster than max_rate_deg_s = '
                      f'{self.settings.max_rate_deg_s:g} °/s (counter glitch)')
            self._note_bad(int(ks[i] * tint), int((ks[i] + 1) * tint), reason)
        self._k_next = int(k_end)
        self.buffer.discard_before(int(t[j[-1]]))
        if flush:
            self._close_bad()
        return n

    def _note_bad(self, a_ns: int, b_ns: int, reason: str) -> None:
        if self._bad is not None and self._bad.reason == reason and self._bad.last_ns == a_ns:
            self._bad.last_ns, self._bad.n = b_ns, self._bad.n + 1
            return
        self._close_bad()
        self._bad = _BadRun(a_ns, b_ns, reason, 1)

    def _close_bad(self) -> None:
        if self._bad is None:
            return
        b = self._bad
        self.rejections.append(Rejection(b.first_ns, (
            f'/gyro/pulses from {format_stamp(b.first_ns)} to {format_stamp(b.last_ns)} '
            f'({b.n} interval(s)): {b.reason}; those intervals are not used.')))
        self._bad = None

    def keep_since(self, k: int) -> None:
        """Forget the reduced rows before interval ``k`` (live use keeps a window only)."""
        cols = self._rows.arrays(3)
        if len(cols[0]) and cols[0][0] < k:
            sel = cols[0] >= k
            self._rows = _Rows([tuple(c[sel] for c in cols)])

    def arrays(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                              npt.NDArray[np.int64]]:
        """Interval index k, ΔN (NaN if invalid) and Δt (int ns, 0 if invalid)."""
        k, dn, dt = self._rows.arrays(3)
        return k.astype(np.int64), dn.astype(np.float64), dt.astype(np.int64)


class TemperatureIntervals:
    """Reduces one temperature sensor to per-interval means."""

    def __init__(self, sensor: str, settings: IntervalSettings) -> None:
        """Create the sensor's stream buffer."""
        self.sensor = sensor
        self.settings = settings
        self.buffer = StampedBuffer(1, int(settings.restart_backstep_s * NS_PER_S))
        self._k_next: int | None = None
        self._rows = _Rows()
        self.n_messages = 0
        self.notices: list[str] = []

    def extend(self, t_ns: ArrayLike, celsius: ArrayLike) -> None:
        """Many readings of this sensor."""
        t = np.asarray(t_ns, np.int64)
        self.n_messages += len(t)
        if self.buffer.extend(t, celsius):
            self.notices.append(f'/gyro/temperature [{self.sensor}] restarted (stamps jumped '
                                'back); reduced intervals are kept.')

    def append(self, t_ns: int, celsius: float) -> None:
        """One reading."""
        self.n_messages += 1
        if self.buffer.append(t_ns, celsius):
            self.notices.append(f'/gyro/temperature [{self.sensor}] restarted (stamps jumped '
                                'back); reduced intervals are kept.')

    def reduce(self, *, flush: bool = False) -> int:
        """Reduce every interval the sensor has passed; return how many rows were added."""
        t, v = self.buffer.arrays()
        if not len(t):
            return 0
        tint = self.settings.interval_ns
        k_first = int(t[0] // tint)
        if self._k_next is None or k_first > self._k_next:
            self._k_next = k_first if self._k_next is None else max(self._k_next, k_first)
        newest = int(t[-1])
        if flush:
            k_end = newest // tint + 1
        else:
            k_end = (newest - int(self.settings.reorder_window_s * NS_PER_S)) // tint
        if k_end <= self._k_next:
            return 0
        n = int(k_end - self._k_next)
        cut = int(np.searchsorted(t, k_end * tint, side='left'))
        kk = t[:cut] // tint - self._k_next
        inside = kk >= 0
        sums = np.bincount(kk[inside], weights=v[:cut, 0][inside], minlength=n)
        counts = np.bincount(kk[inside], minlength=n)
        # mean stamp of the readings, as an offset from the interval start (ns)
        offsets = (t[:cut][inside] - (kk[inside] + self._k_next) * tint).astype(np.float64)
        off_sums = np.bincount(kk[inside], weights=offsets, minlength=n)
        with np.errstate(invalid='ignore', divide='ignore'):
            means = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
            mean_off = np.where(counts > 0, off_sums / np.maximum(counts, 1), np.nan)
        ks = np.arange(self._k_next, k_end, dtype=np.int64)
        self._rows.append(ks, means, counts.astype(np.float64), mean_off)
        self._k_next = int(k_end)
        self.buffer.discard_before(int(k_end * tint))
        return n

    def keep_since(self, k: int) -> None:
        """Forget the reduced rows before interval ``k`` (live use keeps a window only)."""
        cols = self._rows.arrays(4)
        if len(cols[0]) and cols[0][0] < k:
            sel = cols[0] >= k
            self._rows = _Rows([tuple(c[sel] for c in cols)])

    def keep_last(self, n: int) -> None:
        """Forget all but the last ``n`` reduced rows (live use keeps a window only)."""
        cols = self._rows.arrays(4)
        if len(cols[0]) > n:
            self._rows = _Rows([tuple(c[-n:] for c in cols)])

    def arrays(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """Interval index k and mean reading (NaN where the sensor was silent), °C."""
        k, m, _, _ = self._rows.arrays(4)
        return k.astype(np.int64), m.astype(np.float64)

    def stamped_arrays(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                      npt.NDArray[np.float64]]:
        """Per interval: count, mean reading and mean stamp offset.

        k, mean reading (°C, NaN where silent) and the mean stamp of those readings as
        an offset from the interval start (ns, NaN where silent).
        """
        k, m, _, off = self._rows.arrays(4)
        return k.astype(np.int64), m.astype(np.float64), off.astype(np.float64)


@dataclass(frozen=True, slots=True)
class IntervalTable:
    """The streams joined on the interval grid (contiguous k).

    Attributes:
        interval_s: T, s.
        k: interval indices; interval k spans [k·T, (k+1)·T) of stamp time.
        dcount: pulse count difference (NaN where invalid).
        dt_ns: its duration (0 where invalid).
        temperatures_c: per sensor name, the interval means (NaN where missing).
        temperature_offsets_ns: per sensor name, the mean stamp of the readings in each
            interval as an offset from its start, ns (NaN where missing; a sensor not
            listed counts as read at the interval centres).
    """

    interval_s: float
    k: npt.NDArray[np.int64]
    dcount: npt.NDArray[np.float64]
    dt_ns: npt.NDArray[np.int64]
    temperatures_c: dict[str, npt.NDArray[np.float64]]
    temperature_offsets_ns: dict[str, npt.NDArray[np.float64]] = field(default_factory=dict)

    @property
    def t_mid_ns(self) -> npt.NDArray[np.int64]:
        """Centre stamp of each interval, ns."""
        tint = int(round(self.interval_s * NS_PER_S))
        return self.k * tint + tint // 2

    def rate_rad_s(self, scale_factor_rad_per_pulse: float) -> npt.NDArray[np.float64]:
        """Raw mean rate of each interval, K·ΔN/Δt, rad/s (NaN where invalid)."""
        with np.errstate(invalid='ignore', divide='ignore'):
            return np.where(self.dt_ns > 0, scale_factor_rad_per_pulse * self.dcount
                            / (self.dt_ns / NS_PER_S), np.nan)

    def __len__(self) -> int:
        """Number of intervals."""
        return len(self.k)


def join_intervals(pulses: tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                 npt.NDArray[np.int64]] | None,
                   temperatures: dict[str, tuple[npt.NDArray[Any], ...]],
                   interval_s: float) -> IntervalTable:
    """Place every stream's rows on one contiguous interval grid (the union of their spans).

    ``temperatures`` maps a sensor to (k, means) or (k, means, stamp offsets ns)
    (:meth:`TemperatureIntervals.stamped_arrays`).
    """
    ks = [p[0] for p in [pulses] if p is not None and len(p[0])]
    ks += [cols[0] for cols in temperatures.values() if len(cols[0])]
    if not ks:
        return IntervalTable(interval_s, np.zeros(0, np.int64), np.zeros(0),
                             np.zeros(0, np.int64), {s: np.zeros(0) for s in temperatures})
    k0 = min(int(k[0]) for k in ks)
    k1 = max(int(k[-1]) for k in ks)
    n = k1 - k0 + 1
    dcount = np.full(n, np.nan)
    dt = np.zeros(n, np.int64)
    if pulses is not None and len(pulses[0]):
        dcount[pulses[0] - k0] = pulses[1]
        dt[pulses[0] - k0] = pulses[2]
    temps, offsets = {}, {}
    for name, cols in temperatures.items():
        k, m = cols[0], cols[1]
        col = np.full(n, np.nan)
        col[k - k0] = m
        temps[name] = col
        if len(cols) > 2:
            off = np.full(n, np.nan)
            off[k - k0] = cols[2]
            offsets[name] = off
    return IntervalTable(interval_s, np.arange(k0, k1 + 1, dtype=np.int64), dcount, dt, temps,
                         offsets)


def causal_slope(values: npt.NDArray[np.float64], window_n: int,
                 spacing_s: float) -> npt.NDArray[np.float64]:
    """Least-squares slope over the last ``window_n`` samples (this one included), per s.

    NaNs are skipped; a window needs more than half its samples finite, else NaN. Each
    window's sums are computed by ``np.correlate`` with fixed kernels, so a value depends
    only on its own window (the live tracker, holding just the last window, gets the
    same number as the offline pass over the whole recording).
    """
    y = np.asarray(values, np.float64)
    n = len(y)
    if n == 0:
        return np.zeros(0)
    ok = np.isfinite(y)
    pad = window_n - 1
    okp = np.concatenate((np.zeros(pad), ok.astype(np.float64)))
    yp = np.concatenate((np.zeros(pad), np.where(ok, y, 0.0)))
    x = np.arange(window_n, dtype=np.float64)
    m = np.correlate(okp, np.ones(window_n), 'valid')
    sx = np.correlate(okp, x, 'valid')
    sxx = np.correlate(okp, x * x, 'valid')
    sy = np.correlate(yp, np.ones(window_n), 'valid')
    sxy = np.correlate(yp, x, 'valid')
    den = m * sxx - sx * sx
    with np.errstate(invalid='ignore', divide='ignore'):
        slope = (m * sxy - sx * sy) / den / spacing_s
    return np.where((m > window_n / 2) & (den > 0), slope, np.nan)


@dataclass(frozen=True, slots=True)
class SensorSampling:
    """How one temperature sensor was read, from its interval rows.

    Attributes:
        sensor: its name.
        n_points: intervals holding at least one finite reading.
        typical_spacing_s: median spacing of those readings' mean stamps, s (NaN below two);
            about the averaging interval when the sensor is read faster than that.
        longest_gap_s: the longest spacing, s (NaN below two points).
        n_filled: intervals without a reading given a value by interpolation.
        n_bridged: gaps longer than 2.5 typical spacings (dropouts) that were bridged.
    """

    sensor: str
    n_points: int
    typical_spacing_s: float
    longest_gap_s: float
    n_filled: int
    n_bridged: int


def interpolate_sensor(col: npt.NDArray[np.float64], offsets_ns: npt.NDArray[np.float64] | None,
                       interval_s: float, max_gap_s: float, sensor: str = ''
                       ) -> tuple[npt.NDArray[np.float64], SensorSampling]:
    """Interpolate a sensor onto the intervals without a reading.

    Give each interval without a reading the sensor's value at the interval centre,
    linearly interpolated between the two readings around it when they lie at most
    ``max_gap_s`` apart (METHODS §D.5); intervals holding readings keep their mean.

    Each interval's readings count as one point at their mean stamp (``offsets_ns`` from
    the interval start; the interval centre where not given). Nothing is extrapolated:
    before the first and after the last reading the value stays NaN.
    """
    tint = interval_s * NS_PER_S
    fin = np.isfinite(col)
    off = np.full(len(col), 0.5 * tint) if offsets_ns is None else np.where(
        np.isfinite(offsets_ns), offsets_ns, 0.5 * tint)
    k_pts = np.nonzero(fin)[0]
    o_pts = off[fin]
    v_pts = col[fin]
    out = col.copy()
    if len(k_pts) < 2:
        return out, SensorSampling(sensor, len(k_pts), math.nan, math.nan, 0, 0)
    # every time is taken relative to a nearby reading (index differences × T + offsets), so
    # a value depends only on its neighbours, not on where the table starts: a live window
    # gives the offline numbers bit for bit
    spacing = (np.diff(k_pts) * tint + np.diff(o_pts)) / NS_PER_S
    typical = float(np.median(spacing))
    idx = np.arange(len(col))
    i = np.searchsorted(k_pts, idx, side='right')  # first reading after each interval
    inside = (~fin) & (i >= 1) & (i < len(k_pts))
    ii = i[inside]
    span = (k_pts[ii] - k_pts[ii - 1]) * tint + (o_pts[ii] - o_pts[ii - 1])
    gap_ok = span <= max_gap_s * NS_PER_S * (1 + 1e-12)
    fill = np.zeros(len(col), bool)
    rows = np.nonzero(inside)[0][gap_ok]
    fill[rows] = True
    a = ii[gap_ok] - 1
    into = (rows - k_pts[a]) * tint + (0.5 * tint - o_pts[a])
    out[rows] = v_pts[a] + (v_pts[a + 1] - v_pts[a]) * (into / span[gap_ok])
    bridged = (spacing > 2.5 * typical) & (spacing <= max_gap_s * (1 + 1e-12))
    return out, SensorSampling(sensor, len(k_pts), typical, float(spacing.max()),
                               int(np.count_nonzero(fill)), int(np.count_nonzero(bridged)))


def sensor_sampling(table: IntervalTable, settings: IntervalSettings
                    ) -> dict[str, SensorSampling]:
    """How each sensor of ``table`` was read (see :class:`SensorSampling`)."""
    return {name: interpolate_sensor(col, table.temperature_offsets_ns.get(name),
                                     table.interval_s, settings.max_temperature_gap_s,
                                     name)[1]
            for name, col in table.temperatures_c.items()}


@dataclass(frozen=True, slots=True)
class SensorCheck:
    """Temperatures after interpolation and the sensor checks, and what the checks found.

    Attributes:
        temperatures_c: per sensor, interval values (means, or interpolated between
            readings) with stuck spans set to NaN.
        rejections: stuck and silent spans, one whole sentence each.
        sampling: per sensor, how it was read and what interpolation filled.
        notes: whole sentences on what interpolation did.
    """

    temperatures_c: dict[str, npt.NDArray[np.float64]]
    rejections: tuple[Rejection, ...]
    sampling: dict[str, SensorSampling] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


def true_runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, end) index pairs of the True runs of ``mask``."""
    if not len(mask):
        return []
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.nonzero(d == 1)[0].tolist(), np.nonzero(d == -1)[0].tolist()))


def check_sensors(table: IntervalTable, settings: IntervalSettings) -> SensorCheck:
    """Interpolate each sensor, then find stuck and silent spans.

    Interpolate each sensor onto the intervals it has no reading in
    (:func:`interpolate_sensor`), then find stuck and silent spans; blank the stuck ones.

    A sensor is stuck over a run of intervals in which its value is exactly the same for
    at least ``sensor_stuck_s`` while the other cavity sensor (for the shell: the other
    two) moved by at least ``sensor_stuck_min_change_c`` (equal readings interpolate to
    equal values, so a sparse stuck sensor is found too). A sensor is silent over a run
    of intervals with no value: no finite reading within ``max_temperature_gap_s``
    (dropped out, or NaN messages).
    """
    temps: dict[str, npt.NDArray[np.float64]] = {}
    sampling: dict[str, SensorSampling] = {}
    notes: list[str] = []
    for name, col in table.temperatures_c.items():
        temps[name], sampling[name] = interpolate_sensor(
            col, table.temperature_offsets_ns.get(name), table.interval_s,
            settings.max_temperature_gap_s, name)
        smp = sampling[name]
        if smp.n_filled and math.isfinite(smp.typical_spacing_s) \
                and smp.typical_spacing_s > 1.5 * table.interval_s:
            fin = np.nonzero(np.isfinite(temps[name]))[0]
            pulses = np.isfinite(table.dcount)
            edges = int(np.count_nonzero(pulses[:fin[0]]) + np.count_nonzero(
                pulses[fin[-1] + 1:])) if len(fin) else 0
            notes.append(f'temperature sensor {name} is read about every '
                         f'{smp.typical_spacing_s:.3g} s: interpolated between its readings '
                         f'onto {smp.n_filled} of the {table.interval_s:g} s intervals'
                         + (f'; the {edges} interval(s) before its first or after its last '
                            'reading are not used.' if edges else '.'))
        if smp.n_bridged:
            notes.append(f'temperature sensor {name}: {smp.n_bridged} gap(s) in its readings '
                         f'longer than its usual spacing (up to {smp.longest_gap_s:.0f} s, '
                         f'within max_temperature_gap_s = {settings.max_temperature_gap_s:g} s) '
                         'bridged by interpolation.')
    filled = {name: c.copy() for name, c in temps.items()}
    out: list[Rejection] = []
    tint = int(round(table.interval_s * NS_PER_S))
    min_n = max(2, int(round(settings.sensor_stuck_s / table.interval_s)))
    pulses_span = np.isfinite(table.dcount)
    for sensor, col in filled.items():
        others = [temps[o] for o in SENSORS if o in temps and o != sensor
                  and (sensor == SENSOR_SHELL or o != SENSOR_SHELL)]
        fin = np.isfinite(col)
        same = np.zeros(len(col), bool)
        same[1:] = fin[1:] & fin[:-1] & (col[1:] == col[:-1])
        for a, b in true_runs(same):
            a0 = a - 1  # the run of equal values starts one interval earlier
            if b - a0 < min_n or not others:
                continue
            moved = max((float(np.nanmax(o[a0:b]) - np.nanmin(o[a0:b]))
                         if np.any(np.isfinite(o[a0:b])) else 0.0) for o in others)
            if moved >= settings.sensor_stuck_min_change_c:
                temps[sensor][a0:b] = np.nan
                t0, t1 = _span_ns(table, a0, b, tint)
                out.append(Rejection(t0, (
                    f'temperature sensor {sensor} reads exactly {col[a0]:.4g} °C from '
                    f'{format_stamp(t0)} to {format_stamp(t1)} ({(t1 - t0) / NS_PER_S:.0f} s) '
                    f'while the other sensors moved by {moved:.2f} °C: it is stuck; those '
                    'intervals are not used. Check the sensor and its wiring.')))
        silent = np.logical_and(np.logical_not(fin), pulses_span)
        fin_idx = np.nonzero(fin)[0]
        edge_n = int(settings.max_temperature_gap_s / table.interval_s)
        for a, b in true_runs(silent):
            if len(fin_idx) and (b <= fin_idx[0] or a > fin_idx[-1]) and b - a <= edge_n:
                continue  # before the first or after the last reading: an edge, noted below
            t0, t1 = _span_ns(table, a, b, tint)
            out.append(Rejection(t0, (
                f'temperature sensor {sensor} gave no finite reading from {format_stamp(t0)} '
                f'to {format_stamp(t1)} ({b - a} interval(s); dropped out or NaN, and no two '
                f'readings within max_temperature_gap_s = {settings.max_temperature_gap_s:g} s '
                'around them): those intervals are not used.')))
    out.sort(key=lambda r: r.stamp_ns)
    return SensorCheck(temps, tuple(out), sampling, tuple(notes))


def _span_ns(table: IntervalTable, a: int, b: int, tint: int) -> tuple[int, int]:
    """(start of interval ``a``, end of interval ``b`` − 1) of ``table``, int ns."""
    return int(table.k[a]) * tint, int(table.k[b - 1] + 1) * tint


def thermal_variables(temperatures_c: dict[str, npt.NDArray[np.float64]],
                      settings: IntervalSettings) -> dict[str, npt.NDArray[np.float64]]:
    """Per interval: H, Ḣ (°C/s, causal slope), ΔT_ab, ΔT_cs (NaN without a shell sensor)."""
    a = temperatures_c[SENSOR_CAVITY_A]
    b = temperatures_c[SENSOR_CAVITY_B]
    h = 0.5 * (a + b)
    hdot = causal_slope(h, settings.hdot_window_n, settings.averaging_interval_s)
    shell = temperatures_c.get(SENSOR_SHELL)
    dtcs = h - shell if shell is not None else np.full(len(h), np.nan)
    return {'H': h, 'Hdot': hdot, 'dTab': a - b, 'dTcs': dtcs}


def split_frame_ids(frame_id: ArrayLike | str, n: int) -> npt.NDArray[np.str_]:
    """Per-message sensor names from one name or an array of them."""
    if isinstance(frame_id, str):
        return np.full(n, frame_id)
    ids = np.asarray(frame_id).astype(str)
    if len(ids) != n:
        raise ValueError(f'{len(ids)} frame ids for {n} temperature messages')
    return ids
