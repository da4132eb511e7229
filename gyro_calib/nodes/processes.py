"""Start gyro_calib nodes as child processes on a loopback-only, private DDS domain.

Used by the bench demo and the DDS tests. Children get a full copy of the
environment (the ROS wheels re-execute Python once to set LD_LIBRARY_PATH and
need the rest of it), with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST forced.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import yaml

from gyro_calib.startup_interrupt import NODE_ENTRY_POINTS

NODE_MODULES = {name: module for name, module in NODE_ENTRY_POINTS.items()
                if name != 'thermal_bias_node'}
"""The nodes the demo, the docs and the tests start (``python -m MODULE``): every node entry
point but thermal_bias_node, which does not come up without a ``calibration_file`` holding a
thermal model (none is committed for the node-parameter tests to give it)."""


DOMAINS = range(1, 101)
"""The DDS domains a run may take (ROS_DOMAIN_ID 1–100: every port of them below 32768)."""

_HELD: list[IO[bytes]] = []
"""The locks of the domains this process took (held until it exits)."""


@dataclass(frozen=True)
class DomainChoice:
    """A DDS domain for a run and how it was chosen (for the line that names it)."""

    domain: int
    how: str
    lock: IO[bytes] | None = None


def domain_ports(domain: int) -> range:
    """The UDP ports of DDS domain ``domain`` (RTPS: port base 7400 + 250·domain, 250 ports)."""
    base = 7400 + 250 * domain
    return range(base, base + 250)


def bound_udp_ports(tables: tuple[str, ...] = ('/proc/net/udp', '/proc/net/udp6')) -> set[int]:
    """The local UDP ports bound on this machine (every process's; empty where unreadable)."""
    ports: set[int] = set()
    for table in tables:
        try:
            lines = Path(table).read_text(encoding='ascii').splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 1 and ':' in fields[1]:
                ports.add(int(fields[1].rsplit(':', 1)[1], 16))
    return ports


def domain_lock_path(domain: int) -> Path:
    """The lock file a gyro_calib run (a test run, the demo) holds for its domain."""
    return Path(tempfile.gettempdir()) / f'gyro_calib_dds_domain_{domain}.lock'


def hold_free_domain(start: int | None = None,
                     bound: Callable[[], set[int]] = bound_udp_ports) -> DomainChoice:
    """A DDS domain free on this machine, and the lock that keeps it for this run.

    Free: no other gyro_calib run holds its lock (``gyro_calib_dds_domain_<N>.lock`` in the
    temporary directory, held while the run lives), and no DDS participant of any program
    has bound one of its ports (:func:`domain_ports`). The search starts at ``start``
    (default: from the process id) and wraps around :data:`DOMAINS`. None free: the one
    from the process id, said so.
    """
    first = (os.getpid() if start is None else start) % len(DOMAINS)
    in_use = bound()
    for k in range(len(DOMAINS)):
        domain = DOMAINS[(first + k) % len(DOMAINS)]
        if in_use.intersection(domain_ports(domain)):
            continue
        lock = open(domain_lock_path(domain), 'wb')  # noqa: SIM115 (held for the run)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        return DomainChoice(domain, 'free: no other run or DDS participant on this machine '
                            'uses it', lock)
    return DomainChoice(DOMAINS[first], 'none free on this machine: taken from the process '
                        'id, may be shared')


def choose_domain() -> DomainChoice:
    """The DDS domain of this run: ROS_DOMAIN_ID if set, else :func:`hold_free_domain`.

    The lock of a domain taken is held until the process exits.
    """
    if os.environ.get('ROS_DOMAIN_ID'):
        return DomainChoice(int(os.environ['ROS_DOMAIN_ID']), 'ROS_DOMAIN_ID')
    choice = hold_free_domain()
    if choice.lock is not None:
        _HELD.append(choice.lock)
    return choice


def pick_domain_id() -> int:
    """The DDS domain of this run (:func:`choose_domain`)."""
    return choose_domain().domain


def ros_environment(domain_id: int) -> dict[str, str]:
    """A copy of this process's environment with DDS kept on loopback in ``domain_id``."""
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env.setdefault('PYTHONUNBUFFERED', '1')
    return env


def _yaml_string(value: str) -> str:
    """``value`` quoted so that rcl reads it back as the same string.

    ``value`` as rcl reads it back as the same string: rcl parses ``-p`` values as YAML,
    so '' (rejected outright), 'true', '1.5' or 'a: b' must be quoted.
    """
    try:  # rcl's YAML 1.1 also reads y/n/yes/no/on/off as booleans; PyYAML reads y/n as text
        plain = yaml.safe_load(value) == value and value.lower() not in ('y', 'n')
    except yaml.YAMLError:
        plain = False
    return value if plain else "'" + value.replace("'", "''") + "'"


def ros_args(params: dict[str, Any]) -> list[str]:
    """``--ros-args -p name:=value ...`` for a parameter mapping.

    ``--ros-args -p name:=value ...`` for a parameter mapping (floats keep their dot,
    strings stay strings).
    """
    args = ['--ros-args']
    for name, value in params.items():
        if isinstance(value, bool):
            text = 'true' if value else 'false'
        elif isinstance(value, float):
            text = repr(value)  # YAML 1.1 wants a dot in the mantissa: 1e-05 -> 1.0e-05
            mantissa, _, exponent = text.partition('e')
            if exponent and '.' not in mantissa:
                text = f'{mantissa}.0e{exponent}'
        elif isinstance(value, str):
            text = _yaml_string(value)
        elif isinstance(value, tuple):  # a dataclass field's tuple is a ROS list
            text = str(list(value))
        else:
            text = str(value)
        args += ['-p', f'{name}:={text}']
    return args


def start_node(name: str, params: dict[str, Any], env: dict[str, str], *,
               namespace: str = '', **popen: Any) -> subprocess.Popen[bytes]:
    """Start node ``name`` in a child process.

    Start node ``name`` (a key of NODE_MODULES) with ``params`` in a child process, in
    ``namespace`` ('' = the root; ``-r __ns:=...``).
    """
    remap = ['-r', f'__ns:={namespace}'] if namespace else []
    cmd = [sys.executable, '-m', NODE_MODULES[name], *ros_args(params), *remap]
    return subprocess.Popen(cmd, env=env, **popen)
