"""Noise generators for noise characterisation: seeded, chunk-invariant, exact Allan variance.

See :mod:`sim_nodes.noise.processes` (the IEEE Std 952 processes, flicker synthesis) and
:mod:`sim_nodes.noise.sensors` (one axis, a 6-axis IMU, an RLG pulse stream, a FOG).
"""

from __future__ import annotations

from sim_nodes.noise.sensors import (
    AxisNoise,
    FogOutputGenerator,
    ImuNoiseGenerator,
    NoiseTerms,
    RlgPulseGenerator,
)

__all__ = ['AxisNoise', 'FogOutputGenerator', 'ImuNoiseGenerator', 'NoiseTerms',
           'RlgPulseGenerator']
