"""Live thermal compensation that gives the offline numbers whatever the arrival order.

A corrector that judged each pulse sample against the newest temperature that had
arrived gave numbers that depended on how DDS interleaved /gyro/pulses and
/gyro/temperature (issue 24 §5b). :class:`OrderedThermalCompensator` instead holds each
pulse sample, by its stamp, until the temperatures that decide its bias have arrived, and
then subtracts the bias the offline compensation subtracts for it
(:func:`gyro_calib.thermal.compensate.interval_bias`, the bias of the averaging interval
holding the sample pair's midpoint, as ``gyro-calib compensate --out`` writes it;
METHODS §D.3, §D.5). Results depend only on message contents and header stamps.

**When a bias is decided.** Interval i's bias depends on the interval means of the
sensors the model needs, interpolated between readings (§D.5), over the Ḣ window
[i − n_Ḣ + 1, i], and on the stuck-sensor check of the runs of equal values there (a run
found stuck is blanked whole, offline). It is *final* — no later message can change it —
once, for each needed sensor, the readings around that window have been reduced, every run
of identical readings touching it that could be stuck (still open, or as long as
``sensor_stuck_s``) has ended on both sides — over the sensors, as the stuck check compares a
sensor with the others over its run — and the pulse interval i has been reduced (its rate
is valid or not). Typically that is one averaging interval plus the reorder window
plus the longest run of equal readings after i (2–10 s at 1 Hz sensors), or the reading
spacing of a sparse sensor.

**How long a pulse waits (``max_wait_s``, the node's ``thermal_max_age_s``).** A bias not
final with the data of intervals up to i + ⌊max_wait_s/T⌋ is *not covered*: the pulse pair
gets a :class:`Rejection` and no rate — usually a sensor silent, or reading exactly the same
value, for longer than the wait: offline blanks such a run whole once it proves stuck, which
cannot be known before it ends, so live gives no number rather than one offline might not.
That decision uses the intervals up to that cut only, so it too is a function of the
messages. It is taken when both streams' stamps have passed the cut (plus the reorder
window). A temperature topic that is merely behind — an unpaced replay whose executor takes
one topic's whole backlog first — is waited for, however far behind. Only as a memory guard,
with more than ``max_held`` samples held (a temperature topic that stopped), the oldest are
given up once the pulse stamps pass their cut by ``max_wait_s`` more; only then can arrival
order matter. So with the temperatures flowing, the publish latency in stamp time is at most
(⌊max_wait_s/T⌋ + 1)·T + the reorder window after the pair's midpoint interval, and usually
the few seconds the data take to decide it.

Each topic is assumed to arrive in stamp order (one DDS writer, reliable or
best-effort), up to the reorder window the interval reducers allow; the topics may be
interleaved in any way.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.thermal.compensate import (
    CompensatedPair,
    interval_bias,
    model_interval_settings,
)
from gyro_calib.thermal.errors import ModelMismatchError
from gyro_calib.thermal.intervals import (
    IntervalSettings,
    PulseIntervals,
    TemperatureIntervals,
    check_sensors,
    interpolate_sensor,
    join_intervals,
    true_runs,
)
from gyro_calib.thermal.topics import SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL, SENSORS
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.thermal.intervals import IntervalTable
    from gyro_calib.thermal.model import ThermalBiasModel


Outcome = CompensatedPair | Rejection


@dataclass(slots=True)
class _Held:
    """A pulse sample waiting for its bias (or an already decided Rejection)."""

    t_ns: int
    count: float
    prev: tuple[int, float] | None
    interval: int
    rejection: Rejection | None


class OrderedThermalCompensator:
    """Holds pulse pairs by stamp until their bias is final (module docstring).

    Feed messages in arrival order with :meth:`add_pulse` and :meth:`add_temperature`;
    each returns the outcomes released, in pulse stamp order: a :class:`CompensatedPair`
    or a :class:`Rejection` (non-finite count, stamp not after the previous one, no bias).
    """

    def __init__(self, model: ThermalBiasModel, *, max_wait_s: float = 30.0,
                 max_held: int = 200_000,
                 interval_settings: IntervalSettings | None = None) -> None:
        """Create the stream reducers with the model's reduction.

        Args:
            model: the thermal model (its interval, Ḣ window and interpolation gap).
            max_wait_s: how far, in stamp time, a bias may need data beyond its interval.
            max_held: memory guard: with more pulse samples held (about 35 MB at 200 000),
                the oldest are given up once the pulse stamps pass their cut by
                ``max_wait_s`` even though the temperatures have not (a silent topic).
            interval_settings: the reduction (default: the model's).
        """
        self.model = model
        s = interval_settings or model_interval_settings(model)
        self.settings = s
        self._tint = s.interval_ns
        self._reorder_ns = int(s.reorder_window_s * NS_PER_S)
        self.max_wait_ns = int(round(max_wait_s * NS_PER_S))
        self.max_held = max_held
        self._wait_n = int(max_wait_s // s.averaging_interval_s)
        self._n_hd = s.hdot_window_n
        self._gap_n = int(math.ceil(s.max_temperature_gap_s / s.averaging_interval_s)) + 1
        self._stuck_n = max(2, int(round(s.sensor_stuck_s / s.averaging_interval_s)))
        self._keep = self._n_hd + self._stuck_n + 2 * self._gap_n + 4
        self._max_gap_ns = s.max_temperature_gap_s * NS_PER_S * (1 + 1e-12)
        self._pulses = PulseIntervals(s, model.scale_factor_rad_per_pulse)
        self._temps = {name: TemperatureIntervals(name, s) for name in SENSORS}
        self._next_reduce: dict[str, int | None] = {name: None for name in (*SENSORS, '')}
        self._newest: dict[str, int | None] = {name: None for name in (*SENSORS, '')}
        self._first_k: int | None = None
        self._held: deque[_Held] = deque()
        self._last: tuple[int, float] | None = None
        self._decided: dict[int, tuple[float, float] | str] = {}
        self._version = 0
        self._attempt: tuple[int, int, bool] | None = None
        self._need_row = -(2**62)  # no try can succeed before every sensor reaches it

    @property
    def needed(self) -> tuple[str, ...]:
        """The sensors the model's bias depends on."""
        return (SENSOR_CAVITY_A, SENSOR_CAVITY_B) + (
            (SENSOR_SHELL,) if 'dTcs' in self.model.variables else ())

    @property
    def held(self) -> int:
        """Pulse samples waiting for their bias."""
        return len(self._held)

    # ---------------------------------------------------------------- input

    def add_pulse(self, t_ns: int, count: float) -> list[Outcome]:
        """One /gyro/pulses sample; the outcomes this releases."""
        t_ns = int(t_ns)
        self._pulses.append(t_ns, count)
        rejection: Rejection | None = None
        prev = None
        if not math.isfinite(count):
            rejection = Rejection(t_ns, f'pulse count {count!r} at stamp {t_ns} ns is not '
                                        'finite.')
        else:
            prev, self._last = self._last, (t_ns, count)
            if prev is not None and t_ns <= prev[0]:
                rejection = Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, '
                                            f'{prev[0]} ns; it becomes the new reference.')
            elif prev is None:
                prev = None
        if prev is not None or rejection is not None:
            mid = t_ns if prev is None else prev[0] + (t_ns - prev[0]) // 2
            self._held.append(_Held(t_ns, count, prev, mid // self._tint, rejection))
        self._stream_advanced('', t_ns)
        return self._release()

    def add_temperature(self, t_ns: int, celsius: float, frame_id: str) -> list[Outcome]:
        """One /gyro/temperature reading (unknown frame_ids ignored); the outcomes released."""
        red = self._temps.get(frame_id)
        if red is None:
            return []
        red.append(int(t_ns), float(celsius))
        self._stream_advanced(frame_id, int(t_ns))
        return self._release()

    def _stream_advanced(self, name: str, t_ns: int) -> None:
        newest = self._newest[name]
        self._newest[name] = t_ns if newest is None else max(newest, t_ns)
        nxt = self._next_reduce[name]
        if nxt is not None and t_ns < nxt:
            return
        red = self._pulses if name == '' else self._temps[name]
        if red.reduce():
            self._version += 1
        self._next_reduce[name] = ((t_ns - self._reorder_ns) // self._tint + 1) * self._tint \
            + self._reorder_ns
        rows = red.arrays()[0]
        if len(rows):
            k0 = int(rows[0])
            self._first_k = k0 if self._first_k is None else min(self._first_k, k0)

    # ------------------------------------------------------------- decisions

    def _release(self) -> list[Outcome]:
        out: list[Outcome] = []
        while self._held:
            h = self._held[0]
            if h.rejection is None and h.interval not in self._decided:
                self._decide(h.interval)
                if h.interval not in self._decided:
                    break
            self._held.popleft()
            if h.rejection is not None:
                out.append(h.rejection)
                continue
            got = self._decided[h.interval]
            assert h.prev is not None
            if isinstance(got, str):
                out.append(Rejection(h.t_ns, got))
            else:
                out.append(CompensatedPair(h.prev[0], h.prev[1], h.t_ns, h.count, got[0],
                                           got[1]))
        oldest = self._held[0].interval if self._held else (
            self._last[0] // self._tint - 1 if self._last is not None else None)
        if oldest is not None:
            for k in [k for k in self._decided if k < oldest]:
                del self._decided[k]
        self._trim()
        return out

    def _decide(self, i: int) -> None:
        """Decide interval ``i`` (and the held ones after it) if the data allow."""
        cut = i + self._wait_n
        cut_end_ns = (cut + 1) * self._tint + self._reorder_ns
        pulse_newest = self._newest['']
        temps_passed = all((self._newest[s] or -1) >= cut_end_ns for s in self.needed)
        pulses_passed = pulse_newest is not None and pulse_newest >= cut_end_ns
        # a temperature topic merely behind (a replay's backlog taken one topic first)
        # is waited for; only a hoard beyond max_held gives up on the pulses' stamps alone
        give_up = pulse_newest is not None and pulses_passed and (
            temps_passed or (len(self._held) > self.max_held
                             and pulse_newest >= cut_end_ns + self.max_wait_ns))
        attempt = (i, self._version, give_up)
        if attempt == self._attempt:
            return  # nothing new since the last try
        self._attempt = attempt
        if not give_up and not self._may_be_final(i):
            return
        pulse_rows = self._pulses.arrays()[0]
        last_pulse_row = int(pulse_rows[-1]) if len(pulse_rows) else None
        todo = sorted({h.interval for h in self._held if h.rejection is None
                       and h.interval not in self._decided and h.interval >= i})
        # a short window first (the Ḣ window, a sparse sensor's spacing); all kept rows
        # when a run of equal values reaches further back
        for since in (i - self._n_hd - self._gap_n - 16, None):
            table = self._window(cut, since)
            if table is None:
                break
            final = _Finality(self, table, cut)
            if not final(i):
                self._need_row = max(self._need_row, final.need_row)
                continue
            try:
                ib = interval_bias(table, self.model, self.settings, out_of_range='skip')
            except ModelMismatchError as exc:
                if give_up:
                    self._decided[i] = f'no thermal compensation: {exc}'
                return
            k0 = int(table.k[0])
            for j in todo:
                if j in self._decided:
                    continue
                if last_pulse_row is None or j > last_pulse_row or j > cut:
                    break
                if not final(j):
                    break
                r = j - k0
                if ib.valid[r]:
                    self._decided[j] = (float(ib.bias[r]), float(ib.bias_std[r]))
                else:
                    self._decided[j] = self._why_not(table, ib, r)
            if i in self._decided:
                return
        if give_up:
            self._decided[i] = self._not_covered()

    def _may_be_final(self, i: int) -> bool:
        """Cheap: pulse interval i, and every needed sensor as far as the last try asked."""
        rows = self._pulses.arrays()[0]
        if not len(rows) or int(rows[-1]) < i:
            return False
        need = max(i + 1, self._need_row)
        for s in self.needed:
            rows = self._temps[s].arrays()[0]
            if not len(rows) or int(rows[-1]) < need:
                return False
        return True

    def _window(self, cut: int, since: int | None = None) -> IntervalTable | None:
        """The kept rows of every stream from ``since`` up to ``cut``, joined (None: none)."""
        lo = -(2**62) if since is None else since

        def part(cols: tuple[npt.NDArray[Any], ...]) -> tuple[npt.NDArray[Any], ...]:
            sel = (cols[0] <= cut) & (cols[0] >= lo)
            return tuple(c[sel] for c in cols)

        pulses = part(self._pulses.arrays())
        temps = {s: part(r.stamped_arrays()) for s, r in self._temps.items() if r.n_messages}
        temps = {s: c for s, c in temps.items() if len(c[0])}
        if not len(pulses[0]) or not temps:
            return None
        return join_intervals(pulses, temps,  # type: ignore[arg-type]
                              self.settings.averaging_interval_s)

    def _not_covered(self) -> str:
        return (f'no thermal compensation: the temperatures that decide this sample\'s bias '
                f'did not arrive within thermal_max_age_s = {self.max_wait_ns / 1e9:g} s of '
                'stamps (a sensor silent or reading exactly the same value that long, or '
                '/gyro/temperature late).')

    def _why_not(self, table: IntervalTable, ib: object, r: int) -> str:
        from gyro_calib.thermal.compensate import IntervalBias

        assert isinstance(ib, IntervalBias)
        t = int(table.k[r]) * self._tint
        if not math.isfinite(table.dcount[r]):
            return f'no thermal compensation: no valid pulse rate in the interval at {t} ns.'
        h, hd = ib.variables['H'][r], ib.variables['Hdot'][r]
        for rej in ib.rejections:
            if 'outside the calibrated range' in rej.reason and rej.stamp_ns <= t:
                lo, hi = self.model.h_range_c
                return (f'no thermal compensation: the temperature (H {h:.2f} °C, Ḣ '
                        f'{hd * 60:.3f} °C/min) lies outside the calibrated range '
                        f'{lo:.2f}…{hi:.2f} °C ± {self.model.extrapolation_margin_c:g} °C.')
        stuck = [x.reason for x in ib.rejections if 'stuck' in x.reason and x.stamp_ns <= t]
        if stuck:
            return f'no thermal compensation: {stuck[-1]}'
        return ('no thermal compensation: the interval lacks a temperature the model needs '
                f'(no reading of a sensor within max_temperature_gap_s, or Ḣ has fewer than '
                f'half of its {self.settings.hdot_window_s:g} s window).')

    def _trim(self) -> None:
        """Forget rows no held or later pulse can need (bounded memory)."""
        if self._held:
            oldest = self._held[0].interval
        elif self._last is not None:
            oldest = self._last[0] // self._tint
        else:
            return
        k = oldest - self._keep
        rows = self._pulses.arrays()[0]
        if len(rows) and int(rows[0]) < k - self._keep:  # amortised: trim in chunks
            self._pulses.keep_since(k)
            for red in self._temps.values():
                red.keep_since(k)


class _Finality:
    """Whether an interval's bias in a window is what the whole recording gives.

    Every needed sensor's interpolated value must be final over the runs of equal values
    touching the Ḣ window of the interval (closed over the sensors, as the stuck check
    compares a sensor with the others over its run), and just beyond them on both sides,
    so the runs' ends are known: no later message, and no earlier one outside the window,
    can change them.
    """

    def __init__(self, owner: OrderedThermalCompensator, table: IntervalTable,
                 cut: int) -> None:
        """Interpolate the needed sensors of ``table`` and find their runs once."""
        self.owner, self.table = owner, table
        self.k0 = k0 = int(table.k[0])
        first = owner._first_k
        self.at_start = first is not None and k0 <= first
        self.ok = True
        self.first_final = k0  # absolute interval indices
        self.last_final = cut
        self.runs: list[tuple[str, int, int]] = []
        self.check: Any = None
        self.need_row = -(2**62)
        tint = owner._tint
        for s in owner.needed:
            col = table.temperatures_c.get(s)
            fin = np.nonzero(np.isfinite(col))[0] if col is not None else np.zeros(0, int)
            if col is None or not len(fin):
                self.ok = False
                return
            filled = interpolate_sensor(col, table.temperature_offsets_ns.get(s),
                                        table.interval_s,
                                        owner.settings.max_temperature_gap_s)[0]
            if not self.at_start:  # before the first reading here, an earlier one may count
                self.first_final = max(self.first_final, k0 + int(fin[0]))
            last_read = int(fin[-1])
            off = table.temperature_offsets_ns.get(s)
            o = float(off[last_read]) if off is not None and math.isfinite(off[last_read]) \
                else 0.5 * tint
            rows = owner._temps[s].arrays()[0]
            rows_end = min(int(rows[-1]), cut) - k0  # reduced up to here
            # after the last reading a later one could still be interpolated back, unless
            # it would lie further than max_temperature_gap_s from it
            no_fill = (rows_end + 1 - last_read) * tint - o > owner._max_gap_ns
            self.last_final = min(self.last_final, k0 + (rows_end if no_fill else last_read))
            fin_f = np.isfinite(filled)
            same = np.zeros(len(filled), bool)
            same[1:] = fin_f[1:] & fin_f[:-1] & (filled[1:] == filled[:-1])
            self.runs += [(s, a - 1, b) for a, b in true_runs(same)]
        self.runs.sort(key=lambda r: r[1])

    def __call__(self, j: int) -> bool:
        """Whether interval ``j`` (absolute index) is final in the window."""
        if not self.ok:
            return False
        k0, owner = self.k0, self.owner
        lo, hi = j - owner._n_hd + 1 - k0, j - k0  # relative to the table
        changed = True
        while changed:
            changed = False
            for s, a0, b in self.runs:
                if a0 > hi:
                    break
                if b - 1 < lo:
                    continue
                unseen_left = not self.at_start and k0 + a0 - 1 < self.first_final
                if b - a0 < owner._stuck_n and k0 + b <= self.last_final and not unseen_left:
                    continue  # closed on both sides and too short to be stuck: final
                new_lo = lo
                if a0 < lo:
                    if unseen_left:
                        # its start is not in view: fine only when the window alone
                        # already finds it stuck (then it is blanked either way)
                        if self.check is None:
                            self.check = check_sensors(self.table, owner.settings)
                        if b - a0 < owner._stuck_n or np.any(np.isfinite(
                                self.check.temperatures_c[s][a0:b])):
                            return False
                    else:
                        new_lo = a0
                if new_lo < lo or b - 1 > hi:
                    lo, hi = new_lo, max(hi, b - 1)
                    changed = True
        if k0 + hi + 1 > self.last_final:
            self.need_row = k0 + hi + 1
            return False  # a run may go on, or a value after the zone is not known yet
        return self.at_start or k0 + lo - 1 >= self.first_final
