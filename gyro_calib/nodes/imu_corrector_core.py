"""imu_corrector without ROS: the hand-off file, the mode, the conversion and the log lines.

:class:`ImuCorrector` is what the node (:mod:`gyro_calib.nodes.imu_corrector_node`) does with
each message, minus the rclpy calls: the node hands it message contents (stamps in int ns) and
publishes the (topic, :class:`~gyro_calib.imu_conversion.ImuAngularVelocity`) pairs it
returns. It logs through ``node.get_logger()`` (a real node, or ``test/fake_node.py``).

Modes, chosen by the hand-off file (re-read when it changes):

- **single gyro** (a file without ``imu:``): ``/gyro/pulses`` (a pulse gyro, K or K̃) or
  ``/fog/output`` (a FOG: ``fog_scale_factor_counts_per_rad`` or the self-calibrated one) →
  :data:`GYRO_IMU`, z = sense axis (:mod:`gyro_calib.imu_conversion` eqs. (1)–(4));
- **triad** (a format-4 file with ``imu:``): ``/imu/pulses`` → :data:`IMU_DATA`, the body rate
  with its full 3×3 covariance (METHODS §F.6 eqs. (16)–(19)).

- **Imu mode** (``imu_input``: a MEMS or FOG IMU driver's sensor_msgs/Imu, issue 36 §5):
  with a triad's file the driver's rates, published at a common scale factor K₀
  (``raw_scale_rad_per_pulse``: ω_m,i = K₀·ṅ_i), are integrated back to counts and corrected
  as in triad mode (M, b, thermal model, full covariance); with an IMU noise run's file (no
  ``imu:``) the rates are passed as measured, with the per-sample covariance
  diag(N²·f + 2·Q²·f²) of each axis (METHODS §E.5 eq. (16)), f from the stamps. The
  message's own accelerometers are passed through — with diag(N_a²·f) as covariance where
  the file has the accelerometer noise — to :data:`IMU_DATA`.

With a multiposition (or Ferraris) hand-off — an ``imu:`` section with ``accelerometer``,
docs/multiposition.md — the section's gyro "pulse" is one raw unit·s of the recorded
sensor_msgs/Imu, so in Imu mode K₀ is 1 unless ``raw_scale_rad_per_pulse`` says otherwise:
ω = M·ω_raw − b. Its accelerometer part is applied to every accelerometer sample (Imu mode or
``accel_input``): a = A·r − b_a, with covariance A·C_r·Aᵀ + (I⊗rᵀ)·C_A·(I⊗r) + diag(u²(b_a))
(C_r the driver's, C_A the section's ``raw_to_body_covariance``; the A–b_a correlation is not
in the file and is left out).

With an accelerometer input (``accel_input``: the IMU driver's sensor_msgs/Imu, issue 36 §3)
each rate is held until the accelerometer sample of its stamp (within
``accel_tolerance_ns``) arrives, and is published with its linear acceleration and
covariance passed through; a rate with no accelerometer sample at its stamp is not published
(a throttled line says so): a consumer never gets a zero acceleration as a measurement.
"""

from __future__ import annotations

import re
from collections import deque
from dataclasses import replace
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from gyro_calib import topics
from gyro_calib.errors import ConfigError, GyroCalibError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import load_calibration
from gyro_calib.imu_body_rate import has_imu_section, load_imu_calibration, triad_rate_model
from gyro_calib.imu_conversion import (
    ImuAngularVelocity,
    PulseRateConverter,
    TriadRateConverter,
    channel_thermal_models,
    pulse_calibration,
    scale_factor_line,
)
from gyro_calib.registry import handoff_schema
from gyro_calib.thermal.site import RAD_S_PER_DEG_H

GYRO_IMU = topics.GYRO_IMU
"""sensor_msgs/Imu: calibrated rate about the gyro's sense axis (z), rad/s, with covariance."""
IMU_DATA = topics.IMU_DATA
"""sensor_msgs/Imu: a triad's calibrated body rate, rad/s, with its full 3×3 covariance."""
IMU_PULSES = topics.IMU_PULSES
"""sensor_msgs/JointState: a triad's three cumulative counts, name = the channel names."""
REFUSED_EVERY = 1000
"""A refused /imu/pulses sample of a kind already logged is logged again every this many."""
MAX_HELD_RATES = 2000
"""Rates held for their accelerometer sample at most; beyond, the oldest is dropped."""

Output = tuple[str, ImuAngularVelocity]


class AccelerometerCorrection:
    """a = A·r − b_a from a section's ``imu.accelerometer``, with its covariance."""

    def __init__(self, section: dict[str, Any]) -> None:
        """A (raw_to_body), b_a (bias_m_s2) and their uncertainty (absent: zero)."""
        self.a = np.asarray(section['raw_to_body'], dtype=np.float64).reshape(3, 3)
        self.b = np.asarray(section['bias_m_s2'], dtype=np.float64).reshape(3)
        cov = section.get('raw_to_body_covariance')
        self.a_cov = (np.zeros((9, 9)) if cov is None
                      else np.asarray(cov, dtype=np.float64).reshape(9, 9))
        u_b = section.get('bias_m_s2_std')
        self.b_var = np.zeros(3) if u_b is None else np.asarray(u_b, dtype=np.float64) ** 2

    def apply(self, raw: tuple[float, float, float], covariance: tuple[float, ...]
              ) -> tuple[tuple[float, float, float], tuple[float, ...]]:
        """The corrected sample and its covariance (row-major 3×3)."""
        r = np.asarray(raw, dtype=np.float64)
        a = self.a @ r - self.b
        j = np.kron(np.eye(3), r)  # ∂(A·r)/∂vec(A), vec row-major
        c_r = np.asarray(covariance, dtype=np.float64).reshape(3, 3)
        if c_r[0, 0] < 0:  # the driver marks its acceleration unknown: calibration part only
            c_r = np.zeros((3, 3))
        cov = self.a @ c_r @ self.a.T + j @ self.a_cov @ j.T + np.diag(self.b_var)
        return ((float(a[0]), float(a[1]), float(a[2])),
                tuple(float(v) for v in (0.5 * (cov + cov.T)).ravel()))


class ImuNoise:
    """Imu mode with an IMU noise run's file: per-axis N, Q and N_a, SI (issue 36 §5)."""

    def __init__(self, arw: tuple[float, ...], quantisation: tuple[float, ...],
                 accel_vrw: tuple[float, ...] | None) -> None:
        """N (rad/√s), Q (rad) per axis x, y, z; N_a (m/s/√s) or None."""
        self.arw, self.quantisation, self.accel_vrw = arw, quantisation, accel_vrw

    def rate(self, t_ns: int, dt_s: float, omega: tuple[float, float, float]
             ) -> ImuAngularVelocity:
        """The driver's rate with its per-sample covariance, METHODS §E.5 eq. (16)."""
        f = 1.0 / dt_s
        var = [n * n * f + 2.0 * q * q * f * f for n, q in zip(self.arw, self.quantisation,
                                                                 strict=True)]
        cov = (var[0], 0.0, 0.0, 0.0, var[1], 0.0, 0.0, 0.0, var[2])
        return ImuAngularVelocity(t_ns, (float(omega[0]), float(omega[1]), float(omega[2])),
                                  cov)

    def accel_covariance(self, dt_s: float, driver: tuple[float, ...]) -> tuple[float, ...]:
        """diag(N_a²·f) where the file holds N_a, else the driver's own covariance."""
        if self.accel_vrw is None:
            return tuple(driver)
        v = [n * n / dt_s for n in self.accel_vrw]
        return (v[0], 0.0, 0.0, 0.0, v[1], 0.0, 0.0, 0.0, v[2])


def channel_temperature_topic(channel: str) -> str:
    """The temperature topic of a triad channel: /imu/<channel>/temperature."""
    return f'/imu/{channel}/temperature'


class _Logger(Protocol):
    def info(self, line: str) -> Any: ...
    def warning(self, line: str) -> Any: ...
    def error(self, line: str) -> Any: ...


class _NodeLike(Protocol):
    def get_logger(self) -> Any: ...


class ImuCorrector:
    """The node's behaviour, fed message contents (module docstring)."""

    def __init__(self, node: _NodeLike, *, use_k_tilde: bool = False, gyro_id: str = '',
                 thermal_max_age_s: float = 30.0, equal_variances: bool = False,
                 accel_input: str = '', accel_tolerance_ns: int = 100_000,
                 imu_input: str = '', raw_scale_rad_per_pulse: float = 0.0) -> None:
        """Start with no calibration (nothing is published until a valid file is read).

        ``accel_input``: the topic of the IMU driver's sensor_msgs/Imu whose accelerometers
        are passed through ('' = none: the output carries no accelerometer).
        """
        self.imu_input, self.raw_scale = imu_input, raw_scale_rad_per_pulse
        if imu_input:
            accel_input = imu_input  # the Imu's own accelerometers, paired by its stamp
        self.accel_input, self.accel_tolerance_ns = accel_input, accel_tolerance_ns
        self.imu_noise: ImuNoise | None = None
        self.accel_correction: AccelerometerCorrection | None = None
        self._section_raw_scale = 0.0  # K0 a multiposition section implies (1: raw unit·s)
        self._imu_last: tuple[int, Any] | None = None
        self._imu_counts: npt.NDArray[np.float64] | None = None
        self._held: deque[Output] = deque()
        self._accels: deque[tuple[int, tuple[float, float, float], tuple[float, ...]]] = \
            deque()
        self._unpaired = 0
        self.node = node
        self.use_k_tilde, self.gyro_id = use_k_tilde, gyro_id
        self.thermal_max_age_s, self.equal_variances = thermal_max_age_s, equal_variances
        self.converter: PulseRateConverter | None = None
        self.triad: TriadRateConverter | None = None
        self._file_key: tuple[int, int, int] | None = None
        self._last_problem = ''
        self._thermal_state = ''
        self._skipped = 0
        self._refused: dict[str, int] = {}

    @property
    def log(self) -> Any:
        """The node's logger."""
        return self.node.get_logger()

    @property
    def output(self) -> str:
        """The Imu topic of the current mode."""
        return IMU_DATA if self.triad is not None or self.imu_noise is not None else GYRO_IMU

    @property
    def reads_fog(self) -> bool:
        """Single-gyro mode with a FOG's calibration: counts come on /fog/output."""
        return self.converter is not None and self.converter.calibration.is_fog

    @property
    def thermal_channels(self) -> tuple[str, ...]:
        """Triad channels whose bias comes from a thermal model (they need temperatures)."""
        return tuple(self.triad.thermal) if self.triad is not None else ()

    # ------------------------------------------------------------------ file

    def poll_file(self, path: str) -> None:
        """Load the hand-off file if it changed (inode, mtime, size); log what is used."""
        import os

        if not path:
            self._problem('parameter calibration_file is not set: give the hand-off YAML '
                          '(-p calibration_file:=/path/gyro.yaml).')
            return
        try:
            st = os.stat(path)
            key: tuple[int, int, int] | None = (st.st_ino, st.st_mtime_ns, st.st_size)
        except OSError:
            key = None
        if key is not None and key == self._file_key:
            return
        self._file_key = key
        try:
            if key is not None and has_imu_section(path):
                self._load_triad(path)
            elif self.imu_input:
                self._load_imu_noise(path)
            else:
                self._load_single(path)
        except GyroCalibError as exc:
            self._problem(str(exc))
            return
        self._last_problem = ''

    def _load_single(self, path: str) -> None:
        calibration = pulse_calibration(load_calibration(path, handoff_schema()),
                                        use_k_tilde=self.use_k_tilde, gyro_id=self.gyro_id)
        if self.converter is None or self.converter.calibration.is_fog != calibration.is_fog:
            self.converter = PulseRateConverter(calibration,
                                                thermal_max_age_s=self.thermal_max_age_s)
        else:
            self.converter.calibration = calibration
        self.triad = self.accel_correction = None
        self._section_raw_scale = 0.0
        c = calibration
        source = topics.FOG_OUTPUT if c.is_fog else topics.GYRO_PULSES
        self.log.info(
            f'calibration loaded from {path}: {scale_factor_line(c)}, bias = '
            + (f'{c.bias_rad_s!r} ± {c.bias_std!r} rad/s' if c.thermal_model is None
               else 'from thermal_model') + f'; reading {source}, publishing {GYRO_IMU}')
        if c.is_fog:
            self.log.info(f'FOG: {c.scale_factor_note}.')
        if self.equal_variances:
            self.log.warning('equal_variances applies to triad mode only: a single gyro '
                             'measures z alone (x and y carry no information).')
        m = c.thermal_model
        if m is not None:
            self._thermal_state = ''
            self.log.info(
                f'thermal model of gyro {m.gyro_id or "(unnamed)"}: bias = b0 + '
                f'{" + ".join(m.terms) or "(constant)"}, calibrated H {m.h_range_c[0]:.2f}…'
                f'{m.h_range_c[1]:.2f} °C ± {m.extrapolation_margin_c:g} °C; the bias is '
                f'taken live from {topics.GYRO_TEMPERATURE}'
                + ('' if c.scale_factor_key != 'thermal_model' else
                   '; K is the one the model was fitted with (its uncertainty is not in the '
                   'file, so the Imu variance leaves it out)'))
            if not self.gyro_id:
                self.log.warning('parameter gyro_id is not set: the thermal model\'s '
                                 'gyro identity is not checked.')
        elif not c.bias_known:
            self.log.warning('the calibration has no bias_rad_s'
                             + (' (fog_bias_rad_s)' if c.is_fog else '')
                             + ': the rates are NOT bias-corrected (calibrate with the site '
                             'latitude).')
        if c.angle_random_walk_rad_per_sqrt_s == 0.0:
            self.log.warning('the calibration has no angle_random_walk_rad_per_sqrt_s: '
                             'the Imu variance holds quantisation, K and bias only.')

    def _load_imu_noise(self, path: str) -> None:
        """Imu mode with an IMU noise run's file: the per-axis N, Q (and N_a) it holds."""
        from gyro_calib.export.source import AXES, read_source

        src = read_source(path)
        n = [src.gyro[a].get('N') for a in AXES]
        if any(t is None for t in n):
            raise ConfigError(f'calibration file {path}: imu_input needs each axis\'s gyro '
                              'angle random walk (imu_gyro_<axis>_angle_random_walk_rad_per_'
                              'sqrt_s, from gyro-calib noise on the IMU\'s Imu topic) or a '
                              'triad\'s imu: section.')
        q = [src.gyro[a]['Q'].value if 'Q' in src.gyro[a] else 0.0 for a in AXES]
        na = ([src.accel[a]['N'].value for a in AXES]
              if all('N' in src.accel[a] for a in AXES) else None)
        self.imu_noise = ImuNoise(tuple(t.value for t in n if t is not None), tuple(q),
                                  None if na is None else tuple(na))
        self.triad = self.converter = self.accel_correction = None
        self._section_raw_scale = 0.0
        self.log.info(
            f'IMU noise calibration loaded from {path}: N = '
            + ', '.join(f'{v:.6g}' for v in self.imu_noise.arw) + ' rad/√s (x, y, z); '
            f'reading {self.imu_input}, publishing {IMU_DATA} with covariance diag(N²·f + '
            '2·Q²·f²), accelerometers passed through'
            + (' with covariance diag(N_a²·f)' if na is not None else ''))
        self.log.warning('the file holds no gyro bias or scale factor (a noise run measures '
                         'none): the rates are passed as the driver gives them.')

    @property
    def k0(self) -> float:
        """K₀ of Imu mode: the parameter, else the section's (1 for a multiposition one)."""
        return self.raw_scale if self.raw_scale > 0 else self._section_raw_scale

    def _load_triad(self, path: str) -> None:
        cal = load_imu_calibration(path)
        model = triad_rate_model(cal, source=f'calibration file {path}')
        self.accel_correction = (AccelerometerCorrection(cal.accelerometer)
                                 if cal.accelerometer else None)
        self._section_raw_scale = 1.0 if cal.accelerometer else 0.0
        thermal = channel_thermal_models(cal, model)
        old = self.triad
        if old is not None and not thermal and not old.thermal:
            old.model = model  # keep the reference sample
        else:
            self.triad = TriadRateConverter(model, thermal,
                                            thermal_max_age_s=self.thermal_max_age_s,
                                            equal=self.equal_variances)
        self.converter = None
        self.imu_noise = None
        if self.imu_input and self.accel_correction is not None:
            unit = self.accel_correction_unit(cal.accelerometer)
            self.log.info(
                f'IMU section (multiposition): the gyro\'s M is per raw unit of the recorded '
                f'Imu, ω = M·ω_raw − b with K0 = {self.k0:g}'
                + ('' if self.raw_scale <= 0 or self.raw_scale == 1.0 else
                   ' (raw_scale_rad_per_pulse as given; the section implies 1)')
                + f'; accelerometers corrected, a = A·r − b_a (raw unit {unit})')
        elif self.accel_input and self.accel_correction is not None:
            self.log.info('IMU section (multiposition): accelerometers from '
                          f'{self.accel_input} corrected, a = A·r − b_a')
        if self.imu_input and not self.k0 > 0:
            self.log.error(f'imu_input with a triad\'s file needs raw_scale_rad_per_pulse (K0, '
                           f'the scale factor the driver publishes each channel\'s rate with, '
                           f'ω = K0·Δn/Δt): set it; nothing is published from '
                           f'{self.imu_input} until then.')
        k = ', '.join(f'{c} {v:.6g}' for c, v in zip(
            model.channels, model.scale_factor_rad_per_pulse, strict=True))
        self.log.info(
            f'triad calibration loaded from {path}: channels {list(model.channels)} '
            f'(K = 1/|row of M⁻¹|: {k} rad/pulse), ω = M·ṅ − b with the full covariance '
            '(METHODS §F.6)' + (', equal variances (the largest) on every axis'
                                if self.equal_variances else '')
            + f'; reading {self.imu_input or IMU_PULSES}, publishing {IMU_DATA}')
        if thermal:
            self.log.info('thermal bias of channel(s) ' + ', '.join(
                f'{c} from {channel_temperature_topic(c)}' for c in thermal))
        if not model.bias_known:
            self.log.warning('the calibration has no imu.bias_rad_s: the rates are NOT '
                             'bias-corrected' + (f' ({cal.missing["bias_rad_s"]})'
                                                 if 'bias_rad_s' in cal.missing else '.'))
        no_arw = [c for c, n in zip(model.channels, model.arw_rad_per_sqrt_s, strict=True)
                  if n == 0.0]
        if no_arw:
            self.log.warning(f'no angle random walk for channel(s) {", ".join(no_arw)} '
                             '(imu.noise): their count noise is quantisation only.')

    @staticmethod
    def accel_correction_unit(section: dict[str, Any]) -> str:
        """The raw unit the section's accelerometer was calibrated in ('m/s²' if not said)."""
        return str(section.get('raw_unit') or 'm/s²')

    def _problem(self, message: str) -> None:
        if message != self._last_problem:  # once per distinct problem, not every poll
            self._last_problem = message
            using = self.converter is not None or self.triad is not None
            self.log.error(message + (
                ' Keeping the calibration in use.' if using
                else ' Nothing is published until a valid file appears.'))

    # -------------------------------------------------------------- messages

    def on_gyro_pulses(self, t_ns: int, names: list[str], positions: list[float]
                       ) -> list[Output]:
        """A /gyro/pulses message (used in single-gyro mode with a pulse gyro's file)."""
        if self.converter is None or self.reads_fog:
            return []
        return self._single(t_ns, names, positions, topics.GYRO_JOINT)

    def on_fog_output(self, t_ns: int, names: list[str], positions: list[float]
                      ) -> list[Output]:
        """A /fog/output message (used in single-gyro mode with a FOG's file)."""
        if not self.reads_fog:
            return []
        return self._single(t_ns, names, positions, topics.FOG_JOINT)

    def _single(self, t_ns: int, names: list[str], positions: list[float], joint: str
                ) -> list[Output]:
        assert self.converter is not None
        try:
            count = positions[names.index(joint) if names else 0]
        except (ValueError, IndexError):
            return self._outputs([Rejection(t_ns, f'no position for joint "{joint}" '
                                                  f'(names {names}).')])
        return self._outputs(self.converter.add_pulse(t_ns, count))

    def on_temperature(self, t_ns: int, celsius: float, frame_id: str) -> list[Output]:
        """A /gyro/temperature reading (single-gyro mode with a thermal model)."""
        if self.converter is None:
            return []
        return self._outputs(self.converter.add_temperature(t_ns, celsius, frame_id))

    def on_imu_pulses(self, t_ns: int, names: list[str], positions: list[float]
                      ) -> list[Output]:
        """An /imu/pulses message (triad mode)."""
        if self.triad is None:
            return []
        return self._outputs(self.triad.add_pulses(t_ns, names, positions))

    def on_channel_temperature(self, channel: str, t_ns: int, celsius: float,
                               frame_id: str) -> list[Output]:
        """A reading of /imu/<channel>/temperature (triad mode with thermal models)."""
        if self.triad is None:
            return []
        return self._outputs(self.triad.add_temperature(channel, t_ns, celsius, frame_id))

    def _outputs(self, outs: list[ImuAngularVelocity | Rejection]) -> list[Output]:
        """The rates to publish, in stamp order; log why samples got none."""
        topic = self.output
        published: list[Output] = []
        for out in outs:
            if isinstance(out, Rejection) and out.reason.startswith('no thermal compensation'):
                self._thermal_problem(out.reason)
                continue
            if isinstance(out, ImuAngularVelocity) and self._thermal_state:
                self._thermal_state = ''
                bias = self.converter.last_bias if self.converter is not None else None
                self.log.info(
                    f'thermal compensation resumed at stamp {out.stamp_ns} ns'
                    + (f' (bias {bias[0] / RAD_S_PER_DEG_H:.4f} °/h)' if bias is not None
                       else '') + f'; publishing {topic} again.')
            if isinstance(out, Rejection):
                self._rejected(out)
            else:
                published.append((topic, out))
        if self.accel_input:
            self._held.extend(published)
            return self._paired()
        return published

    # ------------------------------------------------------------ Imu mode

    def on_imu(self, t_ns: int, angular_velocity_rad_s: tuple[float, float, float],
               acceleration_m_s2: tuple[float, float, float],
               acceleration_covariance: tuple[float, ...]) -> list[Output]:
        """A message of the IMU driver's sensor_msgs/Imu (``imu_input``, issue 36 §5)."""
        if not self.imu_input:
            return []
        last, self._imu_last = self._imu_last, (t_ns, np.asarray(angular_velocity_rad_s,
                                                                 dtype=float))
        rates: list[ImuAngularVelocity | Rejection] = []
        if self.triad is not None and self.k0 > 0:
            counts = (np.zeros(3) if last is None or self._imu_counts is None
                      else self._imu_counts + np.asarray(angular_velocity_rad_s, dtype=float)
                      / self.k0 * (t_ns - last[0]) * 1e-9)
            self._imu_counts = counts
            rates = self.triad.add_pulses(t_ns, list(self.triad.model.channels),
                                          [float(c) for c in counts])
        elif self.imu_noise is not None and last is not None and t_ns > last[0]:
            rates = [self.imu_noise.rate(t_ns, (t_ns - last[0]) * 1e-9, angular_velocity_rad_s)]
        if self.imu_noise is not None and last is not None and t_ns > last[0]:
            acceleration_covariance = self.imu_noise.accel_covariance(
                (t_ns - last[0]) * 1e-9, acceleration_covariance)
        accel = self.on_accel(t_ns, acceleration_m_s2, acceleration_covariance)
        return accel + self._outputs(rates)

    # ------------------------------------------------------- accelerometers

    def on_accel(self, t_ns: int, acceleration_m_s2: tuple[float, float, float],
                 covariance: tuple[float, ...]) -> list[Output]:
        """A sample of the IMU driver's accelerometers (``accel_input``, issue 36 §3)."""
        if not self.accel_input:
            return []
        if self.accel_correction is not None:
            acceleration_m_s2, covariance = self.accel_correction.apply(acceleration_m_s2,
                                                                        covariance)
        self._accels.append((t_ns, acceleration_m_s2, tuple(covariance)))
        while len(self._accels) > MAX_HELD_RATES:
            self._accels.popleft()
        return self._paired()

    def _paired(self) -> list[Output]:
        """Held rates matched to the accelerometer sample of their stamp, in stamp order."""
        out: list[Output] = []
        tol = self.accel_tolerance_ns
        while self._held and self._accels:
            topic, rate = self._held[0]
            t_a, acc, cov = self._accels[0]
            if abs(t_a - rate.stamp_ns) <= tol:
                out.append((topic, replace(rate, linear_acceleration_m_s2=acc,
                                           linear_acceleration_covariance=cov)))
                self._held.popleft()
                self._accels.popleft()
            elif t_a < rate.stamp_ns:
                self._accels.popleft()  # an accelerometer sample with no rate at its stamp
            else:
                self._held.popleft()
                self._no_accel(rate.stamp_ns, t_a)
        while len(self._held) > MAX_HELD_RATES:
            self._no_accel(self._held.popleft()[1].stamp_ns, None)
        return out

    def _no_accel(self, t_ns: int, next_accel_ns: int | None) -> None:
        self._unpaired += 1
        if self._unpaired % 100 == 1:
            why = ('none has arrived for the last '
                   f'{MAX_HELD_RATES} rates' if next_accel_ns is None
                   else f'the next is at {next_accel_ns} ns')
            self.log.warning(
                f'{self._unpaired} rate(s) not published so far: no accelerometer sample on '
                f'{self.accel_input} within {self.accel_tolerance_ns} ns of stamp {t_ns} ns '
                f'({why}); a rate is published only with its own accelerometer sample.')

    def _rejected(self, out: Rejection) -> None:
        if out.reason.startswith('channel names'):
            kind = re.sub(r'\d+', '#', out.reason)
            n = self._refused[kind] = self._refused.get(kind, 0) + 1
            if n % REFUSED_EVERY == 1:
                self.log.warning(f'{IMU_PULSES}: {out.reason}'
                                 + (f' ({n} such samples refused so far)' if n > 1 else ''))
            return
        self._skipped += 1
        if self._skipped % 100 == 1:
            self.log.warning(f'{self._skipped} pulse sample(s) skipped so far; latest: '
                             f'{out.reason}')

    def _thermal_problem(self, reason: str) -> None:
        """Log why nothing is published, once per kind of reason (numbers aside)."""
        kind = re.sub(r'[-+0-9.:]+', '#', reason)
        if kind != self._thermal_state:
            self._thermal_state = kind
            self.log.warning(f'{reason} Publishing nothing on {self.output} until the '
                             'thermal model can give the bias.')
