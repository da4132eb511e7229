"""gyro_calib: online calibration of optical gyroscopes.

The core modules (everything except :mod:`gyro_calib.nodes` and
:mod:`gyro_calib.bench_demo`) import no ROS package: they are plain
NumPy/SciPy and can be used on recorded data offline.

The methods are documented in ``docs/methods.md``; docstrings cite it as
``METHODS §A.2 eq. 3`` (section §A.2, equation (3) of that document).
"""

__version__ = '0.2.0'
