"""Every node's declared parameters (name, type, default, description, range), as JSON.

Run as a script (``python docs/_ext/node_parameters.py``): each node executable of
:data:`gyro_calib.nodes.processes.NODE_MODULES` is constructed in this process with its
defaults — through its own ``main()``, the factory it hands to ``ros_io.run_node`` taken,
not run — on a private loopback DDS domain, in a scratch directory, and what it declared is
printed as JSON: the reference is what the nodes declare, not what a page says they do.
A node that needs a value to come up at all (:data:`NEEDS`) gets one; that parameter's
default is then reported as required.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]

NEEDS: dict[str, dict[str, Any]] = {
    'thermal_calibration_node': {'scale_factor_rad_per_pulse': 4.8e-6, 'latitude_deg': 34.26},
    'noise_node': {'topic': '/imu/data'},
    'bag_player': {'bag': str(ROOT / 'bags' / 'k_tilde_bench')},
    'bag_recorder': {'out': 'REPLACED'},
}
"""What a node needs beside its defaults to come up (as test/test_node_parameters.py)."""

OWN_MAIN = {'bag_player': 'BagPlayer', 'bag_recorder': 'BagRecorder'}
"""Nodes whose main() does not go through ros_io.run_node: their node class."""

TYPES = {1: 'bool', 2: 'integer', 3: 'double', 4: 'string', 5: 'byte[]', 6: 'bool[]',
         7: 'integer[]', 8: 'double[]', 9: 'string[]'}


def _factory(name: str) -> Any:
    from gyro_calib.nodes import ros_io
    from gyro_calib.nodes.processes import NODE_MODULES

    module = importlib.import_module(NODE_MODULES[name])
    if name in OWN_MAIN:
        return getattr(module, OWN_MAIN[name])
    captured: dict[str, Any] = {}
    users = [m for m in list(sys.modules.values())
             if getattr(m, 'run_node', None) is ros_io.run_node]
    for m in users:
        setattr(m, 'run_node', lambda _name, make, *_a, **_k: captured.update(make=make))
    try:
        module.main([])
    finally:
        for m in users:
            setattr(m, 'run_node', ros_io.run_node)
    return captured['make']


def _value(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, (list, tuple)) or type(value).__name__ == 'array':
        return [_value(v) for v in value]
    return value


def dump() -> dict[str, Any]:
    """Node name → {'module', 'parameters': [{name, type, default, description, ...}]}."""
    import rclpy
    from rcl_interfaces.msg import ParameterType  # noqa: F401  (types by number above)

    from gyro_calib.nodes.processes import NODE_MODULES, ros_args

    scratch = Path(tempfile.mkdtemp(prefix='gyro_calib_docs_'))
    out: dict[str, Any] = {}
    for name, module in NODE_MODULES.items():
        work = scratch / name
        work.mkdir()
        os.chdir(work)
        needs = dict(NEEDS.get(name, {}))
        if 'out' in needs:
            needs['out'] = str(work / 'bag')
        rclpy.init(args=ros_args(needs))
        try:
            node = _factory(name)()
            params = []
            for key in sorted(node._parameters):
                if key in ('use_sim_time', 'start_type_description_service'):
                    continue  # rclpy's own, on every node
                param = node._parameters[key]
                desc = node._descriptors.get(key)
                entry: dict[str, Any] = {
                    'name': key, 'type': TYPES.get(int(param.type_.value), 'any'),
                    'default': None if key in needs else _value(param.value),
                    'required': key in needs,
                    'description': ' '.join((desc.description if desc else '').split()),
                    'read_only': bool(desc.read_only) if desc else False}
                if desc is not None and desc.dynamic_typing:
                    entry['type'] = TYPES.get(int(param.type_.value), 'any') + ' (any type)'
                for rng in (desc.floating_point_range if desc else []):
                    entry['range'] = [rng.from_value, rng.to_value]
                for rng in (desc.integer_range if desc else []):
                    entry['range'] = [rng.from_value, rng.to_value]
                params.append(entry)
            out[name] = {'module': module, 'parameters': params}
            node.destroy_node()
        finally:
            rclpy.shutdown()
    return out


if __name__ == '__main__':
    sys.path.insert(0, str(ROOT))
    json.dump(dump(), sys.stdout, indent=1, sort_keys=True)
