from setuptools import find_packages, setup

PACKAGE = "imu_calib"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Deterministic IMU calibration, Allan variance noise model, sensor-model YAML.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "imu-calib = imu_calib.cli:main",
            "allan_node = imu_calib.allan_node:main",
        ],
    },
)
