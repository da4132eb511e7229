"""ament_python / pip package definition of gyro_calib."""

from setuptools import find_packages, setup

PACKAGE = 'gyro_calib'

setup(
    name=PACKAGE,
    version='0.2.0',
    packages=find_packages(include=['gyro_calib', 'gyro_calib.*', 'sim_nodes', 'sim_nodes.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', ['config/calibration.yaml']),
        ('share/' + PACKAGE + '/docs', ['docs/methods.md']),
    ],
    package_data={PACKAGE: ['py.typed', 'schema/*.json', 'report/certificate.html.j2']},
    python_requires='>=3.10',
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
        ],
    },
)
