"""ament_python / pip package definition of gyro_calib."""

import importlib.metadata
import os
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'gyro_calib'
SUPPORTED_ROS = ('jazzy', 'kilted')  # gyro_calib/nodes/ros_distribution.py says the same
RCLPY_MINIMUM = (7, 1)  # Jazzy's rclpy: rclpy.experimental.events_executor, rclpy.event_handler


def check_ros_distribution() -> None:
    """Refuse, in one line, to build for a ROS 2 distribution gyro_calib does not run on.

    A sourced ROS installation names itself in ROS_DISTRO (colcon, rosdep); the PyPI wheels
    carry rclpy's version in their metadata. Neither found (an isolated pip build): no check
    here, and the nodes check rclpy when they start.
    """
    distro = os.environ.get('ROS_DISTRO', '').strip().lower()
    if distro and distro not in SUPPORTED_ROS:
        raise SystemExit(f'gyro_calib: ROS 2 {distro} is not supported; it runs on '
                         f'{" and ".join(SUPPORTED_ROS)} (rclpy >= 7.1). Source one of those.')
    try:
        text = importlib.metadata.version('ros-rclpy')
    except importlib.metadata.PackageNotFoundError:
        return
    version = tuple(int(x) for x in text.split('.')[:2] if x.isdigit())
    if version < RCLPY_MINIMUM:
        raise SystemExit(f'gyro_calib: rclpy {text} is older than Jazzy\'s 7.1; it runs on '
                         f'{" and ".join(SUPPORTED_ROS)}.')


check_ros_distribution()

setup(
    name=PACKAGE,
    version='0.2.0',
    packages=find_packages(include=['gyro_calib', 'gyro_calib.*', 'sim_nodes', 'sim_nodes.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', ['config/calibration.yaml']),
        ('share/' + PACKAGE + '/docs', ['docs/methods.md']),
        ('share/' + PACKAGE + '/docs/methods', sorted(glob('docs/methods/*.md'))),
    ],
    package_data={PACKAGE: ['py.typed', 'schema/*.json', 'report/certificate.html.j2']},
    python_requires='>=3.11',
    install_requires=['numpy', 'scipy', 'PyYAML', 'rosbags', 'mcap', 'zstandard', 'tqdm',
                      'PyWavelets', 'statsmodels', 'matplotlib', 'gtc', 'dask[distributed]',
                      'jinja2', 'weasyprint', 'pyarrow'],
    zip_safe=True,
    maintainer='gyro_calib developers',
    maintainer_email='gyro-calib@example.com',
    description='Online calibration of optical gyroscopes: rate-biased RLG, FOG scale factor, '
                'dither-axis misalignment, temperature bias, noise characterisation.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'calibration_node = gyro_calib.nodes.calibration_node:main',
            'rate_table_sim = sim_nodes.rate_table_node:main',
            'rlg_sim = sim_nodes.rbrlg.rlg_node:main',
            'bench_demo = gyro_calib.nodes.bench_demo:main',
            'imu_corrector = gyro_calib.nodes.imu_corrector_node:main',
            'thermal_bias_node = gyro_calib.nodes.thermal_bias_node:main',
            'gyro-calib = gyro_calib.cli:console_main',
            'bag_recorder = gyro_calib.nodes.bag_recorder:main',
            'bag_player = gyro_calib.nodes.bag_player:main',
            'fog_calibration_node = gyro_calib.nodes.fog_calibration_node:main',
            'fog_sim = sim_nodes.fog.fog_node:main',
            'dither_calibration_node = gyro_calib.nodes.dither_calibration_node:main',
            'vibration_table_sim = sim_nodes.dither.vibration_table_node:main',
            'thermal_calibration_node = gyro_calib.nodes.thermal_calibration_node:main',
            'thermal_chamber_sim = sim_nodes.thermal.chamber_node:main',
            'noise_node = gyro_calib.nodes.noise_node:main',
            'triad_sim = sim_nodes.triad.triad_node:main',
            'triad_calibration_node = gyro_calib.nodes.triad_calibration_node:main',
            'multiposition_calibration_node = '
            'gyro_calib.nodes.multiposition_calibration_node:main',
            'imu_multiposition_sim = sim_nodes.multiposition.imu_node:main',
        ],
    },
)
