"""Shared test fixtures: repository paths, real-data location, an isolated ROS 2 domain per test."""
import fcntl
import itertools
import os
import re
import tempfile

# Before anything imports numpy: the tests do small dense algebra (15x15 filters, short FFTs), where BLAS threads
# only cost time, and two test processes share the two cores.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
from pathlib import Path

import pytest
from hypothesis import settings

# CI (CI=true) runs every property test on the same examples each time: derandomised, no example database, so a
# rare find cannot fail one run and pass the next; a case found locally goes into the test as an @example.
settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
if os.environ.get("CI", "").lower() == "true":
    settings.load_profile("ci")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = (REPO / ".." / "shared" / "data").resolve()
# Ids 100..199 are the tests', 0..99 are left for people running nodes by hand. A random start per pytest
# process spreads the ids; a lock file per id makes them exclusive, because two xdist workers (or two runs on one
# machine) counting from random starts did meet on one domain and each test saw the other's messages.
_DOMAIN_IDS = itertools.count(start=int.from_bytes(os.urandom(2), "little"))
_DOMAIN_LOCKS = Path(tempfile.gettempdir()) / "nav_stack_ros_domains"


def _claim_domain():
    """A ROS_DOMAIN_ID in 100..199 that no other test on this machine holds: ``(id, open lock file)``."""
    _DOMAIN_LOCKS.mkdir(exist_ok=True)
    for _ in range(1000):
        domain = next(_DOMAIN_IDS) % 100 + 100
        lock = open(_DOMAIN_LOCKS / f"{domain}.lock", "w")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return domain, lock
        except BlockingIOError:
            lock.close()
    raise RuntimeError(f"every ROS domain 100..199 is held by another test (locks in {_DOMAIN_LOCKS})")


def shared_data(*parts) -> Path:
    """Path into ../shared/data; skips with a clear message naming where it looked if absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"real data not found: looked for {path}")
    return path


def console_scripts() -> dict:
    """Every console script the workspace declares: name -> ``module:function`` (src/*/setup.py's console_scripts)."""
    scripts = {}
    for setup in sorted(REPO.glob("src/*/setup.py")):
        block = re.search(r'"console_scripts"\s*:\s*\[(.*?)\]', setup.read_text(), flags=re.S)
        for name, target in re.findall(r'"([\w.-]+)\s*=\s*([\w.]+:\w+)"', block.group(1) if block else ""):
            scripts[name] = target
    return scripts


def one_error_line(capsys, *words) -> str:
    """The one stderr line with "error" a CLI printed (no traceback), checked to hold every one of ``words``."""
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.fixture
def ros_env(monkeypatch):
    """Environment for node processes: a test-private ROS_DOMAIN_ID, localhost-only discovery."""
    number, lock = _claim_domain()
    domain = str(number)
    env = dict(os.environ)
    env.update({"ROS_DOMAIN_ID": domain, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                "PYTHONUNBUFFERED": "1", "RCUTILS_LOGGING_BUFFERED_STREAM": "0"})
    monkeypatch.setenv("ROS_DOMAIN_ID", domain)
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    yield env
    lock.close()  # releases the domain for the next test


@pytest.fixture
def rclpy_context(ros_env):
    """rclpy initialised in the test process on the test's own domain (for probe nodes); yields the node env."""
    import rclpy  # here, not at the top: the unit tier imports conftest without needing ROS

    rclpy.init()
    yield ros_env
    rclpy.try_shutdown()


@pytest.fixture(scope="session")
def outage_drive():
    """The simulated paper drive's first 420 s (seed 3, BP3010 grade) with 60-s GNSS outages every 3 minutes:
    ``(sim, windows, gnss without the outages' fixes)``, shared by the NHC, odometer and smoother tests."""
    from imu_sim.models import bp3010_grade_model
    from imu_sim.scenario import load
    from imu_sim.simulate import simulate
    from nav_eval.metrics import drop_fixes, outage_windows

    sc = load(REPO / "config" / "scenarios" / "paper_drive.yaml")
    sc.duration_s = 420.0
    sim = simulate(sc, model=bp3010_grade_model(), seed=3, with_bytes=False)
    windows = outage_windows(60.0, sim.truth.t[-1], 180.0, 60.0, 120.0)
    return sim, windows, drop_fixes(sim.gnss, windows)


def wheel_motion():
    """The motion of :func:`wheel_drive` (ins_gps_kf.synthetic.Motion): 20 s at rest, 5 m/s round a bend."""
    from ins_gps_kf import synthetic as syn

    return syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=20.0)


@pytest.fixture(scope="session")
def wheel_drive():
    """A 55-s synthetic drive at 32 Hz (20 s at rest, then 5 m/s round a bend) with 1-Hz fixes and a 10-Hz wheel
    odometer (0.5 % scale error, 0.05 m/s noise) carrying one of each bad input: a NaN speed, a repeated stamp, a
    stamp gone back, and a stuck wheel (four zeros at speed): ``(imu, gnss, wheel)``, for the odometer's node, bag
    and intake tests."""
    import numpy as np

    from ins_gps_kf import synthetic as syn
    from nav_core.recording import WheelSpeedRecording

    motion = wheel_motion()
    rng = np.random.default_rng(9)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, 32.0), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, 32.0, 1.0, rng)
    t = np.round(np.arange(0.05, imu.t[-1], 0.1), 6)
    speed = 1.005 * motion.speed_yaw(t)[0] + rng.normal(0.0, 0.05, len(t))
    speed[300] = np.nan
    t[350] = t[349]  # a repeated stamp
    t[400] = t[398]  # a stamp gone back
    speed[450:462] = 0.0  # a stuck wheel at 5 m/s for 1.2 s
    return imu, gnss, WheelSpeedRecording(t, speed, "synthetic")
