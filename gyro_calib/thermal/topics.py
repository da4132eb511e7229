"""Topic-contract constants of the thermal method (local until the lead moves them to
:mod:`gyro_calib.topics`)."""

from __future__ import annotations

GYRO_TEMPERATURE = '/gyro/temperature'
"""sensor_msgs/Temperature: temperature (°C, as the message defines), variance (°C², 0 when
unknown); header.frame_id names the sensor (:data:`SENSOR_CAVITY_A`, :data:`SENSOR_CAVITY_B`,
optionally :data:`SENSOR_SHELL`)."""
SENSOR_CAVITY_A = 'cavity_a'
"""Sensor on cavity arm a; H is the mean of the two cavity sensors."""
SENSOR_CAVITY_B = 'cavity_b'
"""Sensor on cavity arm b."""
SENSOR_SHELL = 'shell'
"""Optional sensor on the gyro shell (cavity-to-shell gradient)."""
SENSORS = (SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL)
"""Every sensor name the method reads."""
