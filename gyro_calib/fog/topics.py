"""Topic contract of the FOG method (issue 10 Part 1 item 2), local until the shared
`gyro_calib.topics` takes these names.

All topics carry SI units (REP 103); header stamps are the sample instants.
"""

from __future__ import annotations

from gyro_calib.topics import RATE_TABLE_JOINT_STATES, RATE_TABLE_ZERO_INDEX

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

__all__ = ['FOG_INJECTION', 'FOG_INJECTION_JOINT', 'FOG_JOINT', 'FOG_OUTPUT',
           'FOG_SCALE_FACTOR', 'FOG_SELF_CAL_SCALE_FACTOR', 'RATE_TABLE_JOINT_STATES',
           'RATE_TABLE_ZERO_INDEX']
