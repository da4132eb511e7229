"""Physics simulators of the calibration benches (nodes and offline runs).

A simulator node started alone takes Ctrl-C while its modules load quietly: one line, exit
130 (:mod:`gyro_calib.startup_interrupt`).
"""

from gyro_calib.startup_interrupt import quiet_interrupt_while_a_node_starts

quiet_interrupt_while_a_node_starts()
