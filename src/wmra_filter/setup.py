from setuptools import find_packages, setup

PACKAGE = "wmra_filter"

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
    description="Streaming db8 wavelet multi-resolution denoiser for IMU data.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "wmra_node = wmra_filter.wmra_node:main",
            "wmra-report = wmra_filter.report:main",
        ],
    },
)
