"""Topic-contract names of the thermal method.

Topic-contract names of the thermal method: the shared ones of :mod:`gyro_calib.topics`,
re-exported, plus the sensor names by role and the corrected-rate topic.
"""

from __future__ import annotations

from gyro_calib.topics import GYRO_JOINT, GYRO_PULSES, GYRO_TEMPERATURE, TEMPERATURE_SENSORS

__all__ = ['GYRO_JOINT', 'GYRO_PULSES', 'GYRO_TEMPERATURE', 'TEMPERATURE_SENSORS', 'SENSORS',
           'SENSOR_CAVITY_A', 'SENSOR_CAVITY_B', 'SENSOR_SHELL', 'GYRO_IMU']

SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL = TEMPERATURE_SENSORS
"""header.frame_id of the sensors on cavity arm a and arm b (H is their mean) and on the
shell (cavity-to-shell gradient, optional)."""
SENSORS = TEMPERATURE_SENSORS
"""Every sensor name the method reads."""
GYRO_IMU = '/gyro/imu'
"""sensor_msgs/Imu: calibrated (and, with a thermal model, temperature-compensated) rate about
the sense axis (z), rad/s, with its covariance — what ``imu_corrector`` publishes live and
``gyro-calib compensate --out`` writes into a bag (the same name as
``gyro_calib.nodes.imu_corrector_node.GYRO_IMU``, kept here because the core may not import
a node module)."""
