"""Simulators of a gyro triad (an IMU) on the two-axis bench and the single-axis table.

METHODS §F: the physics (:mod:`~sim_nodes.triad.gyros`), the procedures
(:mod:`~sim_nodes.triad.bench`), the committed scenarios (:mod:`~sim_nodes.triad.scenarios`)
and the ``triad_sim`` node.
"""
