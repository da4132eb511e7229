"""A triad of pulse-output gyros on the two-axis bench (METHODS §F): K, sense axes, M, bias.

kinematics  rotation directions u in the body frame (eqs. 1–3), Earth rate along u (eq. 13),
            forward/reverse windows reduced to a pair (eqs. 5–6)
estimator   rows r_i = s_i/K_i by least squares (eqs. 7–9), K_i, s_i, M = R⁻¹ (eq. 10) with
            covariance and budget (eqs. 11–12), not-measurable rank test, bias (eq. 14)
"""
