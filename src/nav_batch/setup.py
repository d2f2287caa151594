from setuptools import find_packages, setup

PACKAGE = "nav_batch"

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
    description="Fleet batches: imu-calib allan, imu-sim diagnose and ins-gps-kf replay over many recordings on Dask.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "nav-batch = nav_batch.cli:main",
        ],
    },
)
