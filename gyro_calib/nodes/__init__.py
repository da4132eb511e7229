"""ROS 2 nodes: thin shells that translate messages to core calls and back.

A node started alone (its console script, ``ros2 run``, ``python -m``) takes Ctrl-C while
its modules load quietly: one line, exit 130 (:mod:`gyro_calib.startup_interrupt`).
"""

from gyro_calib.startup_interrupt import quiet_interrupt_while_a_node_starts

quiet_interrupt_while_a_node_starts()
