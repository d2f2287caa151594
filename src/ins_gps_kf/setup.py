from setuptools import find_packages, setup

PACKAGE = "ins_gps_kf"

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
    description="Strapdown INS and loosely coupled INS/GPS error-state Kalman filter.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "ins_gps_kf_node = ins_gps_kf.ins_gps_kf_node:main",
            "ins-gps-kf = ins_gps_kf.replay:main",
        ],
    },
)
