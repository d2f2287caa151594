from setuptools import find_packages, setup

PACKAGE = "nav_eval"

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
    description="Evaluations of the INS/GPS filter: simulated paper drive, real recordings, the paper's claims.",
    license="Apache-2.0",
    entry_points={
        # `ins-gps-kf evaluate`: a subcommand added to ins_gps_kf's CLI, which does not import this package
        "ins_gps_kf.cli": ["evaluate = nav_eval.cli:add_parser"],
        "console_scripts": ["nav-eval = nav_eval.cli:main"],
    },
)
