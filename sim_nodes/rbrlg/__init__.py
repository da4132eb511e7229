"""Simulators of the rate-biased RLG bench.

Simulators of the rate-biased RLG bench: the RLG, the tilted two-axis mount, the θ procedure,
offline bench runs and the committed scenario definitions.
"""
