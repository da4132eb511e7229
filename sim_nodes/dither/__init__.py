"""Simulators of the dither-axis misalignment bench (METHODS §C): exact kinematics, pure physics.

Modules: :mod:`kinematics` (composed rotation, body rate, quadrature), :mod:`vibration_table`,
:mod:`gyro` (dithered RLG with transverse rocking), :mod:`bench` (both, streamed in chunks),
:mod:`scenarios` (whole recordings with their truth).
"""
