"""Closed-loop digital fibre-optic gyro simulator (METHODS §B, seed 001).

Modules: :mod:`~sim_nodes.fog.config` (parameters), :mod:`~sim_nodes.fog.front_end`
(detector, pre-amplifier, ADC, demodulation, the loop's static balance),
:mod:`~sim_nodes.fog.loop` (the loop every transit time τ), :mod:`~sim_nodes.fog.equivalent`
(its long-run equivalent), :mod:`~sim_nodes.fog.sensing` (what the sense axis feels;
injection schedule), :mod:`~sim_nodes.fog.gyro` (:class:`FogSimulator`),
:mod:`~sim_nodes.fog.paper` (Table 1 and the front-end fit), :mod:`~sim_nodes.fog.scenarios`
(the bench streamed in chunks, offline recordings with their truth),
:mod:`~sim_nodes.fog.bag_scenarios` (the committed scenario bags), :mod:`~sim_nodes.fog.fog_node`
(the ``fog_sim`` node).
"""

from __future__ import annotations

from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.gyro import FogSimulator
from sim_nodes.fog.scenarios import (
    BenchChunk,
    FogBench,
    FogRecording,
    SelfCalLadder,
    TableSettings,
    mapping_self_cal_bench,
    simulate_mapping_and_self_cal,
    simulate_turntable,
    turntable_bench,
)
from sim_nodes.fog.sensing import InjectionSchedule

__all__ = ['BenchChunk', 'FogBench', 'FogConfig', 'FogRecording', 'FogSimulator',
           'InjectionSchedule', 'SelfCalLadder', 'TableSettings', 'mapping_self_cal_bench',
           'simulate_mapping_and_self_cal', 'simulate_turntable', 'turntable_bench']
