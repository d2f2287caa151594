from setuptools import find_packages, setup

PACKAGE = "sensor_health"

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
    description="Live IMU health: names a sensor fault (effect, channel, onset) while the vehicle drives.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "sensor_health_node = sensor_health.sensor_health_node:main",
            "sensor-health = sensor_health.cli:main",
        ],
    },
)
