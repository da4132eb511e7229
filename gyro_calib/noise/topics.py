"""Topic names the noise method reads and the axis names of an Imu stream.

Shared contract names, repeated here so the method imports no other (METHODS §E).
"""

from __future__ import annotations

GYRO_PULSES = '/gyro/pulses'
"""RLG pulse topic (shared contract name, repeated here so the method imports no other)."""
FOG_OUTPUT = '/fog/output'
"""FOG output topic (cumulative output counts)."""
IMU_PULSES = '/imu/pulses'
"""A triad's pulse topic: three joints (the channels), cumulative counts (METHODS §F)."""
PULSE_TOPICS = (GYRO_PULSES, IMU_PULSES)
"""The pulse-count streams (whole pulses: uniform quantisation, lock-in notes)."""
IMU_AXES = ('gyro_x', 'gyro_y', 'gyro_z', 'accel_x', 'accel_y', 'accel_z')
"""Axis names of an Imu stream, in column order."""
