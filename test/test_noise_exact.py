"""Specification of the exact deviations.

Specification of the exact deviations: allantools and the published NBS-14 values at every
τ, long τ with few clusters included, with the phase in the scratch file and in memory.
"""

from __future__ import annotations

import allantools
import numpy as np
import pytest

from gyro_calib.noise import NoiseSettings, calibrate_noise
from gyro_calib.noise.allan import TauGrid
from gyro_calib.noise.exact import ADVANCE_BLOCKS, THREADS, ExactDeviations

NORMS = {'adev': lambda m: 2.0 * m**2, 'mdev': lambda m: 2.0 * m**4,
         'hdev': lambda m: 6.0 * m**2, 'totdev': lambda m: 2.0 * m**2}
REFERENCE = {'adev': allantools.oadev, 'mdev': allantools.mdev, 'hdev': allantools.ohdev,
             'totdev': allantools.totdev}


def _nbs14_1000() -> np.ndarray:
    """The NBS-14 1000-point fractional-frequency set.

    The NBS-14 1000-point fractional-frequency set (NIST SP 1065 §12.3): the minimal
    standard generator n_{i+1} = 16807·n_i mod (2³¹ − 1), n_0 = 1234567890, y = n/(2³¹ − 1).
    """
    n = [1234567890]
    for _ in range(999):
        n.append(16807 * n[-1] % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # as the standard prints them
    return np.array(n, dtype=np.float64) / 2147483647.0


def _devs(store: ExactDeviations) -> dict[str, np.ndarray]:
    s = store.sums()
    m = s.m.astype(np.float64)
    return {name: np.sqrt(getattr(s, f'{name}_sum') / (NORMS[name](m)
                                                       * getattr(s, f'{name}_terms')))
            for name in NORMS}


def test_nbs14_1000_point_set_gives_the_published_deviations() -> None:
    """The NBS-14 set gives the published deviations.

    SP 1065 Table 31 (τ = 1, 10, 100 s): OADEV, MDEV, TOTDEV, OHDEV to their 7 digits,
    through the whole calibrator (a FOG output stream, 1 count/rad, 1 Hz).
    """
    y = _nbs14_1000()
    phase = np.concatenate(([0.0], np.cumsum(y)))
    t = 1_700_000_000_000_000_000 + np.arange(len(phase), dtype=np.int64) * 1_000_000_000
    cal = calibrate_noise(fog_output=(t, phase), settings=NoiseSettings(
        fog_scale_factor_counts_per_rad=1.0, taus='1, 10, 100'))
    axis = cal.json_section()['axes']['gyro']
    assert axis['tau_s'] == pytest.approx([1.0, 10.0, 100.0], rel=1e-12)
    published = {'adev': [2.922319e-01, 9.159953e-02, 3.241343e-02],
                 'mdev': [2.922319e-01, 6.172376e-02, 2.170921e-02],
                 'totdev': [2.922319e-01, 9.134743e-02, 3.406530e-02],
                 'hdev': [2.943883e-01, 9.581083e-02, 3.237638e-02]}
    for name, values in published.items():
        assert axis[name] == pytest.approx(values, rel=6e-7), name
        assert all(s > 0 for s in axis[f'{name}_std'])


def test_nbs14_10_point_phase_set_gives_the_published_deviations() -> None:
    """SP 1065 Table 29 (τ = 1, 2): OADEV, MDEV, TOTDEV, OHDEV of the 10 phase points."""
    x = np.array([0.0, 103.11111, 123.22222, 157.33333, 166.44444, 48.55555, -96.33333,
                  -2.22222, 111.88889, 0.0])
    store = ExactDeviations(TauGrid('octave', 1.0).factors_up_to, 0.5)
    store.push(x)
    devs = _devs(store)
    published = {'adev': (91.22945, 85.95287), 'mdev': (91.22945, 74.78849),
                 'totdev': (91.22945, 93.90379), 'hdev': (70.80607, 85.61487)}
    for name, values in published.items():
        assert devs[name][:2] == pytest.approx(values, rel=2e-6), name


def _record(n: int, seed: int) -> np.ndarray:
    """Phase of white FM + random-walk FM + a rate offset (rate·samples)."""
    rng = np.random.default_rng(seed)
    rate = 3.0 + rng.standard_normal(n) + np.cumsum(0.01 * rng.standard_normal(n))
    return np.concatenate(([0.0], np.cumsum(rate)))


@pytest.mark.parametrize('memory_points', [1 << 22, 4096])
def test_every_deviation_equals_allantools_at_every_tau_including_few_clusters(
        memory_points: int) -> None:
    """Long τ exactly, in memory and in the scratch file.

    Long τ (m ≥ 1024, down to 4 clusters) exactly, with the phase in memory and in the
    scratch file, fed in uneven chunks.
    """
    x = _record(60_000, 4)
    grid = TauGrid((1.0, 3.0, 1000.0, 1024.0, 4097.0, 9999.0, 15000.0), 1.0)
    store = ExactDeviations(grid.factors_up_to, 0.25, memory_points=memory_points,
                            block=2048)
    for part in np.array_split(x, [5, 77, 20_000, 20_001, 41_234]):
        store.push(part)
    assert store.phase.spilled == (memory_points < len(x))
    devs = _devs(store)
    m = store.sums().m
    assert m.tolist() == [1, 3, 1000, 1024, 4097, 9999, 15000]
    for name, ref in REFERENCE.items():
        tau, dev, _, _ = ref(x, rate=1.0, data_type='phase', taus=m.astype(np.float64))
        pos = np.searchsorted(m, np.round(tau).astype(np.int64))
        assert len(tau) >= 6, name  # allantools drops m with 3m ≥ N for MDEV/HDEV
        assert np.max(np.abs(devs[name][pos] / dev - 1.0)) < 1e-9, name
    store.close()


def test_adev_alone_from_the_scratch_file_equals_it_in_memory_bit_for_bit() -> None:
    """The ADEV-only sweep reads each slice of the file once (shared by factors m and 2m)."""
    x = _record(200_000, 6)
    grid = TauGrid('octave', 1.0)
    sums = []
    for memory_points in (1 << 22, 3000):
        store = ExactDeviations(grid.factors_up_to, 0.25, deviations=('adev',),
                                memory_points=memory_points, block=1024)
        for part in np.array_split(x, 37):
            store.push(part)
        assert store.phase.spilled == (memory_points < len(x))
        sums.append(store.sums())
        store.close()
    assert np.array_equal(sums[0].adev_sum, sums[1].adev_sum)
    m = sums[1].m.astype(np.float64)
    assert m[-1] >= 16 * 1024  # factors far beyond a block, read from the file
    _, dev, _, _ = allantools.oadev(x, rate=1.0, data_type='phase', taus=m)
    ours = np.sqrt(sums[1].adev_sum / (2 * m**2 * sums[1].adev_terms))
    assert np.max(np.abs(ours / dev - 1.0)) < 1e-9


def test_sums_are_bit_identical_however_the_phase_is_chunked_or_probed() -> None:
    x = _record(30_000, 5)
    grid = TauGrid('octave', 1.0)
    one = ExactDeviations(grid.factors_up_to, 0.25, memory_points=8192, block=1024)
    one.push(x)
    many = ExactDeviations(grid.factors_up_to, 0.25, memory_points=8192, block=1024)
    for k, part in enumerate(np.array_split(x, 97)):
        many.push(part)
        if k % 10 == 0:
            many.sums()  # a snapshot must not disturb the stream
    a, b = one.sums(), many.sums()
    for name in ('adev_sum', 'mdev_sum', 'hdev_sum', 'totdev_sum'):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_memory_stays_bounded_once_the_phase_is_in_the_scratch_file() -> None:
    grid = TauGrid('octave', 1.0)
    store = ExactDeviations(grid.factors_up_to, 0.25, memory_points=1 << 16, block=4096)
    sizes = []
    rng = np.random.default_rng(1)
    for _ in range(16):
        store.push(np.cumsum(rng.standard_normal(1 << 16)))
        sizes.append(store.nbytes())
    # the blocks one advance sweeps and the 4 before them (doubled once) and each thread's
    # work buffers, not the 8 MB pushed
    window = (ADVANCE_BLOCKS + 4) * 4096
    assert store.phase.spilled and max(sizes[4:]) == sizes[4] <= 8 * (
        2 * window + (THREADS + 1) * 18 * 4096) < 8 * (1 << 20) // 2
    store.close()


@pytest.mark.parametrize(('spec', 'tau0', 'expected'), [
    ('octave', 0.01, [0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.28]),
    ('default', 0.01, [0.01, 0.02, 0.04, 0.08, 0.1, 0.16, 0.32, 0.64, 1.0, 1.28]),
    ('decade', 0.01, [0.01, 0.02, 0.04, 0.1, 0.2, 0.4, 1.0]),
    ((0.05, 1.0, 30.0), 0.01, [0.05, 1.0]),
])
def test_tau_grids_hold_the_points_users_read(spec: object, tau0: float,
                                              expected: list[float]) -> None:
    m = TauGrid(spec, tau0).factors_up_to(150)  # type: ignore[arg-type]
    assert (m * tau0).tolist() == pytest.approx(expected)


def test_taus_setting_accepts_a_list_and_refuses_nonsense() -> None:
    from gyro_calib.errors import ConfigError

    assert NoiseSettings(taus=[1, 10]).tau_spec == (1.0, 10.0)  # type: ignore[arg-type]
    assert NoiseSettings(taus='all').tau_spec == 'all'
    with pytest.raises(ConfigError, match='taus'):
        NoiseSettings(taus='weekly')
    with pytest.raises(ConfigError, match='deviations'):
        NoiseSettings(deviations='adev, xdev')


def test_a_snapshot_copy_shares_the_scratch_file_without_disturbing_the_stream() -> None:
    """A snapshot copy shares the scratch file without disturbing it.

    The live node's refresh deep-copies the calibrator and flushes the copy: the copy
    must read the original's file, and its own new points must not reach that file.
    """
    import copy

    x = _record(50_000, 6)
    grid = TauGrid('octave', 1.0)
    ref = ExactDeviations(grid.factors_up_to, 0.25, memory_points=4096, block=1024)
    ref.push(x)
    live = ExactDeviations(grid.factors_up_to, 0.25, memory_points=4096, block=1024)
    live.push(x[:30_000])
    snap = copy.deepcopy(live)
    snap.push(x[30_000:31_000])  # the snapshot's flush
    snap_sums = snap.sums()
    del snap  # closes its own descriptor only
    live.push(x[30_000:])
    assert np.array_equal(live.sums().adev_sum, ref.sums().adev_sum)
    short = ExactDeviations(grid.factors_up_to, 0.25, memory_points=4096, block=1024)
    short.push(x[:31_000])
    assert np.array_equal(snap_sums.totdev_sum, short.sums().totdev_sum)
