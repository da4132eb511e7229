"""What the tables did, in words and as the ``--json`` record.

One line on each recorded table's motion (its steady segments and the stretches of changing
rate left out), the samples of each input left out, the reference the samples were analysed
against (the gyro alone, or minus the rate table's angle, METHODS §E.1 (2b)), and why a record
whose table changed rate gives no term and what record would.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from gyro_calib.noise.intake import StreamIntake
from gyro_calib.noise.table import TABLE_NAMES
from gyro_calib.noise.topics import FOG_OUTPUT, GYRO_PULSES
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    from gyro_calib.noise.intake import InputStream
    from gyro_calib.noise.table import TableMotion


class TableReport(StreamIntake):
    """The tables' motion in words and for ``--json`` (a base of the calibrator)."""

    @staticmethod
    def _rates_words(tm: TableMotion) -> str:
        """'at rest', 'at 37.9 °/s', 'at rest, at ±150 °/s' … of the steady segments."""
        out: list[str] = []
        for r in tm.steady_rates():
            word = 'at rest' if abs(r) <= tm.rest_rate_rad_s else f'at {math.degrees(r):.4g} °/s'
            if word not in out:
                out.append(word)
        if len(out) > 4:
            out = [*out[:4], '…']
        return ', '.join(out) or 'none'

    def _table_clause(self, topic: str, tm: TableMotion) -> str:
        name = TABLE_NAMES[topic]
        segs = tm.segments
        if not tm.moved:
            if segs and all(abs(r) <= tm.rest_rate_rad_s for r in tm.steady_rates()):
                return (f'{topic}: the {name} stayed at rest throughout its {tm.record_s():.6g} s '
                        f'record ({tm.states} states')
            return (f'{topic}: the {name} kept a constant rate throughout its '
                    f'{tm.record_s():.6g} s record ({tm.states} states, '
                    f'{self._rates_words(tm)}')
        rate = tm.max_rate_rad_s
        changes = tm.changes()
        if not tm.turning:
            return (f'{topic}: the {name} moved during {tm.moving_s():.6g} s of its '
                    f'{tm.record_s():.6g} s record ({len(changes)} span(s), largest rate '
                    f'{rate:.4g} rad/s = {math.degrees(rate):.4g} °/s')
        kinds: dict[str, int] = {}
        for sp in changes:
            w = sp.what(tm.rest_rate_rad_s)
            kinds[w] = kinds.get(w, 0) + 1
        kind = ', '.join(f'{n} × {w}' for w, n in kinds.items())
        return (f'{topic}: the {name} changed rate during {tm.moving_s():.6g} s of its '
                f'{tm.record_s():.6g} s record ({len(changes)} span(s): {kind}; largest rate '
                f'{rate:.4g} rad/s = {math.degrees(rate):.4g} °/s) and held {len(segs)} steady '
                f'segment(s) ({self._rates_words(tm)}')

    def reference_words(self) -> str:
        """Which reference the gyro samples were analysed against ('' without a gyro angle)."""
        streams = [st for st in self._streams.values() if st.topic in (GYRO_PULSES, FOG_OUTPUT)]
        if not streams:
            return ''
        if self.settings.table_reference != 'gyro_minus_table':
            return 'reference: the gyro alone (table_reference = gyro)'
        ref = sum(st.referenced for st in streams)
        alone = sum(st.unreferenced for st in streams)
        angle = 'K·counts' if streams[0].topic == GYRO_PULSES else 'counts/SF'
        words = (f'reference: the gyro angle minus the rate table\'s encoder angle ({angle} − '
                 f'encoder angle) for {ref} sample(s)')
        if alone:
            words += f', the gyro alone for {alone} (no rate table angle at their stamps)'
        return words

    def reference_used(self) -> str:
        """'gyro', 'gyro_minus_table', or 'mixed' (some samples had no table angle)."""
        streams = [st for st in self._streams.values() if st.topic in (GYRO_PULSES, FOG_OUTPUT)]
        if self.settings.table_reference != 'gyro_minus_table' or not streams:
            return 'gyro'
        ref = sum(st.referenced for st in streams)
        alone = sum(st.unreferenced for st in streams)
        return 'gyro_minus_table' if not alone else ('gyro' if not ref else 'mixed')

    def table_line(self) -> str:
        """One line on the tables' motion ('' when no table state arrived).

        Each recorded table's steady segments (their rates) and the stretches of changing
        rate left out (how many, what kind, for how long, the largest rate); how many
        samples of each input were left out; and the reference the samples were analysed
        against (the gyro alone, or minus the rate table's angle).
        """
        recorded, s = self.gate.recorded(), self.settings
        if not recorded:
            if s.table_reference == 'gyro_minus_table' and any(
                    st.topic in (GYRO_PULSES, FOG_OUTPUT) for st in self._streams.values()):
                return ('table_reference = gyro_minus_table, but no /rate_table/joint_states '
                        'state was recorded: reference: the gyro alone.')
            return ''
        clauses = [self._table_clause(topic, tm) for topic, tm in recorded]
        head = (f'{clauses[0]}; {self._steady_words()})' if len(clauses) == 1
                else '; '.join(f'{c})' for c in clauses) + f'; {self._steady_words()}')
        reference = self.reference_words()
        tail = f'; {reference}.' if reference else '.'
        if not any(tm.moved for _, tm in recorded):
            late = [f'{st.before_table} of {st.topic} before its first state'
                    for st in self._streams.values() if st.before_table]
            late += [f'{st.beyond_table} of {st.topic} after waiting {s.table_wait_s:g} s for a '
                     'later state' for st in self._streams.values() if st.beyond_table]
            unknown = f' ({", ".join(late)}: taken as steady)' if late else ''
            return f'{head}: every sample analysed{unknown}{tail}'
        parts = []
        for st in self._streams.values():
            received = st.reorder.stats.received
            pct = 100.0 * st.left_out / received if received else 0.0
            early = (f', {st.before_table} analysed before the first table state'
                     if st.before_table else '')
            if st.beyond_table:
                early += (f', {st.beyond_table} decided by the last table state after '
                          f'waiting {self.settings.table_wait_s:g} s for a later one')
            parts.append(f'{st.left_out} of {received} samples of {st.topic} '
                         f'({pct:.3g} %){early}')
        kept = any(st.left_out < st.reorder.stats.received for st in self._streams.values())
        return (f'{head}: {", ".join(parts) or "no gyro sample"} left out (the stretches of '
                'changing rate); '
                + ('each steady segment is analysed as a segment of a static record'
                   if kept else 'no sample in a steady segment remains') + tail)

    @staticmethod
    def _table_fields(tm: TableMotion) -> dict[str, Any]:
        changes = tm.changes()
        return {'moved': tm.moved, 'states': tm.states, 'moving_states': tm.moving_states,
                'record_s': tm.record_s(), 'moving_s': tm.moving_s(), 'spans': len(changes),
                'max_rate_rad_s': tm.max_rate_rad_s, 'steady_segments': len(tm.segments),
                'steady_rates_rad_s': [float(r) for r in tm.steady_rates()],
                'turning_s': tm.turning_s(), 'turning_allowed': tm.turning,
                'changes': [sp.what(tm.rest_rate_rad_s) if tm.turning else 'turning'
                            for sp in changes]}

    def table_record(self) -> dict[str, Any] | None:
        """The tables' motion for ``--json`` (``table_motion``), or None without a table.

        The top-level fields describe ``topic``: the rate table when it was recorded, else
        the position table; ``tables`` has the same fields for every recorded table, by
        topic; the samples left out are those while any recorded table changed rate (the
        position table: turned). ``moved``: some stretch was left out; ``steady_segments``,
        ``steady_rates_rad_s``, ``turning_s`` (steady at a non-zero rate), ``changes`` (what
        each stretch was) and ``reference`` (what the samples were analysed against) besides.
        """
        recorded = self.gate.recorded()
        if not recorded:
            return None
        topic, tm = recorded[0]
        s = self.settings
        return {
            'topic': topic, **self._table_fields(tm),
            'samples_left_out': {st.topic: st.left_out for st in self._streams.values()},
            'samples_received': {st.topic: st.reorder.stats.received
                                 for st in self._streams.values()},
            'rest_rate_rad_s': s.table_rest_rate_rad_s,
            'rest_angle_rad': s.table_rest_angle_rad,
            'stamp_jitter_s': s.table_stamp_jitter_s,
            'min_steady_s': s.table_min_steady_s,
            'reference': self.reference_used(),
            'samples_referenced': {st.topic: st.referenced for st in self._streams.values()},
            'line': self.table_line(),
            'tables': {t: self._table_fields(m) for t, m in recorded},
        }

    def _tables_phrase(self) -> str:
        """'the rate table', 'the position table' (the one recorded) or 'every table'."""
        recorded = self.gate.recorded()
        return f'the {TABLE_NAMES[recorded[0][0]]}' if len(recorded) == 1 else 'every table'

    def _motion_reason(self, stream: InputStream) -> str:
        """Why a record whose table changed rate gives no term, and what record would."""
        if not stream.left_out:
            return ''
        s = self.settings
        # the fit needs 8 τ points (octaves m = 1 … 128) with fit_min_clusters clusters each
        # and within max_tau_fraction of the span: the least record for the white-noise term
        need = int(math.ceil(max(s.fit_min_clusters, 1.0 / s.max_tau_fraction) * 128)) + 1
        first, last, n = stream.final
        period = (last - first) / (n - 1) / NS_PER_S if n > 1 and last > first else math.nan
        secs = f' ({need * period:.3g} s)' if math.isfinite(period) else ''
        turned = ' and '.join(
            f'the {TABLE_NAMES[topic]} {"changed rate" if tm.turning else "turned"} during '
            f'{tm.moving_s():.6g} s of its {tm.record_s():.6g} s record ({len(tm.changes())} '
            f'span(s), up to {tm.max_rate_rad_s:.4g} rad/s = '
            f'{math.degrees(tm.max_rate_rad_s):.4g} °/s)'
            for topic, tm in self.gate.recorded() if tm.moved)
        return (f' {turned[:1].upper()}{turned[1:]}: '
                f'{stream.left_out} samples of {stream.topic} were left out and the longest '
                f'steady span holds {stream.longest_rest}. Noise terms need a constant input '
                f'rate: record with the rate table at rest or at one constant rate (the '
                f'position table at rest), {need} samples{secs} or more in one steady span for '
                f'the white-noise term (8 octaves of τ with {s.fit_min_clusters:g} clusters '
                'each), hours for bias instability and the random walks.')
