"""The navigation graph, described once: which nodes run, with which parameters and remaps, for each input.

``launch/navigation.launch.py`` (full ROS 2 install), ``nav-demo`` (the process runner,
:mod:`nav_bringup.graph`) and the graph tests all start :func:`navigation_graph`'s nodes, with the
one params file (``config/navigation.yaml``) under these per-run overrides::

    simulation: scenario_player (emulator -> pty, GPS, /clock) -> bp3010_driver -> wmra_node -> ins_gps_kf_node
    recording:  bag_play -> wmra_node -> ins_gps_kf_node
    hardware:   bp3010_driver -> wmra_node -> ins_gps_kf_node
    always:     allan_node (stationary head), sensor_health_node (names sensor faults live; events on
                sensor_health/events), bag_record (everything)

A player starts once every node that reads what it plays has subscribed (bag_play: ``wait_for_readers``).

Per-scenario overrides live here too: a simulation sets the filter's datum to the scenario's, so
``map`` is the frame of ``truth/odometry`` under every entry point.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

SOURCES = ("simulation", "recording", "hardware")
PLAYER_SETTLE_S = 3.0
"""bag_play's wait after it counts its subscribers, s: a node that subscribed before the player started
counts the player's publisher up to ~2 s after the player counts it (DDS discovery, measured), and misses
what is played before (the recorder, which subscribes once it sees the player, does not)."""


@dataclass
class NodeSpec:
    """One node of the graph: package, executable, parameter overrides, remaps (from, to), the log line that
    says it is ready (the process runner waits for it) and extra command-line arguments."""

    executable: str
    overrides: dict = field(default_factory=dict)
    ready: str = "ready"
    args: tuple = ()
    package: str = ""
    remaps: tuple = ()


@dataclass
class GraphInputs:
    """What one run plays and where it writes (paths as given; the launch file passes its arguments)."""

    source: str                       # simulation | recording | hardware
    sensor_model: str                 # sensor-model YAML for the driver's noise, wmra_node and the filter
    sim_dir: str = ""                 # simulation: imu-sim output folder
    recording: str = ""               # recording: rosbag2 bag
    port: str = "/tmp/bp3010"         # the driver's serial port (simulation: the emulator's pty link)
    rate: float = 1.0                 # playback speed (simulation, recording)
    duration_s: float = 0.0           # simulation: stop after this much simulated time, s (0: all)
    bag_out: str = "navigation_bag"   # bag_record's output folder
    allan_dir: str = ""               # allan_node's out_dir ("": the params file's)
    use_sim_time: bool | None = None  # None: true when something is played (the players publish /clock)
    played_topics: tuple = ("imu/data_raw", "gps/fix")  # recording: the bag's topics to play
    gps_topic: str = "gps/fix"        # the filter's GNSS topic (its params file's gps_topic)
    wheel_topic: str = ""             # the filter's odometer topic when it is enabled ("": off)
    reconnect_period_s: float | None = None  # driver: faster reconnects to a pty (simulation), s

    def __post_init__(self):
        if self.source not in SOURCES:
            raise ValueError(f"graph source {self.source!r}: expected one of {SOURCES}")


PACKAGES = {"scenario_player": "nav_bringup", "bag_play": "imu_driver", "bp3010_driver": "imu_driver",
            "wmra_node": "wmra_filter", "ins_gps_kf_node": "ins_gps_kf", "allan_node": "imu_calib",
            "bag_record": "imu_driver", "sensor_health_node": "sensor_health"}


def navigation_graph(inp: GraphInputs) -> list[NodeSpec]:
    """The nodes of one run in start order: the driver first, the player last (it waits for the graph)."""
    played = inp.source != "hardware"
    sim = {"use_sim_time": played if inp.use_sim_time is None else bool(inp.use_sim_time)}
    model = {"sensor_model_path": str(inp.sensor_model)}
    kf = dict(sim, **model)
    if inp.source == "simulation":
        kf.update(scenario_datum(inp.sim_dir))
    allan = dict(sim, out_dir=str(inp.allan_dir)) if inp.allan_dir else dict(sim)
    specs = []
    if inp.source != "recording":
        driver = dict(sim, port=str(inp.port))
        if inp.reconnect_period_s is not None:
            driver["reconnect_period_s"] = float(inp.reconnect_period_s)
        specs.append(NodeSpec("bp3010_driver", driver))
    specs += [NodeSpec("wmra_node", dict(sim, **model)), NodeSpec("ins_gps_kf_node", kf),
              NodeSpec("allan_node", allan, ready="collecting")]
    specs += [NodeSpec("sensor_health_node", dict(sim, **model)),
              # the report replays the bag: it must hold all the filter received, so the recorder must be
              # subscribed before anything plays (its last subscription: the filter's output)
              NodeSpec("bag_record", dict(sim, output=str(inp.bag_out)), ready="recording /odometry/filtered")]
    if inp.source == "simulation":
        specs.append(NodeSpec("scenario_player", {
            "sim_dir": str(inp.sim_dir), "link": str(inp.port), "rate": float(inp.rate),
            "duration_s": float(inp.duration_s),
            # imu/data: only the recorder subscribes it
            "wait_for_subscribers": ["gps/fix", "imu/data_raw", "imu/data"]}))
    elif inp.source == "recording":
        topics = list(inp.played_topics)
        specs.append(NodeSpec("bag_play", {
            "bag": str(inp.recording), "rate": float(inp.rate), "topics": topics or [""],
            # played once every node reading a topic subscribes it (by name: the topics have 2 to 4 readers),
            # then a settle
            "wait_for_subscribers": 1, "wait_for_readers": recording_readers(inp, topics) or [""],
            "settle_s": PLAYER_SETTLE_S}))
    for spec in specs:
        spec.package = PACKAGES[spec.executable]
    return specs


def recording_readers(inp: GraphInputs, played) -> list:
    """bag_play's ``wait_for_readers`` (``topic=node,node``): the graph's nodes reading each played topic.

    The recorder subscribes to the raw IMU and the fixes once it sees the player (the report replays them
    from its bag); the filter's wheel-speed topic is read by the filter alone.
    """
    gps = inp.gps_topic.lstrip("/")
    readers = {"imu/data_raw": ["wmra_node", "allan_node", "sensor_health_node", "bag_record"],
               gps: ["ins_gps_kf_node", "bag_record"] + (["sensor_health_node"] if gps == "gps/fix" else [])}
    if inp.wheel_topic:
        readers.setdefault(inp.wheel_topic.lstrip("/"), []).insert(0, "ins_gps_kf_node")
    return [f"{t}={','.join(readers[t])}" for t in played if t in readers]


def scenario_datum(sim_dir) -> dict:
    """The filter's datum parameters (deg, deg, m) for a simulation: its truth frame's origin."""
    from nav_bringup.truth import sim_frame

    frame = sim_frame(sim_dir)
    return {"datum_lat_deg": float(frame.lat0_deg), "datum_lon_deg": float(frame.lon0_deg),
            "datum_h_m": float(frame.h0_m)}


def played_topics(recording, gps_topic: str = "gps/fix", wheel_topic: str | None = None) -> tuple:
    """The bag's topics the graph reads (raw IMU, the filter's GPS topic and, with its odometer on, its wheel-speed
    topic): a bag of another run holds the graph's own outputs too, which, played, would meet the live ones."""
    from nav_core import bagio

    read = {"imu/data_raw", bagio.norm_topic(gps_topic)} | ({bagio.norm_topic(wheel_topic)} if wheel_topic else set())
    return tuple(sorted(read & set(bagio.topics(Path(recording)))))
