"""The fix-error-angle procedure (METHODS §A.3): moved to :mod:`sim_nodes.two_axis_procedure`.

The triad bench shares it; this module keeps the old import path.
"""

from sim_nodes.two_axis_procedure import (
    ThetaProcedureConfig,
    _move,
    _rate_bias_pieces,
    full_procedure_profiles,
    rate_bias_pieces,
    theta_procedure_profiles,
)

__all__ = ['ThetaProcedureConfig', '_move', '_rate_bias_pieces', 'full_procedure_profiles',
           'rate_bias_pieces', 'theta_procedure_profiles']
