"""IMUs without a turntable: multi-position calibration (docs/methods.md §G).

recording      what the method reads: stamped raw accelerometer and gyro samples
readers        the plain formats of the recordings (IMU-TK ASCII, imucal CSV, xyz6)
gravity        local g from latitude and height (eq. (1))
static         static intervals from the recording's own noise (eq. (2))
records        TriadFit: parameters, covariance, ν, residuals, conditioning
rotation       rotations integrated from rates, vectorised over motions (eq. (5))
uncertainty    least-squares covariance with propagated inputs, Welch–Satterthwaite (7)–(9)
accelerometer  scale, misalignment, bias from gravity at the poses (eq. (4))
gyroscope      bias from the static intervals, scale and misalignment from the motions (6)
calibrator     the whole calibration of one recording and its conditioning statement
ferraris       the Ferraris variant: six positions and three known turns (eqs. (10)–(11))
"""
