"""Calibration certificates (``gyro-calib report``): one self-contained HTML + PDF per gyro.

A front door above the registry: it reads the hand-off file (:mod:`gyro_calib.handoff`) and,
when the bags are given or the calibration has just run, what the methods' sessions know
(degrees of freedom, uncertainty bases, rejections, figures). Nothing below imports it.
"""
