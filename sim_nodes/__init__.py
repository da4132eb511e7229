"""Physics simulators of the calibration benches (nodes and offline runs)."""
