"""Temperature-chamber and thermal prism-laser-gyro simulators (METHODS §D; pure physics).

- :mod:`sim_nodes.thermal.chamber`: chamber programmes (soaks, ramps).
- :mod:`sim_nodes.thermal.gyro`: the gyro's thermal network, hidden bias law, noise and
  pulses, streamed in chunks.
- :mod:`sim_nodes.thermal.scenarios`: named gyros, faults and whole recordings.
"""
