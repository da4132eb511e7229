"""package.xml names every ROS package the code imports, and nothing it does not.

A colcon / rosdep user gets only what package.xml names: a ROS package the code imports
but package.xml leaves out is a node that dies with ModuleNotFoundError on their machine
(issue 24 §5: std_srvs and lifecycle_msgs were missing). Each Python file is parsed (ast,
imports inside functions and under TYPE_CHECKING included) and the imported top-level
modules that are ROS packages are compared with package.xml:

- gyro_calib/ and sim_nodes/ (what is installed) against ``depend`` / ``exec_depend``;
- test/ against those plus ``test_depend``.

A top-level module is a ROS package when it is installed from a ``ros-*`` wheel (the
wheel's distribution name is ``ros-`` plus the package name) or, when it is not installed
here, when its name follows the ROS package naming (``*_msgs``, ``*_srvs``,
``*_interfaces``, ``rclpy``, ``rosbag2_py``...). ``rosbags`` (the pure-Python MCAP reader
from PyPI) is not a ROS package. Entries with a rosdep system key (``python3-*``) are not
ROS packages and are left alone here.
"""

from __future__ import annotations

import ast
import functools
import importlib.metadata
import importlib.util
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
INSTALLED = ('gyro_calib', 'sim_nodes')

IMPLIED = {
    'rclpy.lifecycle': ('lifecycle_msgs', 'rclpy.lifecycle builds the managed mode\'s '
                        'services (~/change_state, ~/get_state) from lifecycle_msgs types: they '
                        'are part of the nodes\' interface'),
}
"""Imported submodule → ROS package it brings into the nodes' interface, with why."""

DECLARED_UNUSED = {
    'ament_index_python': 'test/test_colcon_build.py calls get_package_prefix in a child '
                          'process (code in a string, which ast does not see)',
}
"""package.xml entries no parsed import needs, each with the reason it is declared."""

ROS_NAME = re.compile(r'^(rclpy|rosbag2_py|launch|launch_ros|ament_index_python|'
                      r'\w+_(msgs|srvs|interfaces|action))$')


@functools.cache
def _distributions() -> dict[str, list[str]]:
    return dict(importlib.metadata.packages_distributions())


def _ros_wheel_package(module: str) -> bool:
    """True when ``module`` is installed here from a ``ros-*`` wheel of the same name."""
    dists = _distributions().get(module, [])
    wheel = 'ros-' + module.replace('_', '-')
    return any(d.lower().replace('_', '-') == wheel for d in dists)


@functools.cache
def is_ros_package(module: str) -> bool:
    """The rule of the module docstring."""
    if _ros_wheel_package(module):
        return True
    return importlib.util.find_spec(module) is None and bool(ROS_NAME.match(module))


def imported_ros_packages(*dirs: str) -> dict[str, set[str]]:
    """ROS package → the files (relative to the repo) importing it, over ``dirs``."""
    found: dict[str, set[str]] = {}
    for d in dirs:
        for path in sorted((REPO / d).rglob('*.py')):
            rel = str(path.relative_to(REPO))
            for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'), rel)):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module] + [f'{node.module}.{a.name}' for a in node.names]
                else:
                    continue
                for name in names:
                    top = name.split('.')[0]
                    if is_ros_package(top):
                        found.setdefault(top, set()).add(rel)
                    for prefix, (package, _) in IMPLIED.items():
                        if name == prefix or name.startswith(prefix + '.'):
                            found.setdefault(package, set()).add(f'{rel} ({prefix})')
    return found


def declared(*tags: str) -> set[str]:
    """The ROS packages package.xml names under ``tags`` (rosdep python3-* keys left out)."""
    root = ET.parse(REPO / 'package.xml').getroot()
    return {e.text.strip() for tag in tags for e in root.iter(tag)
            if e.text and not e.text.strip().startswith('python3-')}


RUN_TAGS = ('depend', 'exec_depend')


def _missing_message(missing: dict[str, set[str]], tag: str) -> str:
    return '; '.join(f'{p} (imported by {", ".join(sorted(files))})'
                     for p, files in sorted(missing.items())) + (
        f': add <{tag}>NAME</{tag}> to package.xml for each.')


def test_the_rule_tells_ros_packages_from_the_rest() -> None:
    assert is_ros_package('rclpy') and is_ros_package('std_srvs')
    assert is_ros_package('lifecycle_msgs') and is_ros_package('sensor_msgs')
    assert is_ros_package('rosbag2_py')  # not installed here: by its name
    assert not is_ros_package('rosbags') and not is_ros_package('numpy')
    assert not is_ros_package('yaml') and not is_ros_package('gyro_calib')


def test_every_ros_package_the_installed_code_imports_is_an_exec_depend() -> None:
    used = imported_ros_packages(*INSTALLED)
    assert {'rclpy', 'std_msgs', 'sensor_msgs', 'std_srvs', 'lifecycle_msgs'} <= set(used)
    missing = {p: f for p, f in used.items() if p not in declared(*RUN_TAGS)}
    assert not missing, _missing_message(missing, 'exec_depend')


def test_every_ros_package_the_tests_import_is_declared() -> None:
    used = imported_ros_packages('test')
    missing = {p: f for p, f in used.items()
               if p not in declared(*RUN_TAGS, 'test_depend')}
    assert not missing, _missing_message(missing, 'test_depend')


def test_package_xml_declares_no_ros_package_nothing_imports() -> None:
    used = set(imported_ros_packages(*INSTALLED, 'test'))
    unused = declared(*RUN_TAGS, 'test_depend', 'build_depend') - used - set(DECLARED_UNUSED)
    assert not unused, (f'package.xml declares {", ".join(sorted(unused))} but no file of '
                        'gyro_calib/, sim_nodes/ or test/ imports it: remove it, or list it in '
                        'DECLARED_UNUSED with the reason.')
    stale = {p for p in DECLARED_UNUSED if p in used or p not in declared(
        *RUN_TAGS, 'test_depend')}
    assert not stale, f'DECLARED_UNUSED lists {sorted(stale)}: imported now, or not declared.'


@pytest.mark.parametrize('package', sorted(DECLARED_UNUSED))
def test_each_declared_unused_entry_is_a_test_depend_where_only_tests_need_it(
        package: str) -> None:
    assert package in declared('test_depend'), (
        f'{package} is needed only by a test ({DECLARED_UNUSED[package]}): make it a '
        '<test_depend>, not a run dependency.')
