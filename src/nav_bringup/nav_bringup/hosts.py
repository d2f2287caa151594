"""Two hosts on one machine: Linux network namespaces joined by a veth link, for ``nav-demo --hosts 2``.

The sensor host (namespace ``navs-<pid>``) runs the scenario player and the driver; the compute host
(``navc-<pid>``) runs WMRA, the filter, Allan and the recorder. Each namespace has its own loopback and one end
of a veth pair (10.231.0.1/24 sensor, 10.231.0.2/24 compute) and a multicast route on it, so DDS discovers
across the link by its ordinary multicast (``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET``), as between two machines
on one Ethernet segment. Nothing else is reachable from either namespace: no traffic leaves them.

``--cut-link AT_S:FOR_S`` takes the link down (``ip link set ... down`` on the sensor end: the compute end
loses its carrier) at AT_S of simulated time and brings it up FOR_S simulated seconds later (FOR_S / rate of
wall time: the link's outage is a wall-clock event, and the compute host sees no ``/clock`` through it).

Through a cut nothing is lost: the sensor data crossing the link is reliable and its publishers keep the last
:data:`STORE_S` of it (:func:`link_qos`, ROS 2 QoS overrides), the nodes run with a Fast DDS profile whose
participant lease outlasts that and whose writers' heartbeat is short (:data:`FASTDDS_PROFILE`), so DDS delivers
the cut's samples once the link is back and the filter runs through them in stamp order (docs/two_hosts.md).

Clocks: namespaces share the kernel's clock (a time namespace offsets only CLOCK_MONOTONIC and BOOTTIME, not
the CLOCK_REALTIME that ROS stamps with), so the two hosts cannot have clocks that differ. What the demo keeps
apart is what a deployment keeps apart: the sensor host stamps the samples (the driver, on the simulated
``/clock`` the player publishes there), the compute host only reads stamps, and the filter judges its input's
staleness on its own steady clock, which goes on while no ``/clock`` crosses the cut link.

Needs root (CAP_NET_ADMIN and CAP_SYS_ADMIN for ``ip netns``); :func:`check_permitted` says so in one line.
"""
from __future__ import annotations

import atexit
import ctypes
import json
import math
import os
import shutil
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

SENSOR, COMPUTE = "sensor", "compute"
SENSOR_NODES = ("scenario_player", "bag_play", "bp3010_driver")
SUBNET = "10.231.0"
CLONE_NEWNET = 0x40000000


STORE_S = 60.0
"""s of sensor data the sensor host keeps for a compute host it cannot reach (the link's longest bridged cut)."""
LINK_TOPICS = {  # node -> its endpoints of the sensor data crossing the link: (topic, side, messages per second)
    "bp3010_driver": [("/imu/data_raw", "publisher", 64.0)],
    "bag_play": [("/imu/data_raw", "publisher", 64.0), ("/gps/fix", "publisher", 1.0)],
    # imu/data_corrected does not cross the link but carries its burst: when the link returns wmra_node republishes
    # the cut's backlog at once; best effort, a busy recorder lost 772 of a cut's samples that the filter got (live
    # - offline 1.73 m, load 30). Reliable and kept, the recorder (which takes the QoS offered) gets every one
    "wmra_node": [("/imu/data_raw", "subscription", 64.0), ("/imu/data_corrected", "publisher", 64.0)],
    "scenario_player": [("/gps/fix", "publisher", 1.0)],
    # the filter reads that burst reliably too: best effort, it lost 110 of a cut's samples the bag has at load 4
    # (live - offline 2.35 m) and 5 in a CI run, though its queue holds 20000 (the burst overflows DDS's delivery)
    "ins_gps_kf_node": [("/gps/fix", "subscription", 1.0), ("/imu/data_corrected", "subscription", 64.0)],
    # best effort across the link, the health node would name each sample the link lost (a cut, a datagram at
    # start-up) a sensor dropout; reliable, it sees what the sensor sent, as the bag does
    "sensor_health_node": [("/imu/data_raw", "subscription", 64.0), ("/gps/fix", "subscription", 1.0)]}


def link_qos(specs: list, store_s: float = STORE_S, imu_rate_hz: float = 64.0) -> list:
    """``specs`` with reliable QoS on the sensor data crossing the link: the publishers keep the last ``store_s``
    of messages (KEEP_LAST depth), which DDS delivers once the link is back, so the compute host's filter runs
    through a cut on every sample in stamp order instead of bridging a gap it never saw (docs/two_hosts.md).
    nav-demo gives them to a one-host run too, where the same QoS keeps a busy recorder from losing samples."""
    import dataclasses

    out = []
    for spec in specs:
        extra = {}
        for topic, side, rate_hz in LINK_TOPICS.get(spec.executable, []):
            rate_hz = imu_rate_hz if "imu" in topic else rate_hz
            key = f"qos_overrides.{topic}.{side}"
            extra[f"{key}.reliability"] = "reliable"
            if side == "publisher":
                extra.update({f"{key}.history": "keep_last", f"{key}.depth": int(math.ceil(store_s * rate_hz)) + 10})
        out.append(dataclasses.replace(spec, overrides={**spec.overrides, **extra}) if extra else spec)
    return out


DISCOVERY_ENV = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
"""Discovery across the link: the ROS 2 default (multicast on the subnet), never the tests' LOCALHOST."""
NOT_ACROSS = ("ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS")
FASTDDS_PROFILE = "config/fastdds_two_hosts.xml"
"""Participant lease 60 s (the reliable sensor data's history, :data:`STORE_S`; Fast DDS's default 20 s would
drop the other host in a longer cut and its readers' gap with it) and the reliable writers' heartbeat 0.1 s (the
default 3 s held the cut's samples up to 3 s after the link returned: 2.8-3.0 simulated s at 4x, measured)."""


class HostsError(OSError):
    """Network namespaces cannot be made here (not root, no ``ip``); the message is one line (exit 2)."""


def check_permitted() -> None:
    """HostsError unless this process may create network namespaces (root with ``ip`` from iproute2)."""
    if os.geteuid() != 0:
        raise HostsError("--hosts 2 runs the graph in two Linux network namespaces, which needs root "
                         "(CAP_NET_ADMIN); run it as root, or without --hosts")
    if shutil.which("ip") is None:
        raise HostsError("--hosts 2 needs the 'ip' command (iproute2) to make network namespaces; install it")


def parse_cut(text: str) -> tuple[float, float]:
    """``AT_S:FOR_S`` (simulated seconds from the start of the drive) -> (at_s, for_s); ValueError if malformed."""
    try:
        at_s, for_s = (float(v) for v in text.split(":"))
    except ValueError:
        raise ValueError(f"--cut-link {text!r}: expected AT_S:FOR_S in seconds, e.g. 60:10") from None
    if not (at_s >= 0 and for_s > 0) or not all(map(lambda v: v < 1e7, (at_s, for_s))):
        raise ValueError(f"--cut-link {text!r}: AT_S must be >= 0 and FOR_S > 0 (seconds)")
    return at_s, for_s


def _ip(*args: str) -> None:
    """Run one ``ip`` command; HostsError with its message when it fails."""
    proc = subprocess.run(["ip", *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise HostsError(f"ip {' '.join(args)}: {proc.stderr.strip() or f'exit {proc.returncode}'}")


@dataclass
class TwoHosts:
    """The two namespaces and their link; a context manager that removes them on exit."""

    tag: str = field(default_factory=lambda: str(os.getpid()))
    names: dict = field(init=False)
    links: dict = field(init=False)

    def __post_init__(self):
        self.names = {SENSOR: f"navs-{self.tag}", COMPUTE: f"navc-{self.tag}"}
        self.links = {SENSOR: f"nvs{self.tag}"[:15], COMPUTE: f"nvc{self.tag}"[:15]}
        self.address = {SENSOR: f"{SUBNET}.1", COMPUTE: f"{SUBNET}.2"}

    def __enter__(self) -> "TwoHosts":
        check_permitted()
        try:
            for host in (SENSOR, COMPUTE):
                _ip("netns", "add", self.names[host])
            _ip("link", "add", self.links[SENSOR], "type", "veth", "peer", "name", self.links[COMPUTE])
            for host in (SENSOR, COMPUTE):
                ns, dev = self.names[host], self.links[host]
                _ip("link", "set", dev, "netns", ns)
                _ip("-n", ns, "addr", "add", f"{self.address[host]}/24", "dev", dev)
                _ip("-n", ns, "link", "set", "lo", "up")
                _ip("-n", ns, "link", "set", dev, "up")
            self._multicast_routes()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _multicast_routes(self) -> None:
        """DDS discovery multicast (239.255.0.1) goes out on the link; a link taken down loses its routes."""
        for host in (SENSOR, COMPUTE):
            _ip("-n", self.names[host], "route", "replace", "224.0.0.0/4", "dev", self.links[host])

    def close(self) -> None:
        """Remove both namespaces (the veth pair goes with them); quiet about what does not exist."""
        for host in (SENSOR, COMPUTE):
            subprocess.run(["ip", "netns", "del", self.names[host]], capture_output=True)

    def host_of(self, executable: str) -> str:
        """Which host runs a node: the player and the driver are the sensor host's, the rest the compute host's."""
        return SENSOR if executable in SENSOR_NODES else COMPUTE

    def prefix(self, executable: str) -> tuple:
        """The command prefix that starts a node on its host."""
        return ("ip", "netns", "exec", self.names[self.host_of(executable)])

    def enter(self, host: str = COMPUTE) -> None:
        """Move this thread (and the threads and processes it starts later) into ``host``'s namespace: the demo's
        own probe watches the graph from the compute host, as an operator's laptop on that side would."""
        libc = ctypes.CDLL(None, use_errno=True)
        fd = os.open(f"/run/netns/{self.names[host]}", os.O_RDONLY)
        try:
            if libc.setns(fd, CLONE_NEWNET) != 0:
                err = ctypes.get_errno()
                raise HostsError(f"setns into {self.names[host]}: {os.strerror(err)}")
        finally:
            os.close(fd)

    def link_up(self, up: bool) -> None:
        """Bring the link up or take it down (the sensor end; the compute end loses its carrier)."""
        _ip("-n", self.names[SENSOR], "link", "set", self.links[SENSOR], "up" if up else "down")
        if up:
            self._multicast_routes()


class LinkCutter:
    """Takes the link down at ``at_s`` of simulated time and up ``for_s`` simulated seconds later.

    :meth:`on_clock` is called with the simulated time (s from the start of the drive) of each ``/clock`` the
    compute host receives; the cut and the restore run on a thread of their own. ``cuts`` records each cut with
    its simulated start, the wall time it lasted and ``epoch_s`` (the ``/clock`` at the drive's start, s).
    """

    def __init__(self, hosts: TwoHosts, at_s: float, for_s: float, rate: float):
        self.hosts, self.at_s, self.for_s, self.rate = hosts, at_s, for_s, rate
        self.cuts: list[dict] = []
        self.epoch_s = 0.0  # the /clock time of the drive's start, s
        self._started = False
        self._thread: threading.Thread | None = None
        self.seen_s: list[float] = []  # the first and the newest simulated time the compute host's /clock showed

    def on_clock(self, sim_t: float, clock_s: float) -> None:
        """Start the cut once the simulated time ``sim_t`` (s from the start of the drive; ``clock_s`` as the
        ``/clock`` sent it) reaches ``at_s``."""
        self.epoch_s = clock_s - sim_t
        self.seen_s[1:] = [sim_t]
        if not self._started and sim_t >= self.at_s:
            self._started = True
            self._thread = threading.Thread(target=self._cut, args=(sim_t,), name="link_cut", daemon=True)
            self._thread.start()

    def _cut(self, sim_t: float) -> None:
        start = time.monotonic()
        self.hosts.link_up(False)
        print(f"[demo] link cut at t = {sim_t:.1f} s for {self.for_s:g} s", flush=True)
        time.sleep(self.for_s / self.rate)
        self.hosts.link_up(True)
        wall = time.monotonic() - start
        self.cuts.append({"at_s": round(sim_t, 3), "for_s": self.for_s, "wall_s": round(wall, 3),
                          "restored_at_s": round(sim_t + wall * self.rate, 3), "epoch_s": self.epoch_s})
        print(f"[demo] link restored at t = {sim_t + wall * self.rate:.1f} s", flush=True)

    def finish(self, path: Path) -> list:
        """Wait for a cut in progress to end (the link comes back before the graph stops); write ``path``."""
        if self._thread is not None:
            self._thread.join()
        if self.seen_s:  # the cut is scheduled on this /clock: one first seen late is a cut made late or never
            print(f"[demo] the compute host's /clock showed the drive from t = {self.seen_s[0]:.1f} s "
                  f"to {self.seen_s[-1]:.1f} s", flush=True)
        path.write_text(json.dumps(self.cuts, indent=1) + "\n")
        return self.cuts

    def missed(self) -> str | None:
        """What did not happen when no cut was made (None after a cut): the compute host's /clock never showed AT_S."""
        if self.cuts:
            return None
        seen = (f"from t = {self.seen_s[0]:.1f} to {self.seen_s[-1]:.1f} s" if self.seen_s else "at no time")
        return (f"the link cut at t = {self.at_s:g} s did not happen: the compute host's /clock showed the drive "
                f"{seen} (link_cuts.json is empty)")


def plan(hosts: int, cut_link: str | None, duration_s: float = 0.0):
    """Check ``--hosts``/``--cut-link`` before any work: (at_s, for_s) or None; HostsError when namespaces cannot
    be made here, ValueError for a malformed cut, a cut without two hosts or one not over before the drive's
    ``duration_s`` (0: the whole scenario, not known here) ends."""
    if hosts == 1:
        if cut_link is not None:
            raise ValueError("--cut-link needs --hosts 2 (there is no link on one host)")
        return None
    check_permitted()
    cut = parse_cut(cut_link) if cut_link is not None else None
    if cut and 0 < duration_s <= sum(cut):
        raise ValueError(f"--cut-link {cut_link}: the link would be down at the end of the drive (--duration "
                         f"{duration_s:g}); the cut must end before it, or nothing shows the recovery")
    return cut


def discovery_env(env: dict) -> dict:
    """``env`` for nodes on two hosts: SUBNET discovery, no localhost-only or static-peer settings, and the Fast DDS
    profile of a link that goes down (:data:`FASTDDS_PROFILE`) unless the caller names a profiles file."""
    from nav_core.workspace import workspace_root

    env = {k: v for k, v in env.items() if k not in NOT_ACROSS}
    env.update(DISCOVERY_ENV)
    profile = workspace_root() / FASTDDS_PROFILE
    if profile.is_file():
        env.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile))
    return env


class HostRun:
    """One run on two hosts: the namespaces (removed at the latest when the process exits), this thread on the
    compute host, the link cutter; :meth:`finish` writes the two-host part of the report."""

    def __init__(self, cut: tuple | None, rate: float):
        self.hosts = TwoHosts().__enter__()
        atexit.register(self.hosts.close)
        self.hosts.enter(COMPUTE)
        self.cutter = LinkCutter(self.hosts, *cut, rate) if cut else None
        self.prefix = self.hosts.prefix
        print(f"[demo] two hosts joined by a veth link: sensor {self.hosts.names[SENSOR]} "
              f"({self.hosts.address[SENSOR]}: player, driver), compute {self.hosts.names[COMPUTE]} "
              f"({self.hosts.address[COMPUTE]}: the other nodes)", flush=True)

    def on_clock(self, sim_t: float, clock_s: float) -> None:
        """The demo's /clock callback: the link cut is scheduled on it."""
        if self.cutter is not None:
            self.cutter.on_clock(sim_t, clock_s)

    def finish(self, run_dir: Path, sim_dir: Path | None = None) -> str:
        """Wait for a cut in progress, remove the namespaces, add the link figures to the report; a summary line."""
        from nav_bringup.link_report import add_to_report

        cuts = self.cutter.finish(Path(run_dir) / "link_cuts.json") if self.cutter else []
        self.hosts.close()
        figures = add_to_report(run_dir, cuts, self.cutter.epoch_s if self.cutter else 0.0, sim_dir)
        return "two hosts: " + ", ".join(f"{k} {v}" for k, v in figures.items())
