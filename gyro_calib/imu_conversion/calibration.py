"""What a conversion needs from the hand-off file: :class:`PulseCalibration`, its log line."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gyro_calib.thermal.model import ThermalBiasModel


@dataclass(frozen=True, slots=True)
class PulseCalibration:
    """What the conversion needs from the hand-off file, in SI.

    Attributes:
        scale_factor_rad_per_pulse: K (or K̃ when told to take θ = 0), rad/pulse.
        scale_factor_std: its standard uncertainty, rad/pulse.
        scale_factor_key: the hand-off key it came from.
        bias_rad_s: b, rad/s (0 when the file has none: ``bias_known`` False).
        bias_std: its standard uncertainty, rad/s.
        bias_known: the file holds ``bias_rad_s``.
        angle_random_walk_rad_per_sqrt_s: N, rad/√s (0 when the file has none).
        thermal_model: the temperature bias model (the file's ``thermal_model``), or None;
            when set, the bias comes from it live and ``bias_rad_s`` is not used.
        asymmetry: a FOG's scale-factor asymmetry a = 2(K₊ − K₋)/(K₊ + K₋) (ppm/10⁶), 0 if
            not measured; the rate is divided by 1 ± a/2 by its sign (package docstring (3)).
        asymmetry_std: its standard uncertainty (relative).
        nonlinearity: a FOG's IEEE nonlinearity NL (ppm/10⁶): a rectangular ±NL·|ω| term in
            the variance (package docstring (4)); 0 if not measured.
        scale_factor_note: which scale factor applies and why (a FOG: turntable or self-cal,
            and the run it came from), for the log; '' for a pulse gyro.
    """

    scale_factor_rad_per_pulse: float
    scale_factor_std: float
    scale_factor_key: str = 'scale_factor_rad_per_pulse'
    bias_rad_s: float = 0.0
    bias_std: float = 0.0
    bias_known: bool = False
    angle_random_walk_rad_per_sqrt_s: float = 0.0
    thermal_model: ThermalBiasModel | None = None
    asymmetry: float = 0.0
    asymmetry_std: float = 0.0
    nonlinearity: float = 0.0
    scale_factor_note: str = ''

    @property
    def is_fog(self) -> bool:
        """The scale factor is a FOG's (counts/rad, taken as K = 1/SF rad/count)."""
        return self.scale_factor_key.startswith('fog_')


def scale_factor_line(c: PulseCalibration) -> str:
    """'K = value ± std rad/pulse (from KEY)' for logs.

    'K = value ± std rad/pulse (from KEY)' for logs: the quantity is always K, with the
    hand-off key it came from (a model-borne K: the scale factor the thermal_model was
    fitted with, never 'thermal_model = … rad/pulse').
    """
    where = ('the scale factor the thermal_model was fitted with'
             if c.scale_factor_key == 'thermal_model' else c.scale_factor_key)
    if c.is_fog:
        sf = 1.0 / c.scale_factor_rad_per_pulse
        sf_std = c.scale_factor_std * sf * sf
        return (f'SF = {sf!r} ± {sf_std!r} counts/rad (from {where}; K = 1/SF = '
                f'{c.scale_factor_rad_per_pulse!r} rad/count)')
    name = 'K̃' if c.scale_factor_key == 'k_tilde_rad_per_pulse' else 'K'
    return (f'{name} = {c.scale_factor_rad_per_pulse!r} ± {c.scale_factor_std!r} rad/pulse '
            f'(from {where})')
