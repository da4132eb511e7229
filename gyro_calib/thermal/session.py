"""The thermal method behind the shared front door.

The thermal method behind the shared front door (registry, CLI, bag calibration, hand-off,
``thermal_calibration_node``).

Feeds :class:`~gyro_calib.thermal.calibrator.ThermalCalibrator` from /gyro/pulses and
/gyro/temperature (sensor per message from ``header.frame_id``) exactly as the live node
does, so a bag gives the same model offline as replayed into the node.

Where the inputs come from, first given wins:

- the scale factor K: ``--scale-factor-rad-per-pulse`` (node parameter), the settings
  (``--config``), the hand-off file of ``--calibration`` (``scale_factor_rad_per_pulse``,
  else ``k_tilde_rad_per_pulse`` with θ = 0, else the K a thermal model in it was fitted
  with), the bench settings stored in the bag; else the calibration refuses to start, naming
  the flag;
- the latitude: ``--latitude-deg``, the settings, the bag's bench settings;
- the sense axis: ``--sense-axis-elevation-deg`` / ``--sense-axis-azimuth-deg``, the
  settings, the bag's bench settings, vertical;
- the gyro id: ``--gyro-id``, the settings, the ``--calibration`` file, the bag's bench.

The hand-off holds the model as one mapping, ``thermal_model``
(:meth:`~gyro_calib.thermal.model.ThermalBiasModel.to_dict`), beside the fit's residual std
and the held-out check (:mod:`gyro_calib.thermal.keys`). ``results()`` holds what the fit
measured, each with its uncertainty: the coefficients (``thermal_coefficient_<term>_rad_s``,
per unit of the centred and scaled term; the model mapping carries centre and scale), the
residual std and the bias stabilities (rad/s).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.bagio.messages import JOINT_STATE, TEMPERATURE
from gyro_calib.errors import ConfigError, GyroCalibError
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.thermal.calibrator import COEFFICIENT_PREFIX, ThermalCalibrator
from gyro_calib.thermal.keys import METHOD
from gyro_calib.thermal.settings import ThermalSettings, thermal_settings_from_mapping
from gyro_calib.thermal.site import RAD_S_PER_DEG_H
from gyro_calib.thermal.terms import parse_term
from gyro_calib.thermal.topics import GYRO_PULSES, GYRO_TEMPERATURE

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection
    from gyro_calib.thermal.allan import NoiseFloor
    from gyro_calib.thermal.fit import ThermalFitReport

TOPICS = {GYRO_PULSES: JOINT_STATE, GYRO_TEMPERATURE: TEMPERATURE}
NODE_NAME = 'thermal_calibration_node'
HOLDOUT_KEYS = ('thermal_holdout_bias_stability_raw_rad_s',
                'thermal_holdout_bias_stability_compensated_rad_s')


def _given(value: Any) -> bool:
    """False for None, NaN and '' (not given)."""
    return value is not None and value != '' and not (
        isinstance(value, float) and math.isnan(value))


def thermal_settings(options: CalibrationOptions) -> tuple[ThermalSettings, dict[str, str]]:
    """The settings of a run and where K, the latitude, the axis and the gyro id came from.

    Settings: the node's parameters, then the config file's values; then the site, axis,
    scale factor and gyro id as the module docstring says.

    Raises:
        ConfigError: an unknown or invalid setting; HandoffError: an unreadable
            ``--calibration`` file, or one holding no scale factor when K is taken from it.
    """
    values, source = options.method_settings(ThermalSettings, NODE_NAME)
    settings = thermal_settings_from_mapping(values, source=source)
    origin: dict[str, str] = {}
    changes: dict[str, Any] = {}
    handoff = None
    if options.calibration_file is not None:
        from gyro_calib.handoff import load_calibration

        handoff = load_calibration(options.calibration_file)

    def pick(field: str, flag: Any, flag_name: str, *, from_file: Any = None,
             file_note: str = '') -> None:
        if _given(flag):
            changes[field], origin[field] = flag, flag_name
        elif field in values and _given(values[field]):
            origin[field] = source
        elif _given(from_file):
            changes[field], origin[field] = from_file, file_note
        elif (stored := options.stored(field)) is not None:
            changes[field], origin[field] = stored

    k_file, k_note = None, ''
    if handoff is not None:
        for key, note in (('scale_factor_rad_per_pulse', ''),
                          ('k_tilde_rad_per_pulse', ', K̃ with θ = 0')):
            if handoff.measured(key) is not None:
                k_file, k_note = handoff.measured(key)[0], f'{key}{note}'  # type: ignore[index]
                break
        else:
            model = handoff.get('thermal_model')
            if isinstance(model, dict) and 'thermal_scale_factor_rad_per_pulse' in model:
                k_file = float(model['thermal_scale_factor_rad_per_pulse'])
                k_note = 'the K its thermal_model was fitted with'
    pick('scale_factor_rad_per_pulse', options.scale_factor_rad_per_pulse,
         '--scale-factor-rad-per-pulse', from_file=k_file,
         file_note=f'{options.calibration_file} ({k_note})')
    if handoff is not None and 'scale_factor_rad_per_pulse' not in origin \
            and k_file is None:
        raise ConfigError(
            f'the calibration file {options.calibration_file} holds no scale factor '
            '(scale_factor_rad_per_pulse or k_tilde_rad_per_pulse): give '
            '--scale-factor-rad-per-pulse.')
    pick('latitude_deg', options.latitude_deg, '--latitude-deg')
    pick('sense_axis_elevation_deg', options.sense_axis_elevation_deg,
         '--sense-axis-elevation-deg')
    pick('sense_axis_azimuth_deg', options.sense_axis_azimuth_deg, '--sense-axis-azimuth-deg')
    pick('gyro_id', options.gyro_id or None, '--gyro-id',
         from_file=(handoff.gyro_id or None) if handoff is not None else None,
         file_note=str(options.calibration_file))
    for name, value in changes.items():
        default = getattr(settings, name)
        if isinstance(default, float):
            value = float(value)
        elif isinstance(default, str):
            value = str(value)
        changes[name] = value
    try:
        settings = dataclasses.replace(settings, **changes)
    except ConfigError as exc:
        raise ConfigError(f'{exc} ({provenance({n: origin[n] for n in changes})})') from None
    return settings, origin


def provenance(origin: dict[str, str], short: dict[str, str] | None = None) -> str:
    """Where settings came from, each source named once.

    Where settings came from, each source named once: ``K and latitude from the bag's
    bench settings; gyro_id from --gyro-id`` (``short`` renames fields).
    """
    by_source: dict[str, list[str]] = {}
    for name, source in origin.items():
        by_source.setdefault(source, []).append((short or {}).get(name, name))
    parts = []
    for source, names in by_source.items():
        listed = names[0] if len(names) == 1 else ', '.join(names[:-1]) + ' and ' + names[-1]
        parts.append(f'{listed} from {source}')
    return '; '.join(parts)


def _minus(centre: float, fmt: str) -> str:
    """'− c' for a centre c ≥ 0, '+ |c|' below (no '− -0.3')."""
    return f'− {centre:{fmt}}' if centre >= 0 else f'+ {-centre:{fmt}}'


class ThermalSession(MethodSession):
    """Temperature bias model of a gyro in a chamber run (METHODS §D)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Build the calibrator from the options.

        Raises:
            ConfigError: a setting is invalid, or K or the latitude is not given (the message
                names the flag).
        """
        self.settings, self.origin = thermal_settings(options)
        self.calibrator = ThermalCalibrator(self.settings)
        self._record_gyro_id = ''  # the gyro id of the hand-off being written
        self._lines: list[str] = []

    # -- input ------------------------------------------------------------------------------
    def topics(self) -> dict[str, str]:
        """/gyro/pulses and /gyro/temperature."""
        return dict(TOPICS)

    def feed(self, batch: SampleBatch) -> None:
        """Pulses (stamp, position[0]) and temperatures (stamp, °C, variance, frame_id)."""
        pulses = batch.joint_state(GYRO_PULSES)
        if pulses is not None:
            self.calibrator.extend_pulses(pulses[0], pulses[1])
        temps = batch.columns.get(GYRO_TEMPERATURE)
        if temps is not None and len(temps.stamp_ns):
            frame = temps.frame_id
            ids = np.asarray(frame.names, dtype=str)[frame.codes] if len(frame.names) else \
                np.full(len(temps.stamp_ns), '')
            self.calibrator.extend_temperatures(temps.stamp_ns,
                                                temps.values['temperature_degc'], ids,
                                                temps.values['variance_degc2'])

    def process(self, *, flush: bool = False) -> list[str]:
        """Reduce what the streams allow; fit when due.

        Reduce what the streams allow; fit at the end (``flush``) or every
        ``refit_every_s``.
        """
        lines = self.calibrator.process(flush=flush)
        self._lines += lines
        return lines

    # -- results ----------------------------------------------------------------------------
    @property
    def report(self) -> ThermalFitReport | None:
        """The last fit's report, or None."""
        try:
            return self.calibrator.report
        except GyroCalibError:
            return None

    def results(self) -> dict[str, Estimate]:
        """Coefficients, residual std and bias stabilities (rad/s), once fitted."""
        return self.calibrator.results()

    def missing(self) -> dict[str, str]:
        """Hand-off keys not measured, with the reason.

        Hand-off keys not measured, with the reason (the held-out figures only when the
        settings ask for a held-out check).
        """
        rep = self.report
        if rep is None:
            why = self.calibrator.missing().get(f'{COEFFICIENT_PREFIX}const_rad_s',
                                                'the thermal model is not fitted yet.')
            return {'thermal_model': why}
        s = self.settings
        if s.calibration_style == 'soak' or s.validation_fraction == 0:
            return {}  # no held-out check was asked for: nothing is missing
        got = self.results()
        return {k: ('the recording is too short for a held-out segment of '
                    f'{s.validation_block_s:g} s beside the fit rows (check the model on '
                    'another run with gyro-calib compensate).')
                for k in HOLDOUT_KEYS if k not in got}

    def rejections(self) -> list[Rejection]:
        """Pulse gaps and glitches, stuck or silent sensors, short plateaus."""
        return list(self.calibrator.rejections)

    def notices(self) -> list[str]:
        """Samples dropped per stream (non-finite, duplicate, late), restarts."""
        out = [line for line in self._lines if 'restarted' in line or 'ignored' in line]
        summary = self.calibrator.stream_summary
        return out + ([f'dropped samples: {summary}'] if summary else [])

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the first to the last averaging interval the model rests on."""
        rep = self.report
        if rep is None:
            return None
        used = np.isfinite(rep.bias_model_rad_s)
        if not np.any(used):
            return None
        half = int(round(self.settings.averaging_interval_s * 5e8))
        t = rep.t_mid_ns[used]
        return int(t[0]) - half, int(t[-1]) + half

    def handoff_values(self) -> dict[str, Any]:
        """``thermal_model`` (the mapping), the residual std and the held-out figures."""
        rep = self.report
        if rep is None:
            return {}
        model = rep.model.to_dict()
        if not model.get('thermal_gyro_id') and self._record_gyro_id:
            model['thermal_gyro_id'] = self._record_gyro_id
        out: dict[str, Any] = {'thermal_model': model,
                               'thermal_residual_std_rad_s': float(rep.model.residual_std_rad_s)}
        for key in HOLDOUT_KEYS:
            est = self.results().get(key)
            if est is not None:
                out[key] = float(est.value)
                out[key + '_std'] = float(est.std_uncertainty)
                out[key + '_dof'] = est.supported_dof
        return out

    def handoff(self, source: str, *, gyro_id: str = '') -> Any:
        """The hand-off record, under the gyro id the model was fitted for.

        The hand-off record, under the gyro id the model was fitted for; a model fitted
        without an id takes the record's (a live node learns it from /sim/scenario after the
        session was built: identity, not numbers).
        """
        self._record_gyro_id = gyro_id
        return super().handoff(source, gyro_id=gyro_id or self.settings.gyro_id)

    # -- human output -----------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """Coefficients and figures in °/h, as the paper quotes them."""
        res = self.results()
        rep = self.report
        if rep is None:
            return [('thermal model', '—', '', '')]
        rows: list[tuple[str, str, str, str]] = []

        def add(name: str, est: Estimate | None) -> None:
            if est is None:
                rows.append((name, '—', '', ''))
            else:
                rows.append((name, f'{est.value / RAD_S_PER_DEG_H:.5f}',
                             f'{est.std_uncertainty / RAD_S_PER_DEG_H:.2g}', str(est.n_used)))

        add('b0: bias at the centre (°/h)', res.get(f'{COEFFICIENT_PREFIX}const_rad_s'))
        for j, term in enumerate(rep.model.terms, start=1):
            add(f't{j}: {term} coefficient (°/h)',
                res.get(f'{COEFFICIENT_PREFIX}{parse_term(term).key}_rad_s'))
        add('fit residual std (°/h)', res.get('thermal_residual_std_rad_s'))
        add('held-out bias stability raw (°/h)', res.get(HOLDOUT_KEYS[0]))
        add('held-out bias stability compensated (°/h)', res.get(HOLDOUT_KEYS[1]))
        add('calibration run bias stability raw (°/h)',
            res.get('thermal_calibration_bias_stability_raw_rad_s'))
        add('calibration run compensated, in-sample (°/h)',
            res.get('thermal_calibration_bias_stability_compensated_rad_s'))
        return rows

    def summary_lines(self) -> list[str]:
        """The summary lines of a thermal run.

        The chosen terms, the inputs used, the SNR per temperature point, the held-out
        check, the floor, and what is missing.
        """
        rep = self.report
        s = self.settings
        lines = [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        if rep is None:
            return lines
        m = rep.model
        sc = m.scaling
        steps = ', '.join(f'{st.action} {st.term} (p = {st.p_value:.2g})'
                          for st in rep.selection.steps if st.action != 'skip') or 'none'
        lines.insert(0, f'model ({m.calibration_style}, {m.n_used} rows): bias = b0'
                     + (''.join(f' + t{j}·{t}' for j, t in enumerate(m.terms, start=1))
                        or ' (constant only)')
                     + f'; stepwise over {", ".join(rep.candidates)}: {steps}'
                     + (f'; held-out check removed {", ".join(rep.pruned)}' if rep.pruned
                        else '') + '.')
        lines.insert(1, f'coefficients are per unit of the scaled variables: H → (H '
                     f'{_minus(sc.centre["H"], ".3f")} °C)/{sc.scale["H"]:.3f} °C, Ḣ → Ḣ/'
                     f'{sc.scale["Hdot"] * 60:.4g} °C/min, dTab → (dTab '
                     f'{_minus(sc.centre["dTab"], ".3g")})/{sc.scale["dTab"]:.3g} °C, dTcs → '
                     f'(dTcs {_minus(sc.centre["dTcs"], ".3g")})/{sc.scale["dTcs"]:.3g} °C (all '
                     'in thermal_model).')
        lines.insert(2, f'calibrated H {m.h_range_c[0]:.2f}…{m.h_range_c[1]:.2f} °C (± '
                     f'{m.extrapolation_margin_c:g} °C margin), Ḣ {m.hdot_range_c_s[0] * 60:.3f}…'
                     f'{m.hdot_range_c_s[1] * 60:.3f} °C/min; K = '
                     f'{m.scale_factor_rad_per_pulse!r} rad/pulse, latitude '
                     f'{m.latitude_deg:g}° ('
                     + provenance({n: self.origin.get(n, 'the settings') for n in (
                         'scale_factor_rad_per_pulse', 'latitude_deg')},
                         short={'scale_factor_rad_per_pulse': 'K', 'latitude_deg': 'latitude'})
                     + '), Earth rate along the sense axis '
                     f'{m.earth_rate_along_axis_rad_s / RAD_S_PER_DEG_H:.4f} °/h; gyro '
                     f'{m.gyro_id or "(unnamed: identity not checked on use)"}.')
        lines.insert(3, (f'model error u_m (held-out scatter beyond noise and covariance, added '
                         f'in quadrature to every prediction, METHODS §D.3 (17g)): '
                         f'{m.model_error_rad_s / RAD_S_PER_DEG_H:.4f} °/h from '
                         f'{m.model_error_n} held-out blocks of {s.stability_block_s:g} s.')
                     if m.model_error_n else
                     'model error u_m: not estimated (no held-out data); 0 in the model.')
        lines += [n for n in rep.notes if n.startswith('temperature sensor')]
        if rep.snr:
            lines.append('per temperature point: H (°C), raw bias (°/h), model at Ḣ = 0 '
                         '(°/h), SNR raw → denoised (dB):')
            for p in rep.snr:
                sel = (rep.t_mid_ns >= p.start_ns) & (rep.t_mid_ns < p.end_ns)
                measured = float(np.nanmean(rep.bias_raw_rad_s[sel])) / RAD_S_PER_DEG_H
                b, _ = m.bias_rad_s(p.h_c, 0.0, sc.centre['dTab'], sc.centre['dTcs'],
                                    check=False)
                lines.append(f'  {p.h_c:7.2f}  {measured:9.4f}  {b[0] / RAD_S_PER_DEG_H:9.4f}  '
                             f'{p.snr_raw_db:5.1f} → {p.snr_denoised_db:5.1f}')
        res = self.results()
        if HOLDOUT_KEYS[1] in res:
            raw, comp = res[HOLDOUT_KEYS[0]], res[HOLDOUT_KEYS[1]]
            lines.append(f'held-out check ({comp.n_used} blocks of {s.stability_block_s:g} s the '
                         f'fit never saw): bias stability {raw.value / RAD_S_PER_DEG_H:.4f} → '
                         f'{comp.value / RAD_S_PER_DEG_H:.4f} °/h.')
        elif not self.missing():
            lines.append('no held-out check in this style: check the model on a run it never '
                         'saw with gyro-calib compensate BAG --calibration FILE.')
        floor = self.noise_floor()
        if floor is not None and math.isfinite(floor.floor.value):
            lines.append(f'noise floor of {s.stability_block_s:g} s means in this record (ARW '
                         f'{floor.angle_random_walk_rad_per_sqrt_s / (math.pi / 180 / 60):.4f} '
                         f'°/√h and pulse quantisation): {floor.floor.value / RAD_S_PER_DEG_H:.4f}'
                         ' °/h; bias stabilities are of the unfiltered rate (raw − model).')
        return lines

    def info_lines(self) -> list[str]:
        """What the calibration would use: intervals, sensors, plateaus, and the summary."""
        table = self.calibrator.table()
        lines = [f'averaging intervals of {self.settings.averaging_interval_s:g} s: '
                 f'{len(table)}; with a valid pulse rate: '
                 f'{int(np.count_nonzero(np.isfinite(table.dcount)))}']
        for sensor, col in table.temperatures_c.items():
            fin = col[np.isfinite(col)]
            if len(fin):
                lines.append(f'  {sensor}: {len(fin)} intervals, '
                             f'{fin.min():.2f}…{fin.max():.2f} °C')
        rep = self.report
        if rep is not None and rep.plateaus:
            lines.append(f'soak plateaus found: {len(rep.plateaus)}')
        return lines + self.summary_lines()

    def noise_floor(self) -> NoiseFloor | None:
        """ARW + quantisation floor of the block means of the compensated calibration run."""
        from gyro_calib.thermal.allan import noise_floor
        from gyro_calib.thermal.intervals import true_runs

        rep = self.report
        if rep is None:
            return None
        comp = rep.bias_raw_rad_s - rep.bias_model_rad_s
        runs = true_runs(np.isfinite(comp))
        if not runs:
            return None
        a, b = max(runs, key=lambda r: r[1] - r[0])
        tau0 = self.settings.averaging_interval_s
        return noise_floor(comp[a:b], tau0, self.settings.stability_block_s,
                           quantisation_rad=rep.model.scale_factor_rad_per_pulse / math.sqrt(12),
                           min_tau_s=10 * tau0)

    def limiting(self) -> str:
        """What limits the model most, as an action."""
        rep = self.report
        if rep is None:
            return next(iter(self.missing().values()), 'no thermal model.')
        res = self.results()
        comp = res.get('thermal_calibration_bias_stability_compensated_rad_s')
        floor = self.noise_floor()
        if comp is None or floor is None or not math.isfinite(floor.floor.value):
            return 'the bias stability after compensation could not be measured.'
        c, f = comp.value / RAD_S_PER_DEG_H, floor.floor.value / RAD_S_PER_DEG_H
        if c <= 1.5 * f:
            return (f'the gyro\'s own noise: raw − model scatters {c:.4f} °/h over '
                    f'{self.settings.stability_block_s:g} s, near the {f:.4f} °/h that angle '
                    'random walk and quantisation allow; more model terms cannot help.')
        return (f'model misfit or bias instability: raw − model scatters {c:.4f} °/h, well above '
                f'the {f:.4f} °/h noise floor; offer more terms (max_h_power, '
                'candidate_terms dynamic or second_order) or look for effects no candidate holds.')

    def json_section(self) -> dict[str, Any]:
        """Results, missing, rejections, and the model mapping (NaN → null)."""
        out = super().json_section()
        rep = self.report
        if rep is not None:
            out['thermal_model'] = finite_json(rep.model.to_dict())
            out['snr_per_point'] = [
                {'h_c': p.h_c, 'snr_raw_db': p.snr_raw_db, 'snr_denoised_db': p.snr_denoised_db,
                 'intervals': p.n} for p in rep.snr]
        document: dict[str, Any] = finite_json(out)
        return document

    def plot(self, out_dir: Path) -> list[Path]:
        """Bias vs H with the model, residuals vs time, before/after."""
        from gyro_calib.thermal.plots import plot_thermal

        if self.report is None:
            return []
        return plot_thermal(self.calibrator, out_dir)


def finite_json(value: Any) -> Any:
    """``value`` with non-finite floats replaced by None (strict JSON)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_json(v) for v in value]
    return value
