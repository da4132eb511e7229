"""Topic names of the dither-misalignment method (to move into gyro_calib/topics.py).

Defined here until the lead engineer adds them to the shared topic contract.
"""

from __future__ import annotations

GYRO_PULSES = '/gyro/pulses'
"""sensor_msgs/JointState, name ['gyro']: cumulative pulse count (integer in float64)."""
VIBRATION_TABLE_JOINT_STATES = '/vibration_table/joint_states'
"""sensor_msgs/JointState, name ['vibration_table']: position = table angle (rad), velocity
(rad/s), header.frame_id = the case axis the table axis is aligned with: 'z' or 'y'."""
VIBRATION_TABLE_JOINT = 'vibration_table'
DITHER_MISALIGNMENT = '/gyro_calib/dither/misalignment'
"""std_msgs/Float64, reliable, transient-local: a, rad."""
