from setuptools import find_packages, setup

PACKAGE = "imu_sim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={"imu_sim.diagnose": ["calibration.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Trajectory and MEMS sensor simulator; sim-versus-real diagnosis.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "imu-sim = imu_sim.cli:main",
        ],
    },
)
