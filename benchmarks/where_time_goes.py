"""Where a ``gyro-calib`` command's wall time goes: an exclusive stopwatch over named parts.

Run as a child by the benchmarks (issue 40), not by hand:

    python benchmarks/where_time_goes.py --part LABEL=MODULE:ATTR[:iter] ... -- ARGS...

Runs ``gyro_calib.cli.main(ARGS)`` in this process with each named function (or, with
``:iter``, generator: the time inside each ``next``) wrapped by a stopwatch, and the import
machinery as the part ``imports`` wherever an import happens. Parts are exclusive: the
time of a part nested in another counts to the inner one only; what no part claims is
``rest``. Prints one line: ``repr((total_s, {part: s}))``.
"""

from __future__ import annotations

import importlib
import importlib._bootstrap as boot
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

SPENT: dict[str, float] = {}
STACK: list[list[Any]] = []  # [part, start, time of the parts nested in it]


def _enter(part: str) -> None:
    STACK.append([part, time.perf_counter(), 0.0])


def _leave() -> None:
    part, t0, inner = STACK.pop()
    dt = time.perf_counter() - t0
    SPENT[part] = SPENT.get(part, 0.0) + dt - inner
    if STACK:
        STACK[-1][2] += dt


def timed(part: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` with its time counted to ``part``."""
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        _enter(part)
        try:
            return fn(*args, **kwargs)
        finally:
            _leave()
    return wrapper


def timed_iter(part: str, fn: Callable[..., Iterator[Any]]) -> Callable[..., Iterator[Any]]:
    """Generator function ``fn`` with the time inside each ``next`` counted to ``part``."""
    def wrapper(*args: Any, **kwargs: Any) -> Iterator[Any]:
        it = fn(*args, **kwargs)
        while True:
            _enter(part)
            try:
                item = next(it)
            except StopIteration:
                return
            finally:
                _leave()
            yield item
    return wrapper


def main() -> None:
    split = sys.argv.index('--')
    specs, argv = sys.argv[1:split], sys.argv[split + 1:]
    boot._find_and_load = timed('imports', boot._find_and_load)  # type: ignore[attr-defined]
    t_start = time.perf_counter()
    _enter('rest')
    from gyro_calib.cli import main as cli_main

    parts = [s for s in specs if s != '--part']
    for spec in parts:
        label, target = spec.split('=', 1)
        module_name, attr, *kind = target.split(':')
        owner: Any = importlib.import_module(module_name)
        *path, name = attr.split('.')
        for p in path:
            owner = getattr(owner, p)
        wrap = timed_iter if kind == ['iter'] else timed
        setattr(owner, name, wrap(label, getattr(owner, name)))
    try:
        cli_main(argv)
    except SystemExit:
        pass
    _leave()
    print(repr((time.perf_counter() - t_start, SPENT)))


if __name__ == '__main__':
    main()
