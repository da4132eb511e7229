"""An Allan-deviation curve of one axis, pooled over the segments of a record.

Each segment (a gap-free stretch of samples) gives raw sums of squared second
differences per averaging factor m (:class:`gyro_calib.noise.allan.AllanSums`). Pooling
weights each segment by its number of terms (AVAR = Σ S_i / (2 m² τ² Σ n_i)), labels the
point with the term-weighted mean period (τ = m·Σ n_i·τ0_i / Σ n_i, τ0_i from integer-ns
stamps), and combines the segments' equivalent degrees of freedom as
(Σ n_i)²/Σ(n_i²/EDF_i) for each noise type (see :mod:`gyro_calib.noise.edf`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.edf import edf_greenhall, edf_oadev, edf_totdev

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.noise.allan import AllanSums
    from gyro_calib.noise.exact import DeviationSums

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]

ALPHAS = (2, 1, 0, -1, -2)
"""Noise types α with an EDF row in :attr:`AllanCurve.edf_by_alpha`, in this order."""


@dataclass(frozen=True, slots=True)
class AllanCurve:
    """Overlapping Allan variance of one axis at each averaging time.

    Attributes:
        tau_s: averaging times τ, s (ascending).
        avar: Allan variance, rate unit² ((rad/s)², (m/s²)²).
        m: averaging factor in samples (τ = m·τ0).
        terms: second differences summed (all segments).
        span: L = Σ (N_i − 2m): level-0 span of the term start points, samples.
        edf_by_alpha: EDF for each noise type in ALPHAS (5 × len(τ)).
        tau0_s: mean sample period over the record, s.
        n_samples: samples (phase points) analysed, all segments.
        n_segments: segments pooled.
        overlap: 'partial' (decimation tree) or 'full'.
    """

    tau_s: FloatArray
    avar: FloatArray
    m: IntArray
    terms: IntArray
    span: FloatArray
    edf_by_alpha: FloatArray
    tau0_s: float
    n_samples: int
    n_segments: int
    overlap: str
    clusters: FloatArray | None = None
    """Non-overlapping clusters T/τ at each τ (all segments: Σ (N_i − 1)/m)."""
    others: dict[str, tuple[FloatArray, IntArray, FloatArray]] = field(default_factory=dict)
    """'mdev', 'hdev', 'totdev' → (variance, rate unit²; terms; EDF by noise type, 5 × len)
    at the same τ (NaN where the statistic has no term); only those computed."""

    @property
    def n_rate_samples(self) -> int:
        """Rate samples analysed, all segments: Σ (N_i − 1) (N_i phase points in segment i).

        A segment of N phase points (the counts of a pulse or FOG output, or an IMU's rates
        integrated from 0) holds N − 1 rate samples: the count every estimate rests on.
        """
        return self.n_samples - self.n_segments

    @property
    def adev(self) -> FloatArray:
        """Allan deviation, rate unit."""
        return np.sqrt(self.avar)

    def edf(self, alpha: npt.ArrayLike, statistic: str = 'adev') -> FloatArray:
        """EDF at each τ for the noise type α at that τ.

        EDF at each τ for the noise type α at that τ (array or scalar), of the ADEV or
        of another statistic in :attr:`others`.
        """
        a = np.broadcast_to(np.asarray(alpha, dtype=np.int64), self.tau_s.shape)
        rows = np.array([ALPHAS.index(int(v)) for v in a], dtype=np.int64)
        table = self.edf_by_alpha if statistic == 'adev' else self.others[statistic][2]
        return table[rows, np.arange(len(self.tau_s))]

    def __len__(self) -> int:
        """Number of τ points."""
        return len(self.tau_s)


@dataclass(slots=True)
class SegmentSums:
    """One segment's sums, ready to pool.

    Attributes:
        sums: raw sums (phase unit as fed: rate·samples for rate input, counts for phase).
        tau0_s: mean sample period of the segment, s.
        variance_scale: multiplies sum_sq/(2 m²) to give AVAR in rate unit² (1 for rate
            input; (phase unit per count)²/τ0² for phase input).
        max_m: largest averaging factor reported from this segment.
        extra: the exact store's MDEV/HDEV/TOTDEV sums (full overlap), or None.
    """

    sums: AllanSums
    tau0_s: float
    variance_scale: float
    max_m: int
    extra: DeviationSums | None = None


@dataclass(slots=True)
class CurvePool:
    """Accumulates accepted segments' sums per averaging factor (grows with segments only)."""

    segments: list[SegmentSums] = field(default_factory=list)

    def add(self, seg: SegmentSums) -> None:
        """Pool one more segment."""
        self.segments.append(seg)

    def curve(self, overlap: str, extra: SegmentSums | None = None) -> AllanCurve | None:
        """The pooled curve (with ``extra``, the live segment, if given); None if empty."""
        segs = self.segments + ([extra] if extra is not None else [])
        parts = []
        for s in segs:
            a = s.sums
            keep = (a.m <= s.max_m) & (a.terms > 0)
            if np.any(keep):
                m = a.m[keep].astype(np.float64)
                ones = np.ones(len(m))
                parts.append(np.column_stack((
                    m, a.sum_sq[keep] * s.variance_scale, a.terms[keep].astype(np.float64),
                    ones * s.tau0_s, a.stride[keep].astype(np.float64), ones * a.n_points,
                    a.n_points - 2.0 * m)))
        if not parts:
            return None
        arr = np.concatenate(parts)
        ms = arr[:, 0].astype(np.int64)
        unique_m = np.unique(ms)
        idx = np.searchsorted(unique_m, ms)
        k = len(unique_m)
        s_sum = np.bincount(idx, arr[:, 1], k)
        n_sum = np.bincount(idx, arr[:, 2], k)
        tau0_w = np.bincount(idx, arr[:, 2] * arr[:, 3], k) / n_sum
        span = np.asarray(np.bincount(idx, arr[:, 6], k), dtype=np.float64)
        avar = s_sum / (2.0 * unique_m.astype(np.float64) ** 2 * n_sum)
        level_points = (arr[:, 5] - 1) // arr[:, 4] + 1
        level_m = arr[:, 0] / arr[:, 4]
        edf = np.empty((len(ALPHAS), k))
        for r, alpha in enumerate(ALPHAS):
            if overlap == 'full':
                nu = edf_greenhall(level_points, level_m, alpha)
            else:
                nu = edf_oadev(level_points, level_m, alpha)
            den = np.bincount(idx, arr[:, 2] ** 2 / nu, k)
            edf[r] = n_sum**2 / den  # (Σ n_i)² / Σ (n_i²/EDF_i)
        clusters = np.asarray(np.bincount(idx, (arr[:, 5] - 1.0) / arr[:, 0], k), np.float64)
        others = self._others(segs, unique_m)
        n_samples = sum(s.sums.n_points for s in segs)
        total_w = sum(s.sums.n_points for s in segs)
        tau0 = sum(s.sums.n_points * s.tau0_s for s in segs) / total_w
        return AllanCurve(unique_m * tau0_w, avar, unique_m, n_sum.astype(np.int64), span, edf,
                          float(tau0), int(n_samples), len(segs), overlap, clusters, others)

    @staticmethod
    def _others(segs: list[SegmentSums], unique_m: IntArray
                ) -> dict[str, tuple[FloatArray, IntArray, FloatArray]]:
        """Pooled MDEV/HDEV/TOTDEV variances, terms and EDF rows at the curve's factors.

        Variances in rate unit²: MVAR = Σs/(2m⁴Σn), HVAR = Σs/(6m²Σn), TOTVAR =
        Σs/(2m²Σn) with the phase in rate·samples (τ0 cancels; SP 1065 eqs. 14, 17, 25).
        """
        exact = [s for s in segs if s.extra is not None]
        if not exact:
            return {}
        k = len(unique_m)
        mf = unique_m.astype(np.float64)
        norms = {'mdev': 2.0 * mf**4, 'hdev': 6.0 * mf**2, 'totdev': 2.0 * mf**2}
        out: dict[str, tuple[FloatArray, IntArray, FloatArray]] = {}
        for name in ('mdev', 'hdev', 'totdev'):
            total, terms = np.zeros(k), np.zeros(k)
            den = np.zeros((len(ALPHAS), k))
            seen = False
            for s in exact:
                e = s.extra
                assert e is not None
                sums = getattr(e, f'{name}_sum')
                n_t = getattr(e, f'{name}_terms')
                keep = (e.m <= s.max_m) & (n_t > 0) & np.isfinite(sums)
                if not np.any(keep):
                    continue
                seen = True
                pos = np.searchsorted(unique_m, e.m[keep])
                total[pos] += sums[keep] * s.variance_scale
                terms[pos] += n_t[keep]
                for r, alpha in enumerate(ALPHAS):
                    if name == 'totdev':
                        nu = edf_totdev(e.n_points, e.m[keep], alpha)
                    else:
                        nu = edf_greenhall(e.n_points, e.m[keep], alpha,
                                           d=2 if name == 'mdev' else 3,
                                           modified=name == 'mdev')
                    den[r, pos] += n_t[keep].astype(np.float64) ** 2 / nu
            if not seen:
                continue
            with np.errstate(invalid='ignore', divide='ignore'):
                var = np.where(terms > 0, total / (norms[name] * terms), np.nan)
                edf = np.where(den > 0, terms**2 / den, 1.0)
            out[name] = (var, terms.astype(np.int64), edf)
        return out
