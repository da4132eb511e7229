"""Fleet calibration (``gyro-calib batch``): many gyros on a Dask cluster, fleet reports.

A front door above the registry, beside :mod:`gyro_calib.report`: a manifest lists the gyros
(:mod:`.manifest`), one task per gyro and method runs the bag calibration on a worker
(:mod:`.tasks`), the parent only schedules, writes the files the workers return and the fleet
files (:mod:`.fleet`). Nothing below imports it.
"""
