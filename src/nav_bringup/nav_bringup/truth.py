"""Truth (or reference) track in the filter's ENU frame, interpolated at any stamp."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from nav_core import recording
from nav_core.earth import LocalFrame
from nav_core.units import DEG


@dataclass
class TruthTrack:
    """Truth positions (n, 3) m in ENU of ``frame`` at stamps ``t`` (s, with the bag epoch), attitude rad."""

    t: np.ndarray
    enu: np.ndarray
    rpy: np.ndarray
    velocity_n: np.ndarray | None
    frame: LocalFrame
    epoch_s: float

    @classmethod
    def from_csv(cls, truth_csv: Path, frame: LocalFrame, epoch_s: float = 0.0) -> TruthTrack:
        """Read a truth CSV and express it in ``frame``; CSV time + ``epoch_s`` gives the stamps."""
        traj = recording.read_trajectory_csv(truth_csv)
        enu = frame.to_enu(traj.lat / DEG, traj.lon / DEG, traj.h)
        return cls(traj.t + epoch_s, enu, np.column_stack([traj.roll, traj.pitch, traj.yaw]), traj.velocity_n,
                   frame, epoch_s)

    @classmethod
    def from_sim_dir(cls, sim_dir: Path) -> TruthTrack:
        """The truth of an ``imu-sim simulate`` run, in the ENU frame at its scenario datum."""
        info = yaml.safe_load((Path(sim_dir) / "sim_info.yaml").read_text())
        return cls.from_csv(Path(sim_dir) / "truth.csv", sim_frame(sim_dir), float(info.get("bag_epoch_s", 0.0)))

    def at(self, t_s) -> np.ndarray:
        """ENU positions (n, 3) at stamps ``t_s``."""
        return np.column_stack([np.interp(t_s, self.t, self.enu[:, i]) for i in range(3)])

    def horizontal_error(self, t_s: float, enu: np.ndarray) -> float:
        """Horizontal distance (m) of ``enu`` from the truth at ``t_s``."""
        return float(np.hypot(*(enu[:2] - self.at(np.array([t_s]))[0, :2])))


def sim_frame(sim_dir) -> LocalFrame:
    """The local frame of an ``imu-sim simulate`` run: its scenario's truth datum, read through
    :func:`imu_sim.scenario.load` (a datum the scenario leaves out, ``height_m`` say, is the simulator's default)."""
    from imu_sim import scenario

    info = yaml.safe_load((Path(sim_dir) / "sim_info.yaml").read_text())
    return scenario.build_trajectory(scenario.load(info["scenario"])).frame
