"""From the interval table to a thermal bias model (METHODS §D.1–3), as one pure function.

:func:`fit_thermal` does, in order:

1. sensor checks: both cavity sensors present; each sensor interpolated between its
   readings onto the intervals without one (METHODS §D.5; a sensor whose readings lie
   further apart than ``max_temperature_gap_s`` is refused); stuck and silent spans
   blanked (:func:`gyro_calib.thermal.intervals.check_sensors`);
2. variables per interval: raw rate K·ΔN/Δt minus the Earth rate along the sense axis
   = bias; H, Ḣ (causal slope), ΔT_ab, ΔT_cs;
3. denoising of the rate by the lifting wavelet transform, per gap-free run
   (:func:`gyro_calib.thermal.wavelet.denoise`); SNR before/after per temperature point;
4. regression rows: ``continuous`` — means over ``fit_block_s`` blocks of the denoised
   bias and of each (centred, scaled) term column (the terms are evaluated per interval
   and then averaged, so the model predicts interval by interval exactly what it was
   fitted to); ``soak`` — one point per settled soak plateau, with the standard
   uncertainty of its mean from the scatter of its ``stability_block_s`` means;
5. the check of distinct temperature levels against the highest power of H asked for;
6. held-out split (continuous): every n-th ``validation_block_s`` segment is left out;
7. stepwise selection on the fit rows (:func:`gyro_calib.thermal.regression.stepwise`):
   Allan-variance long-run variance up to ``noise_max_span_s`` for block rows,
   Birge-scaled WLS for points; a variable's first power is not removed while a term of
   higher order in it stays (marginality, METHODS §D.3);
8. held-out check: a chosen term is dropped while dropping it does not increase the
   held-out mean square of ``stability_block_s`` residual means (the terms must predict
   data they were not fitted to), under the same marginality rule; a first power missing
   beside its higher terms is added back;
9. final coefficients from all rows with the chosen terms, and the model;
10. model error u_m (METHODS §D.3 eq. (17g)): the mean square of the held-out residual
   block means beyond that of the fit rows' own residual block means and beyond the
   coefficient covariance, stated as a standard uncertainty added in quadrature to every
   prediction of the model.

Uncertainty of the coefficients (continuous style, 1 s intervals): residuals of block
means are autocorrelated (bias instability, quantisation, model misfit, wavelet
smoothing), so the naive OLS standard errors are 2–4× too small. The covariance is
LRV·(XᵀX)⁻¹ with the long-run variance LRV of the residuals read from their Allan
variance up to ``noise_max_span_s`` (default 30 min;
:func:`gyro_calib.thermal.allan.allan_long_run_variance`; :mod:`.regression` says why
not a Newey–West/HAC estimate); ``benchmarks/thermal_coverage.py`` measures how often
the stated uncertainty covers the truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.thermal.allan import bias_stability, block_means
from gyro_calib.thermal.errors import SensorSamplingError, TemperatureDataError
from gyro_calib.thermal.intervals import (
    IntervalTable,
    SensorCheck,
    check_sensors,
    thermal_variables,
    true_runs,
)
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.regression import (
    LinearFit,
    StepwiseResult,
    fit_linear,
    full_rank,
    stepwise,
)
from gyro_calib.thermal.settings import ThermalSettings
from gyro_calib.thermal.site import earth_rate_along_axis_rad_s
from gyro_calib.thermal.soak import Plateau, find_plateaus
from gyro_calib.thermal.terms import (
    Term,
    candidate_terms,
    design_columns,
    distinct_levels,
    main_effects,
    min_levels_for,
    required_variables,
    scaling_from_data,
)
from gyro_calib.thermal.topics import SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL
from gyro_calib.thermal.wavelet import denoise, snr_db
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class PointSnr:
    """SNR of one temperature point before and after denoising (see :func:`snr_db`).

    Attributes:
        h_c: mean H of the segment, °C.
        start_ns, end_ns: the segment.
        snr_raw_db: of the raw interval rate. snr_denoised_db: of the denoised one.
        n: intervals in the segment.
    """

    h_c: float
    start_ns: int
    end_ns: int
    snr_raw_db: float
    snr_denoised_db: float
    n: int


@dataclass(frozen=True, slots=True)
class FitRows:
    """The regression rows (fit blocks or soak points).

    Attributes:
        t_ns: centre stamp of each row.
        y_rad_s: bias (denoised, Earth rate removed), rad/s.
        variables: row means of H, Hdot, dTab, dTcs.
        columns: row means of each candidate term's scaled column.
        sigma_rad_s: standard uncertainty of y (soak points) or None.
        held_out: rows left out of the selection fit.
    """

    t_ns: npt.NDArray[np.int64]
    y_rad_s: npt.NDArray[np.float64]
    variables: dict[str, npt.NDArray[np.float64]]
    columns: dict[str, npt.NDArray[np.float64]]
    sigma_rad_s: npt.NDArray[np.float64] | None
    held_out: npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class ThermalFitReport:
    """Everything the fit produced (for results, log lines and plots).

    Attributes:
        model: the model (final terms, coefficients from all rows).
        fit: the final fit on all rows.
        selection: stepwise result on the fit rows.
        pruned: terms the held-out check removed.
        holdout_fit: the final terms fitted on the fit rows only (None without held-out).
        rows: the regression rows.
        candidates: candidate term names offered.
        holdout_stability_raw, holdout_stability_compensated: bias stability of the
            held-out data, raw and raw − (fit-rows-only model), rad/s (None without).
        calibration_stability_raw, calibration_stability_compensated: the same over the
            whole calibration run with the final model (in-sample), rad/s.
        snr: per temperature point.
        plateaus: soak plateaus found.
        denoise_levels: wavelet levels used (0 = not denoised).
        t_mid_ns: interval centres. bias_raw_rad_s: raw bias per interval.
        bias_denoised_rad_s: denoised. bias_model_rad_s: final model per interval (NaN
            where the variables are missing).
        variables: per-interval H, Hdot, dTab, dTcs.
        rejections: stuck/silent sensor spans, short plateaus.
        notes: whole sentences for the log.
    """

    model: ThermalBiasModel
    fit: LinearFit
    selection: StepwiseResult
    pruned: tuple[str, ...]
    holdout_fit: LinearFit | None
    rows: FitRows
    candidates: tuple[str, ...]
    holdout_stability_raw: Estimate | None
    holdout_stability_compensated: Estimate | None
    calibration_stability_raw: Estimate
    calibration_stability_compensated: Estimate
    snr: tuple[PointSnr, ...]
    plateaus: tuple[Plateau, ...]
    denoise_levels: int
    t_mid_ns: npt.NDArray[np.int64]
    bias_raw_rad_s: npt.NDArray[np.float64]
    bias_denoised_rad_s: npt.NDArray[np.float64]
    bias_model_rad_s: npt.NDArray[np.float64]
    variables: dict[str, npt.NDArray[np.float64]]
    rejections: tuple[Rejection, ...]
    notes: tuple[str, ...]


def denoise_runs(x: npt.NDArray[np.float64], settings: ThermalSettings
                 ) -> tuple[npt.NDArray[np.float64], int]:
    """Denoise each run of finite values separately; return the series and levels used."""
    out = x.copy()
    levels = 0
    if not settings.denoise:
        return out, 0
    for a, b in true_runs(np.isfinite(x)):
        res = denoise(x[a:b], wavelet=settings.wavelet, levels=settings.wavelet_levels,
                      threshold_rule=settings.threshold_rule,
                      threshold_mode=settings.threshold_mode)
        out[a:b] = res.values
        levels = max(levels, res.levels)
    return out, levels


def _group_means(groups: npt.NDArray[np.int64], weight: npt.NDArray[np.float64],
                 values: npt.NDArray[np.float64], n: int) -> npt.NDArray[np.float64]:
    den = np.bincount(groups, weights=weight, minlength=n)
    num = np.bincount(groups, weights=np.where(weight > 0, values, 0.0) * weight, minlength=n)
    with np.errstate(invalid='ignore', divide='ignore'):
        return num / den


def interval_stability(table: IntervalTable, k_mask: npt.NDArray[np.bool_],
                       model_rad_s: npt.NDArray[np.float64] | None, *, scale_factor: float,
                       earth_rad_s: float, block_s: float) -> Estimate:
    """Bias stability of raw (model None) or raw − model, over the masked intervals.

    Blocks of ``block_s`` aligned to the absolute interval grid; a block counts when at
    least 90 % of its intervals are in the mask. Computed from the raw counts (exact).
    """
    nb = int(round(block_s / table.interval_s))
    if not len(table.k):
        return Estimate(math.nan, math.nan, 0, 0)
    shift = int((-table.k[0]) % nb)  # align to k multiple of nb
    dcount = np.where(k_mask, table.dcount, np.nan)[shift:]
    dt = np.where(k_mask, table.dt_ns, 0)[shift:]
    angle = dcount * scale_factor
    if model_rad_s is not None:
        angle = angle - model_rad_s[shift:] * (dt / NS_PER_S)
    means = block_means(angle, dt, intervals_per_block=nb) - earth_rad_s
    return bias_stability(means)


def fit_thermal(table: IntervalTable, settings: ThermalSettings, *,
                frame_ids_seen: tuple[str, ...] = ()) -> ThermalFitReport:
    """Fit the thermal bias model to a reduced recording (see the module docstring).

    Raises:
        TemperatureDataError: no cavity sensor, a needed shell sensor missing, too few
            distinct temperatures for the terms asked, no soak plateau.
        InsufficientDataError: too little valid data for the fit.
    """
    s = settings
    isets = s.interval_settings()
    k_rad = s.scale_factor_rad_per_pulse
    earth = earth_rate_along_axis_rad_s(s.latitude_deg, s.sense_axis_elevation_deg,
                                        s.sense_axis_azimuth_deg, s.earth_rate_deg_h)
    notes: list[str] = []
    rejections: list[Rejection] = []
    _require_cavity_sensors(table, frame_ids_seen)
    if not np.any(np.isfinite(table.dcount)):
        raise InsufficientDataError('no valid /gyro/pulses interval: the pulse topic is missing '
                                    'or every interval has a gap or glitch.')
    check = check_sensors(table, isets)
    _require_readable_sensors(check, s)
    rejections += check.rejections
    notes += check.notes
    temps = check.temperatures_c
    shell = SENSOR_SHELL in temps and bool(np.any(np.isfinite(temps[SENSOR_SHELL])))
    terms = candidate_terms(s.candidate_terms, max_h_power=s.max_h_power, shell=shell)
    if not shell and any('dTcs' in t.variables for t in terms):
        raise TemperatureDataError(
            f'candidate_terms {s.candidate_terms!r} include the cavity-to-shell gradient '
            '(dTcs) but the recording has no shell temperature (frame_id "shell"): record '
            'it or drop dTcs from the candidates.')
    if s.candidate_terms.strip() == 'dynamic' and not shell:
        notes.append('no shell sensor: the cavity-to-shell gradient dTcs is not offered.')
    variables = thermal_variables(temps, isets)
    needed = tuple(sorted(set(required_variables(terms)) | {'H'}))
    rate = table.rate_rad_s(k_rad)
    bias_raw = rate - earth
    valid = np.isfinite(bias_raw)
    for v in needed:
        valid &= np.isfinite(variables[v])
    if np.count_nonzero(valid) < 3:
        raise InsufficientDataError(
            f'only {np.count_nonzero(valid)} interval(s) have both a valid pulse rate and the '
            f'temperatures the terms need ({", ".join(needed)}): nothing to fit.')
    bias_dn, levels = denoise_runs(bias_raw, s)
    if levels:
        notes.append(f'rate denoised with {s.wavelet} ({levels} levels, {s.threshold_rule} '
                     f'{s.threshold_mode} thresholds) before fitting.')
    scaling = scaling_from_data({v: variables[v][valid] for v in variables})
    cols = design_columns(terms, {v: np.where(valid, variables[v], 0.0) for v in variables},
                          scaling)
    names = tuple(t.name for t in terms)
    plateaus = find_plateaus(variables['H'], interval_s=table.interval_s,
                             max_rate_c_per_min=s.soak_max_rate_c_per_min, min_s=s.soak_min_s,
                             settle_fraction=s.soak_settle_fraction)
    snr = _point_snr(table, plateaus, valid, bias_raw + earth, bias_dn + earth,
                     variables['H'], s)
    if s.calibration_style == 'continuous':
        rows, used = _block_rows(table, valid, bias_dn, cols, names, variables, s)
    else:
        rows, used, rej = _soak_rows(table, plateaus, valid, bias_dn, cols, names, variables,
                                     s, k_rad, earth)
        rejections += rej
    _check_levels(rows, terms, s)
    if len(rows.y_rad_s) < 2:
        raise TemperatureDataError(
            f'calibration_style soak found {len(rows.y_rad_s)} usable soak point(s); at least '
            'two (and more than the model has coefficients) are needed.')
    fit_mask = ~rows.held_out
    n_hold = int(np.count_nonzero(rows.held_out))
    lrv_rows = int(round(s.noise_max_span_s / s.fit_block_s)) \
        if s.calibration_style == 'continuous' else 0
    sigma = rows.sigma_rad_s
    keep_while = {t.name: main_effects(t) for t in terms}
    sel = stepwise(rows.y_rad_s[fit_mask], {n: c[fit_mask] for n, c in rows.columns.items()},
                   names, p_enter=s.p_enter, p_remove=s.p_remove, start=s.stepwise_start,
                   sigma=None if sigma is None else sigma[fit_mask], lrv_max_rows=lrv_rows,
                   keep_while=keep_while)
    for step in sel.steps:
        if step.action == 'skip':
            notes.append(f'term {step.term} is collinear with the others on these data and was '
                         'not offered to the stepwise selection.')
    chosen = list(sel.terms)
    pruned: list[str] = []
    holdout_fit = None
    if n_hold:
        chosen, pruned = _prune_on_held_out(rows, chosen, keep_while, s)
        if pruned:
            notes.append(f'held-out check removed {", ".join(pruned)} (no better prediction of '
                         'the held-out data with them).')
    added = _complete_main_effects(rows, chosen, keep_while, fit_mask)
    if added:
        notes.append(f'{", ".join(added)} added back beside the higher-order terms in '
                     'them (a first power stays while its higher powers do).')
    if n_hold:
        holdout_fit = fit_linear(rows.y_rad_s[fit_mask],
                                 {n: c[fit_mask] for n, c in rows.columns.items()}, chosen,
                                 lrv_max_rows=lrv_rows)
    final = fit_linear(rows.y_rad_s, rows.columns, chosen, sigma=sigma, lrv_max_rows=lrv_rows)
    if holdout_fit is not None:
        model_error, model_error_n = _model_error(rows, holdout_fit, chosen, s)
    else:
        model_error, model_error_n = 0.0, 0
        notes.append('no held-out data (validation_fraction 0, a short recording or soak '
                     'points): the model error beyond the coefficient covariance is not '
                     'estimated (thermal_model_error_rad_s 0); check the model on another run '
                     'with compensate.')
    col_index = {n: i for i, n in enumerate(names)}
    x_int = np.column_stack([np.ones(len(table))] + [cols[:, col_index[n]] for n in chosen])
    model_int = np.where(valid, x_int @ final.coefficients, np.nan)
    h_used = variables['H'][used]
    hd_used = variables['Hdot'][used]
    model = ThermalBiasModel(
        gyro_id=s.gyro_id, terms=tuple(chosen),
        coefficients_rad_s=tuple(float(c) for c in final.coefficients),
        covariance_rad2_s2=tuple(tuple(float(c) for c in row) for row in final.covariance),
        scaling=scaling, h_range_c=(float(h_used.min()), float(h_used.max())),
        hdot_range_c_s=(float(np.nanmin(hd_used)), float(np.nanmax(hd_used))),
        extrapolation_margin_c=s.extrapolation_margin_c,
        hdot_margin_fraction=s.hdot_margin_fraction, scale_factor_rad_per_pulse=k_rad,
        latitude_deg=s.latitude_deg, sense_axis_elevation_deg=s.sense_axis_elevation_deg,
        sense_axis_azimuth_deg=s.sense_axis_azimuth_deg, earth_rate_along_axis_rad_s=earth,
        averaging_interval_s=s.averaging_interval_s, hdot_window_s=s.hdot_window_s,
        sensors=tuple(x for x in (SENSOR_CAVITY_A, SENSOR_CAVITY_B, SENSOR_SHELL)
                      if x in temps and np.any(np.isfinite(temps[x]))),
        residual_std_rad_s=final.residual_std,
        fit_block_s=s.fit_block_s if s.calibration_style == 'continuous' else math.nan,
        calibration_style=s.calibration_style, covariance_kind=final.covariance_kind,
        n_used=final.n, dof=final.dof, max_temperature_gap_s=s.max_temperature_gap_s,
        model_error_rad_s=model_error, model_error_n=model_error_n)
    hold_raw = hold_comp = None
    if holdout_fit is not None:
        hold_mask = _held_intervals(table, rows, s) & valid
        model_fit_only = np.where(valid, x_int @ holdout_fit.coefficients, np.nan)
        kw = dict(scale_factor=k_rad, earth_rad_s=earth, block_s=s.stability_block_s)
        hold_raw = interval_stability(table, hold_mask, None, **kw)
        hold_comp = interval_stability(table, hold_mask, model_fit_only, **kw)
    kw = dict(scale_factor=k_rad, earth_rad_s=earth, block_s=s.stability_block_s)
    cal_raw = interval_stability(table, valid, None, **kw)
    cal_comp = interval_stability(table, valid, model_int, **kw)
    return ThermalFitReport(
        model=model, fit=final, selection=sel, pruned=tuple(pruned), holdout_fit=holdout_fit,
        rows=rows, candidates=names, holdout_stability_raw=hold_raw,
        holdout_stability_compensated=hold_comp, calibration_stability_raw=cal_raw,
        calibration_stability_compensated=cal_comp, snr=tuple(snr), plateaus=tuple(plateaus),
        denoise_levels=levels, t_mid_ns=table.t_mid_ns, bias_raw_rad_s=bias_raw,
        bias_denoised_rad_s=bias_dn, bias_model_rad_s=model_int, variables=variables,
        rejections=tuple(sorted(rejections, key=lambda r: r.stamp_ns)), notes=tuple(notes))


def _require_cavity_sensors(table: IntervalTable, frame_ids_seen: tuple[str, ...]) -> None:
    missing = [x for x in (SENSOR_CAVITY_A, SENSOR_CAVITY_B)
               if x not in table.temperatures_c
               or not np.any(np.isfinite(table.temperatures_c[x]))]
    if not missing:
        return
    if not any(np.any(np.isfinite(c)) for c in table.temperatures_c.values()) \
            and not frame_ids_seen:
        raise TemperatureDataError(
            'no /gyro/temperature readings at all: the thermal model needs the cavity '
            'temperatures (sensor_msgs/Temperature with header.frame_id cavity_a and cavity_b). '
            'Record the temperature topic with the pulses.')
    seen = ', '.join(sorted(set(frame_ids_seen))) or 'none'
    raise TemperatureDataError(
        f'no finite reading from temperature sensor(s) {", ".join(missing)} (frame_ids seen: '
        f'{seen}): H is the mean of cavity_a and cavity_b, so both are needed.')


def _require_readable_sensors(check: SensorCheck, s: ThermalSettings) -> None:
    """Refuse a sensor read too sparsely to interpolate.

    Refuse a sensor read so sparsely that it cannot be interpolated onto the intervals:
    its readings lie further apart than ``max_temperature_gap_s`` almost everywhere.
    """
    for name, smp in check.sampling.items():
        if smp.n_points == 0:
            continue
        spacing = smp.typical_spacing_s
        if smp.n_points < 2 or spacing > s.max_temperature_gap_s:
            every = (f'about every {spacing:.4g} s' if math.isfinite(spacing)
                     else f'only {smp.n_points} time(s) in the whole recording')
            need = (f'set max_temperature_gap_s (--config) to at least '
                    f'{math.ceil(1.2 * spacing):g} s '
                    '(if the temperature changes slowly enough over that span) or '
                    if math.isfinite(spacing) else '')
            raise SensorSamplingError(
                f'temperature sensor {name} is read {every}, further apart than '
                f'max_temperature_gap_s = {s.max_temperature_gap_s:g} s: its temperature '
                f'cannot be interpolated between readings; {need}read the sensor more often.')


def _block_rows(table: IntervalTable, valid: npt.NDArray[np.bool_],
                bias_dn: npt.NDArray[np.float64], cols: npt.NDArray[np.float64],
                names: tuple[str, ...], variables: dict[str, npt.NDArray[np.float64]],
                s: ThermalSettings) -> tuple[FitRows, npt.NDArray[np.bool_]]:
    nb = int(round(s.fit_block_s / s.averaging_interval_s))
    bid = table.k // nb
    g = (bid - bid[0]).astype(np.int64)
    n = int(g[-1]) + 1
    w = valid.astype(np.float64)
    cnt = np.bincount(g, weights=w, minlength=n)
    ok = cnt >= s.min_valid_fraction * nb
    if np.count_nonzero(ok) < 3:
        raise InsufficientDataError(
            f'only {np.count_nonzero(ok)} fit block(s) of {s.fit_block_s:g} s have at least '
            f'{s.min_valid_fraction:.0%} valid intervals: record longer or fix the gaps.')
    y = _group_means(g, w, bias_dn, n)[ok]
    columns = {name: _group_means(g, w, cols[:, j], n)[ok] for j, name in enumerate(names)}
    var_means = {v: _group_means(g, w * np.isfinite(x), np.nan_to_num(x), n)[ok]
                 for v, x in variables.items()}
    tint = int(round(s.averaging_interval_s * NS_PER_S))
    t_ns = ((np.arange(n) + bid[0]) * nb * tint + nb * tint // 2)[ok]
    held = np.zeros(len(y), bool)
    if s.validation_fraction > 0:
        period = max(2, int(round(1.0 / s.validation_fraction)))
        seg = (t_ns - t_ns[0]) // int(round(s.validation_block_s * NS_PER_S))
        held = (seg % period) == period // 2
        if np.count_nonzero(~held) < 2 * (len(names) + 2):
            held[:] = False
    used = valid & ok[g]
    return FitRows(t_ns.astype(np.int64), y, var_means, columns, None, held), used


def _held_intervals(table: IntervalTable, rows: FitRows,
                    s: ThermalSettings) -> npt.NDArray[np.bool_]:
    """Intervals inside held-out fit blocks."""
    tint = int(round(s.averaging_interval_s * NS_PER_S))
    nb = int(round(s.fit_block_s / s.averaging_interval_s))
    held_blocks = (rows.t_ns[rows.held_out] - nb * tint // 2) // (nb * tint)
    return np.isin(table.k // nb, held_blocks)


def _soak_rows(table: IntervalTable, plateaus: list[Plateau], valid: npt.NDArray[np.bool_],
               bias_dn: npt.NDArray[np.float64], cols: npt.NDArray[np.float64],
               names: tuple[str, ...], variables: dict[str, npt.NDArray[np.float64]],
               s: ThermalSettings, k_rad: float, earth: float
               ) -> tuple[FitRows, npt.NDArray[np.bool_], list[Rejection]]:
    if not plateaus:
        raise TemperatureDataError(
            f'calibration_style soak found no plateau: no stretch of {s.soak_min_s:g} s with '
            f'|Ḣ| ≤ {s.soak_max_rate_c_per_min:g} °C/min. Soak longer at each set point, or '
            "use calibration_style 'continuous'.")
    nb = int(round(s.stability_block_s / s.averaging_interval_s))
    tint = int(round(s.averaging_interval_s * NS_PER_S))
    y, sig, t_ns = [], [], []
    colv: dict[str, list[float]] = {n: [] for n in names}
    varv: dict[str, list[float]] = {v: [] for v in variables}
    used = np.zeros(len(valid), bool)
    rej: list[Rejection] = []
    for p in plateaus:
        sl = slice(p.settled, p.end)
        ok = valid[sl]
        means = block_means(table.dcount[sl] * k_rad, np.where(ok, table.dt_ns[sl], 0),
                            intervals_per_block=nb) - earth
        means = means[np.isfinite(means)]
        t0 = int(table.k[p.settled]) * tint
        if len(means) < 2:
            rej.append(Rejection(t0, (
                f'soak plateau at H = {np.nanmean(variables["H"][sl]):.2f} °C from '
                f'{format_stamp(t0)}: its settled part holds fewer than two valid '
                f'{s.stability_block_s:g} s blocks, so its uncertainty is unknown; not used.')))
            continue
        idx = np.arange(p.settled, p.end)[ok]
        used[idx] = True
        y.append(float(np.mean(bias_dn[idx])))
        # scatter of the block means, plus the quantisation of the span's two end counts
        # (a handful of equal block means would otherwise claim zero uncertainty)
        span_s = len(means) * s.stability_block_s
        sig.append(math.sqrt(float(np.var(means, ddof=1)) / len(means)
                             + k_rad**2 / 6.0 / span_s**2))
        t_ns.append(int(table.k[(p.settled + p.end) // 2]) * tint)
        for j, n in enumerate(names):
            colv[n].append(float(np.mean(cols[idx, j])))
        for v, x in variables.items():
            varv[v].append(float(np.nanmean(x[idx])) if np.any(np.isfinite(x[idx]))
                           else math.nan)
    rows = FitRows(np.array(t_ns, np.int64), np.array(y),
                   {v: np.array(x) for v, x in varv.items()},
                   {n: np.array(x) for n, x in colv.items()}, np.array(sig),
                   np.zeros(len(y), bool))
    return rows, used, rej


def _check_levels(rows: FitRows, terms: tuple[Term, ...], s: ThermalSettings) -> None:
    need = min_levels_for(terms)
    h = rows.variables['H']
    have = distinct_levels(h, s.distinct_temperature_step_c)
    if have < need:
        top = max(t.h_power() for t in terms)
        lv = np.unique(np.floor(h[np.isfinite(h)] / s.distinct_temperature_step_c))
        shown = ', '.join(f'{v * s.distinct_temperature_step_c:.0f}' for v in lv[:12])
        raise TemperatureDataError(
            f'the recording covers {have} distinct temperature level(s) (H bins of '
            f'{s.distinct_temperature_step_c:g} °C starting at {shown} °C); a model up to '
            f'H^{top} needs at least {need} (its coefficients plus one degree of freedom). '
            'Add set points or a wider ramp, or lower max_h_power / drop the higher powers.')


def _prune_on_held_out(rows: FitRows, chosen: list[str],
                       keep_while: dict[str, tuple[str, ...]],
                       s: ThermalSettings) -> tuple[list[str], list[str]]:
    """Backward elimination of terms on the held-out residual.

    Drop terms while dropping one does not raise the held-out mean-square residual; a
    term another kept term needs (``keep_while``: its main effects) is not dropped.
    """
    fit_mask = ~rows.held_out
    y_fit = rows.y_rad_s[fit_mask]
    cols_fit = {n: c[fit_mask] for n, c in rows.columns.items()}
    y_hold = rows.y_rad_s[rows.held_out]
    groups = rows.t_ns[rows.held_out] // int(round(s.stability_block_s * NS_PER_S))
    _, g = np.unique(groups, return_inverse=True)

    def score(terms: list[str]) -> float:
        fit = fit_linear(y_fit, cols_fit, terms)
        x = np.column_stack([np.ones(len(y_hold))]
                            + [rows.columns[t][rows.held_out] for t in terms])
        r = y_hold - x @ fit.coefficients
        means = np.bincount(g, weights=r) / np.bincount(g)
        return float(np.mean(means**2))

    current = list(chosen)
    pruned: list[str] = []
    base = score(current)
    while current:
        needed = {n for t in current for n in keep_while.get(t, ()) if n != t}
        trials = [(score([t for t in current if t != drop]), drop) for drop in current
                  if drop not in needed]
        if not trials:
            break
        best, drop = min(trials)
        if best > base:
            break
        current.remove(drop)
        pruned.append(drop)
        base = best
    return current, pruned


def _complete_main_effects(rows: FitRows, chosen: list[str],
                           keep_while: dict[str, tuple[str, ...]],
                           fit_mask: npt.NDArray[np.bool_]) -> list[str]:
    """Add the first powers a chosen term needs.

    Add (in place) the candidate first powers a chosen term needs and the model lacks
    (a constant-start selection can enter H³ without H); returns the names added.
    """
    added: list[str] = []
    for t in list(chosen):
        for n in keep_while.get(t, ()):
            if n in chosen or n not in rows.columns:
                continue
            trial = [*chosen, n]
            if full_rank({c: rows.columns[c][fit_mask] for c in trial}, trial,
                         int(np.count_nonzero(fit_mask))) \
                    and np.count_nonzero(fit_mask) - len(trial) - 1 >= 1:
                chosen.append(n)
                added.append(n)
    return added


def _model_error(rows: FitRows, holdout_fit: LinearFit, chosen: list[str],
                 s: ThermalSettings) -> tuple[float, int]:
    """Model error u_m, rad/s, and the held-out blocks it rests on (METHODS §D.3 (17g)).

    The model fitted on the fit rows (after selection on them) predicts the held-out rows.
    Averaged over ``stability_block_s`` blocks g, the held-out residuals r̄_g carry the
    noise of a block mean, the coefficient error x̄_g·C·x̄_gᵀ the covariance states, and
    the error the covariance does not state (the selection's: a term dropped or a spurious
    one kept; a law the terms follow only in the fitted span). The noise of a block mean is
    read from the fit rows' own residuals, averaged over blocks of the same length: they
    hold the noise (bias instability included, whatever its correlation time) and the
    misfit the fit could not absorb, so what remains is how much worse the model predicts
    data it was not selected and fitted on than the data it was:

        u_m² = max(0, mean_g r̄_g² − mean_f r̄_f² − mean_g x̄_g·C·x̄_gᵀ)
    """
    block_ns = int(round(s.stability_block_s * NS_PER_S))
    hold = rows.held_out
    y = rows.y_rad_s[hold]
    x = np.column_stack([np.ones(len(y))] + [rows.columns[t][hold] for t in chosen])
    r = y - x @ holdout_fit.coefficients
    _, g = np.unique(rows.t_ns[hold] // block_ns, return_inverse=True)
    cnt = np.bincount(g).astype(np.float64)
    r_bar = np.bincount(g, weights=r) / cnt
    x_bar = np.column_stack([np.bincount(g, weights=x[:, j]) / cnt for j in range(x.shape[1])])
    coef_var = np.einsum('gi,ij,gj->g', x_bar, holdout_fit.covariance, x_bar)
    _, gf = np.unique(rows.t_ns[~hold] // block_ns, return_inverse=True)
    r_fit = np.bincount(gf, weights=holdout_fit.residuals) / np.bincount(gf)
    excess = float(np.mean(r_bar**2) - np.mean(r_fit**2) - np.mean(coef_var))
    return math.sqrt(max(excess, 0.0)), len(cnt)


def _point_snr(table: IntervalTable, plateaus: list[Plateau], valid: npt.NDArray[np.bool_],
               rate_raw: npt.NDArray[np.float64], rate_dn: npt.NDArray[np.float64],
               h: npt.NDArray[np.float64], s: ThermalSettings) -> list[PointSnr]:
    """SNR before/after denoising on each settled plateau (else on each long valid run)."""
    tint = int(round(s.averaging_interval_s * NS_PER_S))
    spans = [(p.settled, p.end) for p in plateaus]
    if not spans:
        min_n = int(round(600.0 / s.averaging_interval_s))
        spans = [(a, b) for a, b in true_runs(valid) if b - a >= min_n]
    out = []
    for a, b in spans:
        ok = valid[a:b] & np.isfinite(rate_raw[a:b])
        if np.count_nonzero(ok) < 8:
            continue
        out.append(PointSnr(float(np.nanmean(h[a:b][ok])), int(table.k[a]) * tint,
                            int(table.k[b - 1] + 1) * tint, snr_db(rate_raw[a:b][ok]),
                            snr_db(rate_dn[a:b][ok]), int(np.count_nonzero(ok))))
    return out
