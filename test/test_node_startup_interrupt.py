"""A node started alone takes Ctrl-C during its imports quietly: one line, exit 130.

New-user walk: ``ros2 run gyro_calib calibration_node`` (or ``python -m …``) interrupted
while it still loaded NumPy printed a traceback through the imports. Now, as ``gyro-calib``
and bench_demo already do (:mod:`gyro_calib.startup_interrupt`), every node of setup.py's
entry points says ``NODE: interrupted; not started, nothing written.`` and exits 130, with
nothing on stdout; a process that only imports the nodes (a test, a library user) keeps
Python's Ctrl-C.
"""

from __future__ import annotations

import ast
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gyro_calib import startup_interrupt
from gyro_calib.startup_interrupt import NODE_ENTRY_POINTS, starting_node

ROOT = Path(__file__).resolve().parents[1]


def interrupted_while_loading(argv: list[str], marker: str = '_multiarray_umath'
                              ) -> subprocess.CompletedProcess[str]:
    """Run ``python ARGV``; Ctrl-C as soon as ``marker`` (a shared library) is mapped."""
    child = subprocess.Popen(
        [sys.executable, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # noqa: PLW1509
    maps = Path(f'/proc/{child.pid}/maps')
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if marker in maps.read_text():
                break
        except OSError:
            break
        assert child.poll() is None, f'{marker} was never loaded: the node ended first'
        time.sleep(0.002)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


@pytest.mark.parametrize('node', ['calibration_node', 'rate_table_sim',
                                  'multiposition_calibration_node'])
def test_ctrl_c_while_a_node_started_with_python_m_loads_is_one_line_exit_130(
        node: str) -> None:
    done = interrupted_while_loading(['-m', NODE_ENTRY_POINTS[node]])
    assert (done.returncode, done.stdout) == (130, ''), done.stderr
    assert done.stderr == f'{node}: interrupted; not started, nothing written.\n'


def test_ctrl_c_while_a_nodes_console_script_loads_is_one_line_exit_130(
        tmp_path: Path) -> None:
    """``ros2 run gyro_calib noise_node`` runs the console script setuptools writes."""
    script = tmp_path / 'noise_node'
    script.write_text('import sys\nfrom gyro_calib.nodes.noise_node import main\n'
                      'sys.exit(main())\n')
    done = interrupted_while_loading([str(script)])
    assert (done.returncode, done.stdout) == (130, ''), done.stderr
    assert done.stderr == 'noise_node: interrupted; not started, nothing written.\n'


def test_the_nodes_known_are_setup_pys_node_entry_points() -> None:
    tree = ast.parse((ROOT / 'setup.py').read_text(encoding='utf-8'))
    scripts = next(ast.literal_eval(k.value) for node in ast.walk(tree)
                   if isinstance(node, ast.Call) for k in node.keywords
                   if k.arg == 'entry_points')['console_scripts']
    nodes = {name.strip(): target.split(':')[0].strip()
             for name, target in (s.split('=') for s in scripts)}
    del nodes['gyro-calib'], nodes['bench_demo']  # each installs its own start-up handler
    assert nodes == NODE_ENTRY_POINTS


@pytest.mark.parametrize(('argv', 'orig_argv', 'node'), [
    (['/opt/ros/lib/gyro_calib/noise_node', '--ros-args'], None, 'noise_node'),
    (['-m'], ['python', '-m', 'sim_nodes.fog.fog_node', '--ros-args'], 'fog_sim'),
    (['x/gyro_calib/nodes/bag_player.py'], None, 'bag_player'),
    (['-m'], ['python', '-m', 'pytest', '-n', '0'], ''),
    (['/usr/bin/my_tool'], None, ''),
    (['-m'], ['python', '-m', 'gyro_calib.nodes.bench_demo'], ''),
])
def test_the_node_starting_is_told_by_its_command_line(
        argv: list[str], orig_argv: list[str] | None, node: str,
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, 'argv', argv)
    monkeypatch.setattr(sys, 'orig_argv', orig_argv or ['python', *argv])
    assert starting_node() == node


def test_importing_the_nodes_in_process_keeps_ctrl_c_as_it_was() -> None:
    import gyro_calib.nodes  # noqa: F401
    import sim_nodes  # noqa: F401

    assert signal.getsignal(signal.SIGINT) not in startup_interrupt._INSTALLED


def test_every_node_the_demo_and_tests_start_is_an_entry_point() -> None:
    from gyro_calib.nodes.processes import NODE_MODULES

    assert NODE_MODULES.items() <= NODE_ENTRY_POINTS.items()
