"""The topic contract (names, joint names, units), shared by nodes, bags and tests.

All topics carry SI units (REP 103). Header stamps are the sample instants.
"""

from __future__ import annotations

RATE_TABLE_JOINT_STATES = '/rate_table/joint_states'
"""sensor_msgs/JointState, name ['rate_table']: unwrapped encoder angle (rad), rate (rad/s)."""
RATE_TABLE_ZERO_INDEX = '/rate_table/zero_index'
"""std_msgs/Header: stamp = instant the reference mark passed (either direction)."""
GYRO_PULSES = '/gyro/pulses'
"""sensor_msgs/JointState, name ['gyro']: cumulative pulse count (integer in float64)."""
K_TILDE = '/gyro_calib/k_tilde'
"""std_msgs/Float64, transient-local: running K̃, rad/pulse."""
DIAGNOSTICS = '/diagnostics'
"""diagnostic_msgs/DiagnosticArray: values, uncertainties, counts, last rejection reason."""
RATE_TABLE_TRUE_MOTION = '/sim/rate_table/true_motion'
"""Simulation only. sensor_msgs/JointState batch: position[i] true angle (rad), velocity[i]
true rate (rad/s), effort[i] stamp of sample i minus header.stamp (ns)."""

RATE_TABLE_JOINT = 'rate_table'
GYRO_JOINT = 'gyro'
