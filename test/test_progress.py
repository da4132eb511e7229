"""Progress at a glance (issue 19 part 4).

Progress at a glance (issue 19 part 4): what is measured, what is still needed and how much
more data, and a level — what every calibration node puts on /diagnostics.
"""

from __future__ import annotations

from pathlib import Path

from gyro_calib.bag_calibration import method_options
from gyro_calib.bagio import bag_info, iter_sample_batches
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions, MethodSession

BAGS = Path(__file__).resolve().parent.parent / 'bags'


def _session(method: str, bag: str) -> MethodSession:
    m = METHODS[method]
    return m.make_session(method_options(CalibrationOptions(), m, [bag_info(BAGS / bag)]))


def _stream(session: MethodSession, bag: str) -> list[str]:
    """Feed the bag in small batches, as a live node does; the progress after each."""
    seen = []
    for batch in iter_sample_batches(BAGS / bag, session.topics(), batch_messages=5_000):
        session.feed(batch)
        session.process()
        p = session.progress()
        seen.append(f'{p.level}: {p.message}')
    session.process(flush=True)
    return seen


def test_rbrlg_counts_down_the_window_pairs_then_asks_for_the_stations() -> None:
    session = _session('rbrlg', 'k_tilde_bench')
    first = session.progress()
    assert (first.level, first.message) == (
        'WARN', 'nothing measured yet; still needed: K̃ needs 2 more forward/reverse window '
        'pair(s) (5 revolutions each way); 0 of 2 accepted')
    seen = _stream(session, 'k_tilde_bench')
    assert any('K̃ needs 1 more forward/reverse window pair(s) (5 revolutions each way, about'
               in line for line in seen), seen
    last = session.progress()
    assert last.level == 'WARN'
    assert last.message.startswith('3 measured (k_tilde_rad_per_pulse n=3, ')
    assert last.needs == {'fix_error_angle_rad': 'θ needs 3 position-table stations of the '
                          'four-position procedure; none seen yet'}


def test_the_four_position_procedure_counts_stations_and_ends_ok() -> None:
    session = _session('rbrlg', 'theta_multi_station')
    seen = _stream(session, 'theta_multi_station')
    assert any('θ needs 3 more station(s) (0 measured, 3 spread in β needed)' in line
               for line in seen), seen
    assert any('θ needs 1 more station(s) (2 measured, 3 spread in β needed)' in line
               for line in seen), seen
    assert not any(line.startswith('ERROR') for line in seen), seen
    assert session.progress().level == 'OK'
    assert session.progress().message.startswith('complete: 5 measured (')


def test_a_refused_theta_is_an_error_not_a_wait() -> None:
    session = _session('rbrlg', 'theta_multi_station')
    session.calibrator.nominal_tilt_deg = 30.0  # the bench is mounted at 45°
    _stream(session, 'theta_multi_station')
    p = session.progress()
    assert p.level == 'ERROR'
    assert 'wrong: ' in p.message and 'tilt' in p.problems[0]
    assert 'fix_error_angle_rad' not in p.needs  # wrong, not waiting for more data


def test_dither_says_how_much_of_the_other_orientation_it_needs() -> None:
    session = _session('dither', 'dither_z')
    _stream(session, 'dither_z')
    p = session.progress()
    assert p.level == 'WARN'
    assert p.message.endswith('still needed: the Y orientation needs 5 more accepted block(s) '
                              'of 2 s (about 10 s with the table along Y); 0 of 5 so far')


def test_every_method_reports_progress_from_its_missing_reasons() -> None:
    for method, bag in (('fog', 'fog_fault_short_plateau'),
                        ('thermal', 'thermal_fault_stuck_sensor')):
        session = _session(method, bag)
        assert session.progress().message.startswith('nothing measured yet; still needed: ')
        _stream(session, bag)
        p = session.progress()
        assert p.level in ('OK', 'WARN')
        assert set(p.needs) <= set(session.missing())
        assert p.message.startswith(('complete: ' if p.level == 'OK' else '')
                                     + f'{len(session.results())} measured (')
