"""A MEMS IMU turned by hand between static poses (issue 38; the multiposition method's bench).

imu        the IMU's errors and the hand-turned pose procedure, simulated to raw samples
scenarios  the committed scenario (``bags/multiposition_hand_turned``) and its bag
imu_node   ``imu_multiposition_sim``: the same run published live as sensor_msgs/Imu
"""
