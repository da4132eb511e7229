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

FOG_OUTPUT = '/fog/output'
"""sensor_msgs/JointState, name ['fog']: position[0] = cumulative output count (integer in
float64); output rate (counts/s) = Δcount/Δt."""
FOG_INJECTION = '/fog/injection'
"""sensor_msgs/JointState, name ['fog_injection']: position[0] = the injected ramp expressed
as the output rate (counts/s) a perfectly linear loop would add; in force from header.stamp
until the next message; 0 = none."""
FOG_SCALE_FACTOR = '/gyro_calib/fog/scale_factor'
"""std_msgs/Float64, transient-local: turntable scale factor K, counts/rad."""
FOG_SELF_CAL_SCALE_FACTOR = '/gyro_calib/fog/self_cal_scale_factor'
"""std_msgs/Float64, transient-local: self-calibrated scale factor over the linear range,
counts/rad."""
FOG_JOINT = 'fog'
FOG_INJECTION_JOINT = 'fog_injection'

VIBRATION_TABLE_JOINT_STATES = '/vibration_table/joint_states'
"""sensor_msgs/JointState, name ['vibration_table']: position = table angle (rad), velocity
(rad/s), header.frame_id = the case axis the table axis is aligned with: 'z' or 'y'."""
VIBRATION_TABLE_JOINT = 'vibration_table'
DITHER_MISALIGNMENT = '/gyro_calib/dither/misalignment'
"""std_msgs/Float64, reliable, transient-local: the dither-axis misalignment a, rad."""

GYRO_TEMPERATURE = '/gyro/temperature'
"""sensor_msgs/Temperature: temperature (°C, as the message defines), variance (°C², 0 when
unknown); header.frame_id names the sensor: 'cavity_a', 'cavity_b' (their mean is H),
optionally 'shell'."""
TEMPERATURE_SENSORS = ('cavity_a', 'cavity_b', 'shell')
"""The sensor names (header.frame_id) of /gyro/temperature."""
