"""Issue 17 §1 for ``gyro-calib noise``: the bench settings stored with the bags it reads.

``noise`` took the FIRST bag's stored bench settings (scale factor, input topic) whatever the
bag, so a bag that does not hold the input read lent its settings (or its lack of them) to
the one that does. Now the stored settings come from the bags holding the input read; bags
that store different values are refused in one line naming the setting, the bags and the flag
that decides. (``compensate``: test_thermal_bags.py.)
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gyro_calib.bagio import bag_info
from gyro_calib.cli import main as gyro_calib

BAGS = Path(__file__).resolve().parents[1] / 'bags'


def _copy_bag(src: Path, dst: Path, old: str, new: str) -> Path:
    """A copy of a committed bag (its recording linked) whose metadata has ``old`` → ``new``."""
    dst.mkdir()
    for f in src.iterdir():
        if f.suffix == '.mcap':
            (dst / f.name).symlink_to(f)
    meta = (src / 'metadata.yaml').read_text()
    assert old in meta
    (dst / 'metadata.yaml').write_text(meta.replace(old, new))
    return dst


def test_noise_takes_k_from_the_bag_it_reads_not_the_first_bag(
        capsys: pytest.CaptureFixture[str]) -> None:
    """A bag without K first no longer hides another bag's stored K.

    fog_turntable (first, no /gyro/pulses, no stored K) used to hide the K stored with
    noise_rlg_static: 'needs a scale factor', exit 2.
    """
    assert gyro_calib(['noise', str(BAGS / 'fog_turntable'), str(BAGS / 'noise_rlg_static'),
                       '--topic', '/gyro/pulses', '--no-progress']) == 0
    out = capsys.readouterr().out
    assert 'K = 4.0860157e-06 rad/pulse from the bench settings stored' in out


def test_noise_refuses_bags_that_store_different_scale_factors(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old = 'scale_factor_rad_per_pulse: 4.0860157e-06, topic'
    a = _copy_bag(BAGS / 'noise_rlg_static', tmp_path / 'a', old, old)
    # another run of the bench (other seeds): a copy of one bag is the same data twice
    assert gyro_calib(['simulate', 'noise_rlg_static', '--seed', '5', '--out',
                       str(tmp_path / 'run2')]) == 0
    capsys.readouterr()
    b = _copy_bag(tmp_path / 'run2', tmp_path / 'b', old,
                  'scale_factor_rad_per_pulse: 4.1e-06, topic')
    assert bag_info(b).scenario['bench']['scale_factor_rad_per_pulse'] == 4.1e-06
    plot = tmp_path / 'plots'
    assert gyro_calib(['noise', str(a), str(b), '--no-progress', '--plot', str(plot)]) == 2
    out, err = capsys.readouterr()
    assert out == '' and err.count('\n') == 1
    assert 'scale_factor_rad_per_pulse' in err and str(a) in err and str(b) in err
    assert '--scale-factor-rad-per-pulse' in err
    assert not plot.exists()
    # the flag decides
    assert gyro_calib(['noise', str(a), str(b), '--no-progress',
                       '--scale-factor-rad-per-pulse', '4.0860157e-06']) == 0


def test_noise_refuses_bags_that_store_different_inputs_naming_topic(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The first bag's stored input topic used to win silently."""
    assert gyro_calib(['noise', str(BAGS / 'noise_rlg_static'), str(BAGS / 'noise_imu_static'),
                       '--no-progress']) == 2
    out, err = capsys.readouterr()
    assert out == '' and err.count('\n') == 1
    assert 'topic' in err and 'noise_rlg_static' in err and 'noise_imu_static' in err
    assert 'give --topic' in err


def test_stored_benches_keep_every_bag_in_order_and_a_bag_storing_none_counts_empty() -> None:
    """One (bag, stored bench) list for noise, compensate and the methods' options.

    A bag storing no bench counts with {} (another bag's settings never stand in for it);
    the methods' options (every_bag=False) leave it out, as they always did.
    """
    from types import SimpleNamespace

    from gyro_calib.bag_calibration import stored_benches, topic_counts

    def bag(path: str, scenario: dict[str, object], **counts: int) -> SimpleNamespace:
        return SimpleNamespace(path=Path(path), scenario=scenario, topics={
            name: SimpleNamespace(name=f'/{name}', count=n) for name, n in counts.items()})

    bags = [bag('a', {'bench': {'gyro_id': 'A'}}, imu=3), bag('b', {}, imu=4, table=1),
            bag('c', {'bench': 'not a mapping'})]
    assert stored_benches(bags) == (('a', {'gyro_id': 'A'}), ('b', {}), ('c', {}))
    assert stored_benches(bags, every_bag=False) == (('a', {'gyro_id': 'A'}),)
    assert topic_counts(bags) == {'/imu': 7, '/table': 1}
