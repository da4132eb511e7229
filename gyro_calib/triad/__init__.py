"""A triad of pulse-output gyros on the two-axis bench (METHODS §F): K, sense axes, M, bias.

kinematics    rotation directions u in the body frame (eqs. 1–3), Earth rate along u (eq. 13),
              forward/reverse windows reduced to a pair (eqs. 5–6)
records       what the estimator takes and gives: TriadPair, BenchParameter, TriadResult …
estimator     rows r_i = s_i/K_i by least squares (eqs. 7–9), K_i, s_i, M = R⁻¹ (eq. 10) with
              covariance and budget (eqs. 11–12), not-measurable rank test
bias          the biases from the pair sums, the Earth rate along u removed (eq. 14)
settings      the window, pair and channel settings (TriadSettings) and the bench (Bench)
intake        the bench topics read, one segment per bag (mount)
quantisation  the quantisation floor of a window's count (eq. 6a)
cutting       whole-revolution windows per channel on one table, combined into TriadWindows
pairing       forward/reverse windows about one direction → pairs with their u
solve         the pairs solved, the tilt α fitted when the position table gave pairs
results       estimates, missing / not measurable, summary rows, the hand-off's imu: section
session       TriadSession: the shared session running them (re-exports their names)
plots         --plot's figure: each pair's residual per channel (eq. 8)
"""
