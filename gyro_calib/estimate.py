"""The one result shape every estimator returns: value beside uncertainty and count."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class Rejection:
    """A window (or event) an estimator did not use, and why.

    Attributes:
        stamp_ns: header stamp the rejection refers to (window start or event), int ns.
        reason: a whole sentence a bench engineer can act on.
    """

    stamp_ns: int
    reason: str


@dataclass(frozen=True, slots=True)
class Estimate:
    """A measured quantity with its standard (k = 1) uncertainty.

    Attributes:
        value: the estimate, in the unit the producing function documents.
        std_uncertainty: standard uncertainty (k = 1) of ``value``, same unit.
        n_used: number of independent measurements (windows, pairs, stations) it rests on.
        dof: degrees of freedom of the uncertainty (n_used - 1 for a Type A mean).
        rejected: windows or events left out, each with its reason.
        basis: what the uncertainty rests on (e.g. 'scatter of 3 × Student t 1.321 (2 dof)',
            'predicted from the fits of 3'), '' when not stated.
    """

    value: float
    std_uncertainty: float
    n_used: int
    dof: int
    rejected: tuple[Rejection, ...] = field(default=())
    basis: str = ''

    @property
    def supported_dof(self) -> int:
        """ν as the data support it: the stated ``dof``, at most n − 1 (n = ``n_used``).

        A statement resting on n independent measurements (windows, pairs, blocks,
        plateaus) has at most n − 1 degrees of freedom, however many samples each holds
        (GUM G.3.3: ν of a Type A evaluation from n observations); where ``n_used`` counts
        samples (noise), the stated ν (the EDF) is below it already.
        """
        return min(self.dof, self.n_used - 1) if self.n_used >= 2 else self.dof

    @property
    def relative_uncertainty(self) -> float:
        """Standard uncertainty divided by |value| (dimensionless)."""
        return self.std_uncertainty / abs(self.value)


ONE_SIGMA_PROBABILITY = 0.8413447460685429
"""P(z < 1) of the standard normal: a ±1σ interval covers 68.27 %."""


def student_t_factor(dof: int) -> float:
    """The t such that ±t·s/√n covers the mean as often as ±1σ covers a normal value (dof ≥ 1).

    Shared by the methods (docs/methods.md §A eq. (3d), §F.5). ``scipy.special.stdtrit``,
    the function ``scipy.stats.t.ppf`` evaluates (the same float, test/test_student_t_factor.py),
    without importing scipy.stats: a third of ``gyro-calib calibrate``'s start-up (issue 40).
    """
    from scipy.special import stdtrit

    return float(stdtrit(dof, ONE_SIGMA_PROBABILITY))
