"""A method node beside a simulator (issue 17 items 4 and 7): where the node's parameters and
the bench the simulator publishes on /sim/scenario disagree, the node says so; the gyro id it
was not given is taken from the published bench (the hand-off no longer says gyro_id: '')."""

from __future__ import annotations

import time
from pathlib import Path

from .dds_harness import NodeProcess, launch


def _wait_for(node: NodeProcess, text: str, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and node.proc.poll() is None:
        if text in node.log():
            return True
        time.sleep(0.2)
    return text in node.log()


def test_thermal_node_reports_a_latitude_that_is_not_the_benchs_and_takes_its_gyro_id(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    """The README's old example: latitude_deg:=45.0 against paper_soak's bench at 34.26°
    (the model's constant came out 2.17 °/h off without a word)."""
    node = launch('thermal_calibration_node', {
        'scale_factor_rad_per_pulse': 1.1150714665519326e-05, 'latitude_deg': 45.0,
        'output_file': str(tmp_path / 'A-1.yaml'), 'fit_after_idle_s': 0.0})
    nodes.append(node)
    sim = launch('thermal_chamber_sim', {'programme': 'validation', 'duration_s': 30.0,
                                         'real_time_factor': 0.0})
    nodes.append(sim)
    assert _wait_for(node, 'bench conflict: latitude_deg: parameter latitude_deg gives 45.0 ° '
                     'but the bench settings stored in /sim/scenario', 60.0), node.log()
    assert '34.26 °; using 45.0 °' in node.log()
    assert _wait_for(node, "gyro_id 'A-1' taken from /sim/scenario", 10.0), node.log()
    assert 'scale_factor_rad_per_pulse: parameter' not in node.log()  # the same K: no line
