"""``python -m gyro_calib.cli``: the ``gyro-calib`` console script."""

from gyro_calib.cli import console_main

if __name__ == '__main__':
    console_main()
