"""gyro_calib: online calibration of optical gyroscopes.

The core modules (everything except :mod:`gyro_calib.nodes` and
:mod:`gyro_calib.bench_demo`) import no ROS package: they are plain
NumPy/SciPy and can be used on recorded data offline.
"""

__version__ = '0.2.0'
