"""The progress bar of a subcommand (``--progress`` / ``--no-progress``)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager


def show_progress(flag: bool | None) -> bool:
    """Draw a bar? As ``--progress``/``--no-progress`` say, else when stderr is a terminal."""
    return sys.stderr.isatty() if flag is None else flag


@contextmanager
def progress_bar(flag: bool | None, desc: str) -> Iterator[Callable[[float], None] | None]:
    """A bar named ``desc`` on stderr and the callback that moves it, or None without a bar.

    The callback takes the fraction done (the ``progress`` of
    :func:`~gyro_calib.bag_calibration.calibrate_bags`); the bar counts it in ‰. Whether
    there is a bar: :func:`show_progress` of ``flag``.
    """
    if not show_progress(flag):
        yield None
        return
    from tqdm import tqdm

    with tqdm(total=1000, desc=desc, unit='‰', file=sys.stderr,
              bar_format='{desc} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}') as bar:
        def progress(fraction: float) -> None:
            bar.update(int(fraction * 1000) - bar.n)
        yield progress
