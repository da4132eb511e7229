"""Rate-biased ring laser gyro (METHODS §A, seed 000): K̃, θ, K = K̃·cos θ and bias.

windows      whole-revolution windows from zero-index events (local fits at the index instants)
scale_factor eqs. (3), (4): forward/reverse pairs, honest means
calibrator   streaming K̃ accumulator + batch function
stations     position-table stations of the θ procedure
fix_error_angle  θ, β₀, α: eqs. (15)–(18) and multi-station least squares
error_budget eqs. (5) and (21)
calibration  K̃ + θ → K and bias; the hand-off record
diagnostics  /diagnostics content
config       KTildeConfig (window settings)
"""
