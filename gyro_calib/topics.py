"""The topic contract (names, joint names, units), shared by nodes, bags and tests.

All topics carry SI units (REP 103). Header stamps are the sample instants.
"""

from __future__ import annotations

from collections.abc import Iterable

RATE_TABLE_JOINT_STATES = '/rate_table/joint_states'
"""sensor_msgs/JointState, name ['rate_table']: unwrapped encoder angle (rad), rate (rad/s)."""
RATE_TABLE_ZERO_INDEX = '/rate_table/zero_index'
"""std_msgs/Header: stamp = instant the reference mark passed (either direction)."""
GYRO_PULSES = '/gyro/pulses'
"""sensor_msgs/JointState, name ['gyro']: cumulative pulse count (integer in float64)."""
IMU_PULSES = '/imu/pulses'
"""sensor_msgs/JointState, name = the triad's three channel names (default ['x', 'y', 'z']):
position = cumulative pulse counts per channel (float64), header stamps as /gyro/pulses."""
GYRO_IMU = '/gyro/imu'
"""sensor_msgs/Imu from imu_corrector (single gyro): the calibrated rate about the sense axis
(z), rad/s, with covariance."""
IMU_DATA = '/imu/data'
"""sensor_msgs/Imu from imu_corrector (triad): the calibrated body rate, rad/s, with its full
3×3 covariance."""
K_TILDE = '/gyro_calib/k_tilde'
"""std_msgs/Float64, transient-local: running K̃, rad/pulse."""
DIAGNOSTICS = '/diagnostics'
"""diagnostic_msgs/DiagnosticArray: values, uncertainties, counts, last rejection reason."""
RATE_TABLE_TRUE_MOTION = '/sim/rate_table/true_motion'
"""Simulation only. sensor_msgs/JointState batch: position[i] true angle (rad), velocity[i]
true rate (rad/s), effort[i] stamp of sample i minus header.stamp (ns)."""

RATE_TABLE_JOINT = 'rate_table'
GYRO_JOINT = 'gyro'

POSITION_TABLE_JOINT_STATES = '/position_table/joint_states'
"""sensor_msgs/JointState, name ['position_table']: unwrapped encoder angle (rad), rate (rad/s)."""
POSITION_TABLE_ZERO_INDEX = '/position_table/zero_index'
"""std_msgs/Header: stamp = instant the position table's reference mark passed."""
FIX_ERROR_ANGLE = '/gyro_calib/fix_error_angle'
"""std_msgs/Float64, transient-local: θ, rad."""
SCALE_FACTOR = '/gyro_calib/scale_factor'
"""std_msgs/Float64, transient-local: K = K̃·cos θ, rad/pulse."""
BENCH_TRUE_MOTION = '/sim/bench/true_motion'
"""Simulation only. sensor_msgs/JointState batch for the two-axis bench: name
['rate_table', 'position_table']; position[j·n + i], velocity[j·n + i] = true angle (rad)
and rate (rad/s) of joint j at sample i; effort[i] = stamp of sample i minus header.stamp (ns)."""
POSITION_TABLE_JOINT = 'position_table'
SIM_SCENARIO = '/sim/scenario'
"""Simulation only. std_msgs/String, transient-local: YAML description of a simulator's
parameters, seed and truth (each simulator publishes its part; recorders merge them)."""

FOG_OUTPUT = '/fog/output'
"""sensor_msgs/JointState, name ['fog']: position[0] = cumulative output count (integer in
float64); output rate (counts/s) = Δcount/Δt."""
FOG_INJECTION = '/fog/injection'
"""sensor_msgs/JointState, name ['fog_injection']: position[0] = the injected ramp expressed
as the output rate (counts/s) a perfectly linear loop would add; in force from header.stamp
until the next message; 0 = none."""
FOG_SCALE_FACTOR = '/gyro_calib/fog/scale_factor'
"""std_msgs/Float64, transient-local: turntable scale factor K, counts/rad."""
FOG_SELF_CAL_SCALE_FACTOR = '/gyro_calib/fog/self_cal_scale_factor'
"""std_msgs/Float64, transient-local: self-calibrated scale factor over the linear range,
counts/rad."""
FOG_JOINT = 'fog'
FOG_INJECTION_JOINT = 'fog_injection'

VIBRATION_TABLE_JOINT_STATES = '/vibration_table/joint_states'
"""sensor_msgs/JointState, name ['vibration_table']: position = table angle (rad), velocity
(rad/s), header.frame_id = the case axis the table axis is aligned with: 'z' or 'y'."""
VIBRATION_TABLE_JOINT = 'vibration_table'
DITHER_MISALIGNMENT = '/gyro_calib/dither/misalignment'
"""std_msgs/Float64, reliable, transient-local: the dither-axis misalignment a, rad."""

GYRO_TEMPERATURE = '/gyro/temperature'
"""sensor_msgs/Temperature: temperature (°C, as the message defines), variance (°C², 0 when
unknown); header.frame_id names the sensor: 'cavity_a', 'cavity_b' (their mean is H),
optionally 'shell'."""
TEMPERATURE_SENSORS = ('cavity_a', 'cavity_b', 'shell')
"""The sensor names (header.frame_id) of /gyro/temperature."""


def relative(topic: str) -> str:
    """A contract name relative to the node's namespace: '/gyro/pulses' → 'gyro/pulses'.

    Every node creates its topics with these names, so in the default namespace they resolve
    to the contract's absolute names above and under ``--ros-args -r __ns:=/bench2`` to
    '/bench2/gyro/pulses' (results and /diagnostics too): one namespace per bench.
    """
    return topic.lstrip('/')


def normalized_namespace(namespace: str) -> str:
    """'' for the root namespace ('' or '/'), else '/a/b' (one leading slash, none trailing).

    Raises:
        ValueError: a name ROS would refuse as a namespace (empty parts, characters other
            than letters, digits and '_', a part starting with a digit).
    """
    parts = namespace.strip('/').split('/')
    if parts == ['']:
        return ''
    for part in parts:
        if not part or not (part[0].isalpha() or part[0] == '_') or not all(
                c.isalnum() or c == '_' for c in part) or not part.isascii():
            raise ValueError(f'namespace {namespace!r} is not a ROS namespace: its parts must be '
                             "letters, digits and '_' (not starting with a digit), e.g. /bench2.")
    return '/' + '/'.join(parts)


def under(namespace: str, topic: str) -> str:
    """The absolute name of the contract ``topic`` in ``namespace`` ('' = the root)."""
    return normalized_namespace(namespace) + topic


def namespaces_holding(names: Iterable[str], contract: Iterable[str]) -> list[str]:
    """The namespaces in which a contract topic appears among ``names`` ('' = the root), sorted.

    '/bench2/gyro/pulses' with '/gyro/pulses' in the contract gives '/bench2'.
    """
    wanted = tuple(contract)
    found = set()
    for name in names:
        for topic in wanted:
            if name.endswith(topic) and (name == topic or name[:-len(topic)].startswith('/')):
                found.add(name[:-len(topic)])
    return sorted(found)
