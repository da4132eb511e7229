"""The INS hand-off calibration file: what gyro_calib measured, for the navigation system.

One YAML file per gyro holds every value measured, by any method, each with its standard
(k = 1) uncertainty beside it as ``<name>_std`` and, where the estimator knows them, the
degrees of freedom ν of that uncertainty as ``<name>_dof`` (never more than the n − 1 the n
independent measurements support; a scatter of few repetitions is stated widened by
t₀.₈₄₁₃(ν), a 68 % u: its 95 % U is u·t₀.₉₇₅(ν)/t₀.₈₄₁₃(ν), docs/methods.md), under a
top-level ``gyro:`` mapping; which
method produced them, from what data and when, under ``methods:``; and whether anything the
methods that ran would measure is still missing (``complete``, ``missing`` with reasons). All
units are SI and in the key names. A value that was not measured is an *absent key* — never a
placeholder number. Method-specific keys carry the method's prefix (``fog_…``, ``dither_…``,
``thermal_…``); the RBRLG keys keep the names of format 1.

Example (``format_version: 3``)::

    # gyro_calib INS hand-off calibration; layout: gyro_calib/handoff/ (docs/reference/handoff.md)
    format_version: 3
    gyro_calib_version: 0.2.0
    gyro_id: A-1                         # serial or name; binds: another gyro's run is refused
    conventions:                         # what every number is (CONVENTIONS)
      axis: ...
      rate: ...
      units: ...
    complete: false                      # false: a key this bench could give is missing
    missing:                             # those keys, once, each with why
      bias_rad_s: the bias needs the site latitude (--latitude-deg) to remove the Earth rate.
    not_measurable:                      # keys the methods give, but not from such a bench
      fix_error_angle_rad: θ needs the position-table stations of the four-position procedure.
    gyro:
      k_tilde_rad_per_pulse: 4.0860157e-06           # K̃ (§A eq. (3))
      k_tilde_rad_per_pulse_std: 4.8e-14
      k_tilde_rad_per_pulse_dof: 2                   # ν: 3 window pairs (optional key)
      bias_plus_earth_rate_rad_s: 2.4e-05            # ω′ₑ + ω_B along the sense axis
      bias_plus_earth_rate_rad_s_std: 3.0e-08
      window_pairs: 3
    methods:
      rbrlg:                             # the latest run of each method
        source: bags/k_tilde_bench
        created_utc: '2026-11-23T09:30:00+00:00'
        data_start_stamp_ns: 1795426200000000000
        data_end_stamp_ns: 1795426500000000000
        conditions: {heading_deg: 0.0}   # the bench settings its values rest on
        keys: [k_tilde_rad_per_pulse, bias_plus_earth_rate_rad_s, window_pairs]
        earlier_runs: []                 # runs whose values were kept (each with its keys)

A noise run keeps its curves with it, ``methods.noise.deviations.<axis>``: ADEV, MDEV,
HDEV and TOTDEV per τ with their standard uncertainties and EDF (:data:`DEVIATION_FIELDS`).

Each value comes from exactly one run, named by the ``keys`` of its method's latest run or of
one of its ``earlier_runs``: a K̃ of one run beside a θ of another is stated, with each run's
conditions (latitude and heading a bias rests on, the K a thermal model was fitted with; the
scale factor a dither or noise run turned the output into rad with, and where it came from:
``scale_factor_rad_per_pulse`` or, for a FOG's output, ``fog_scale_factor_counts_per_rad``,
with ``scale_factor_from``, absent when the run used none).

The keys each method may write, with units and meaning, are its ``HANDOFF_KEYS`` (listed in
docs/reference/handoff.md); unknown keys are refused (a misspelt key would otherwise be
silently dropped).
Floats need a dot in the mantissa (YAML 1.1: ``4.0e-6``, not ``4e-6``, which reads as a
string). Files of ``format_version`` 1 (RBRLG only, flat metadata) and 2 (one provenance per
method, ``missing`` per method too) still load; they are rewritten as format 3. ``_dof`` is
optional (files written before it still load; a certificate then assumes k = 2 and says so);
it is a number ≥ 0 (``.inf`` for ν = ∞; 0: no coverage interval) and travels with its value
in a merge.

:func:`write_calibration` replaces the file atomically (temporary file in the same
directory, fsync, rename, fsync of the directory), so a reader such as ``imu_corrector``
sees the old file or the new one, never half of one. :func:`update_calibration` merges a
run into the gyro's file key by key (:meth:`Calibration.merged_into`): each quantity is kept
from the run that measured it best (smaller standard uncertainty; the keys that follow it —
counts, quantities derived in the same fit — go with it), one line per key says what was
added, replaced, kept or dropped, and what would make the file inconsistent is refused:
another gyro, another sensor (a single gyro, a triad, an IMU; other channels or another
sample rate), a value differing from the file's by more than 5 combined standard
uncertainties (``replace`` takes the run's values), a model fitted with another scale factor,
a run whose values rest on a scale factor other than the file's by enough to move one of them
by more than 1/5 of its standard uncertainty, either side new (``replace`` with a new scale
factor drops the values of the run resting on the old one, each with a line, and lists them as
missing), while a smaller difference is merged with a line giving the ppm and the shift
(:func:`scale_factor_findings`).

The package, one module an idea, each importing only those before it:
:mod:`~gyro_calib.handoff.schema` (versions, conventions, keys and their checks),
:mod:`~gyro_calib.handoff.runs` (where values came from), :mod:`~gyro_calib.handoff.scale_factor`
(the scale-factor consistency rule), :mod:`~gyro_calib.handoff.merge` (the key-by-key merge
rules), :mod:`~gyro_calib.handoff.sensor` (one sensor per file: kind, channels, sample rate),
:mod:`~gyro_calib.handoff.calibration` (the record of one gyro),
:mod:`~gyro_calib.handoff.layout` (the on-disk shape), :mod:`~gyro_calib.handoff.load` (reading
formats 1–4) and :mod:`~gyro_calib.handoff.write` (atomic write, merge into a file). This
module re-exports their public names.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as the type checker sees them; at run time, on first use
    from gyro_calib.handoff.calibration import Calibration, method_calibration
    from gyro_calib.handoff.layout import (
        DEVIATION_FIELDS,
        CalibrationYaml,
        ProvenanceYaml,
        calibration_to_yaml_dict,
    )
    from gyro_calib.handoff.load import calibration_from_yaml_dict, load_calibration
    from gyro_calib.handoff.merge import MAX_DISAGREEMENT_SIGMA, SAME_RUN, merge_lines
    from gyro_calib.handoff.runs import CalibrationLike, Provenance
    from gyro_calib.handoff.scale_factor import (
        MAX_MODEL_SCALE_FACTOR_PPM,
        MAX_SCALE_FACTOR_SHIFT,
        SCALE_FACTOR_CONDITIONS,
        SCALE_FACTOR_FROM,
        SCALE_FACTOR_NOTE,
        ScaleFactorFindings,
        scale_factor_findings,
        scale_factor_inconsistency,
    )
    from gyro_calib.handoff.schema import (
        CONVENTIONS,
        FORMAT_VERSION,
        IMU_CONVENTION,
        IMU_FORMAT_VERSION,
        IMU_METHODS,
        READ_VERSIONS,
        TWIN_SUFFIXES,
        HandoffError,
        HandoffKey,
        install_default_schema,
        keys_table,
    )
    from gyro_calib.handoff.write import calibration_text, update_calibration, write_calibration

_WHERE = {
    'Calibration': 'gyro_calib.handoff.calibration',
    'method_calibration': 'gyro_calib.handoff.calibration',
    'DEVIATION_FIELDS': 'gyro_calib.handoff.layout',
    'CalibrationYaml': 'gyro_calib.handoff.layout',
    'ProvenanceYaml': 'gyro_calib.handoff.layout',
    'calibration_to_yaml_dict': 'gyro_calib.handoff.layout',
    'calibration_from_yaml_dict': 'gyro_calib.handoff.load',
    'load_calibration': 'gyro_calib.handoff.load',
    'MAX_DISAGREEMENT_SIGMA': 'gyro_calib.handoff.merge',
    'SAME_RUN': 'gyro_calib.handoff.merge',
    'merge_lines': 'gyro_calib.handoff.merge',
    'CalibrationLike': 'gyro_calib.handoff.runs',
    'Provenance': 'gyro_calib.handoff.runs',
    'MAX_MODEL_SCALE_FACTOR_PPM': 'gyro_calib.handoff.scale_factor',
    'MAX_SCALE_FACTOR_SHIFT': 'gyro_calib.handoff.scale_factor',
    'SCALE_FACTOR_CONDITIONS': 'gyro_calib.handoff.scale_factor',
    'SCALE_FACTOR_FROM': 'gyro_calib.handoff.scale_factor',
    'SCALE_FACTOR_NOTE': 'gyro_calib.handoff.scale_factor',
    'ScaleFactorFindings': 'gyro_calib.handoff.scale_factor',
    'scale_factor_findings': 'gyro_calib.handoff.scale_factor',
    'scale_factor_inconsistency': 'gyro_calib.handoff.scale_factor',
    'CONVENTIONS': 'gyro_calib.handoff.schema',
    'FORMAT_VERSION': 'gyro_calib.handoff.schema',
    'IMU_CONVENTION': 'gyro_calib.handoff.schema',
    'IMU_FORMAT_VERSION': 'gyro_calib.handoff.schema',
    'IMU_METHODS': 'gyro_calib.handoff.schema',
    'READ_VERSIONS': 'gyro_calib.handoff.schema',
    'TWIN_SUFFIXES': 'gyro_calib.handoff.schema',
    'HandoffError': 'gyro_calib.handoff.schema',
    'HandoffKey': 'gyro_calib.handoff.schema',
    'install_default_schema': 'gyro_calib.handoff.schema',
    'keys_table': 'gyro_calib.handoff.schema',
    'calibration_text': 'gyro_calib.handoff.write',
    'update_calibration': 'gyro_calib.handoff.write',
    'write_calibration': 'gyro_calib.handoff.write',
}
"""Each re-exported name → the module defining it, imported on first use (:func:`__getattr__`)."""


def __getattr__(name: str) -> Any:
    """A re-exported name, its module imported on first use (PEP 562).

    ``import gyro_calib.handoff`` alone imports none of its modules: the registry installs
    the schema (:mod:`~gyro_calib.handoff.schema`) without NumPy or YAML, so ``gyro-calib
    --help`` loads neither. A submodule's name (``handoff.schema``) imports that submodule.
    """
    from gyro_calib.lazy_names import resolve

    return resolve(__name__, _WHERE, name, globals())


__all__ = [
    'CONVENTIONS', 'DEVIATION_FIELDS', 'FORMAT_VERSION', 'IMU_CONVENTION', 'IMU_FORMAT_VERSION',
    'IMU_METHODS', 'MAX_DISAGREEMENT_SIGMA', 'MAX_MODEL_SCALE_FACTOR_PPM',
    'MAX_SCALE_FACTOR_SHIFT', 'READ_VERSIONS', 'SAME_RUN', 'SCALE_FACTOR_CONDITIONS',
    'SCALE_FACTOR_FROM', 'SCALE_FACTOR_NOTE', 'TWIN_SUFFIXES', 'Calibration', 'CalibrationLike',
    'CalibrationYaml', 'HandoffError', 'HandoffKey', 'Provenance', 'ProvenanceYaml',
    'ScaleFactorFindings', 'calibration_from_yaml_dict', 'calibration_to_yaml_dict',
    'install_default_schema', 'keys_table', 'load_calibration', 'merge_lines',
    'method_calibration', 'scale_factor_findings', 'scale_factor_inconsistency',
    'calibration_text', 'update_calibration', 'write_calibration',
]
