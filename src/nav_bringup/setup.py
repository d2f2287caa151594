from setuptools import find_packages, setup

PACKAGE = "nav_bringup"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/launch", ["launch/navigation.launch.py"]),
        # config/ is a link to the workspace's top-level config/: one params file for runner and launch.
        ("share/" + PACKAGE + "/config", ["config/navigation.yaml"]),
        ("share/" + PACKAGE + "/config/sensor_models", ["config/sensor_models/bp3010.yaml"]),
        ("share/" + PACKAGE + "/config/scenarios", ["config/scenarios/paper_drive.yaml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Launch files, process runner, demo and report for the whole navigation graph.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "nav-demo = nav_bringup.demo:main",
            "scenario_player = nav_bringup.scenario_player_node:main",
            "nav-convert = nav_bringup.convert:main"
        ],
    },
)
