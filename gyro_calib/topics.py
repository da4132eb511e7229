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

POSITION_TABLE_JOINT_STATES = '/position_table/joint_states'
"""sensor_msgs/JointState, name ['position_table']: unwrapped encoder angle (rad), rate (rad/s)."""
POSITION_TABLE_ZERO_INDEX = '/position_table/zero_index'
"""std_msgs/Header: stamp = instant the position table's reference mark passed."""
FIX_ERROR_ANGLE = '/gyro_calib/fix_error_angle'
"""std_msgs/Float64, transient-local: θ, rad."""
SCALE_FACTOR = '/gyro_calib/scale_factor'
"""std_msgs/Float64, transient-local: K = K̃·cos θ, rad/pulse."""
BENCH_TRUE_MOTION = '/sim/bench/true_motion'
"""Simulation only. sensor_msgs/JointState batch for the two-axis bench: name
['rate_table', 'position_table']; position[j·n + i], velocity[j·n + i] = true angle (rad)
and rate (rad/s) of joint j at sample i; effort[i] = stamp of sample i minus header.stamp (ns)."""
POSITION_TABLE_JOINT = 'position_table'
SIM_SCENARIO = '/sim/scenario'
"""Simulation only. std_msgs/String, transient-local: YAML description of a simulator's
parameters, seed and truth (each simulator publishes its part; recorders merge them)."""
