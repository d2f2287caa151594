from setuptools import find_packages, setup

PACKAGE = "imu_driver"

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
    description="MICRO-ISU BP3010 codec, serial driver node, emulator, rosbag2 play and record nodes.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "bp3010_driver = imu_driver.bp3010_driver_node:main",
            "bp3010_emulator = imu_driver.bp3010_emulator:main",
            "bag_play = imu_driver.bag_play_node:main",
            "bag_record = imu_driver.bag_record_node:main"
        ],
    },
)
