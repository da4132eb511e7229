"""Temperature bias compensation of a prism laser gyro (METHODS §D, seed 004).

Pure core (no ROS import): stream reduction (:mod:`.intervals`), lifting-wavelet
denoising (:mod:`.wavelet`), candidate terms (:mod:`.terms`), fits and stepwise selection
(:mod:`.regression`), the fit pipeline (:mod:`.fit`), the model an INS applies
(:mod:`.model`), compensation and its figures (:mod:`.compensate`, :mod:`.allan`), the
streaming calibrator (:mod:`.calibrator`) and plots (:mod:`.plots`).
"""
