"""Settings shared by every method: ROS 2 parameter files and dataclass field descriptions.

Each method has its own frozen settings dataclass (e.g. :class:`gyro_calib.rbrlg.config.
KTildeConfig`), validated once in ``__post_init__``; the attribute docstring after each field
is the single source of the parameter description its node declares.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from gyro_calib.errors import ConfigError


def read_parameter_file(path: str | Path, *, node_name: str) -> dict[str, Any]:
    """The settings in a YAML file: a plain mapping, or a ROS 2 parameter file
    (``<node_name>:`` or ``/**:`` → ``ros__parameters:``).

    Raises:
        ConfigError: if the file cannot be read or parsed, or holds no mapping.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding='utf-8'))
    except OSError as exc:
        raise ConfigError(f'cannot read config file {path}: {exc.strerror}.') from None
    except yaml.YAMLError as exc:
        raise ConfigError(f'config file {path} is not valid YAML: {exc}.') from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f'config file {path} must hold a mapping of fields.')
    for key in (node_name, '/**'):
        if isinstance(data.get(key), dict) and 'ros__parameters' in data[key]:
            data = data[key]['ros__parameters']
            break
    return dict(data)


def field_descriptions(cls: type) -> dict[str, str]:
    """Attribute docstrings of a dataclass (the string right after each field), by field name.

    They are the single source of the parameter descriptions the nodes declare.
    """
    import ast
    import inspect
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    out: dict[str, str] = {}
    for node, after in zip(body, body[1:]):
        if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)):
            out[node.target.id] = ' '.join(after.value.value.split())
    return out
