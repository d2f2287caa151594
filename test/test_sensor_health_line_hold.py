"""A vibration line that lasts keeps its channel WARN for as long as it lasts (it does not join the reference
spectrum), and the channel returns to OK with a 'cleared' message within seconds of the line going away."""
import json

import numpy as np

from sensor_health.events import Event, cleared_event
from sensor_health.status import statuses
from test_sensor_health_core import RATE, _drive, _model, _thresholds
from sensor_health.monitor import HealthConfig, HealthMonitor


def test_a_lasting_line_stays_warn_for_the_whole_fault_and_clears_within_seconds_after_it():
    t, x = _drive(11, 200.0)
    on = (t >= 100.0) & (t < 170.0)
    x[on, 0] += 3 * 0.012 * np.sin(2 * np.pi * 11.3 * t[on])  # 3 x the per-sample sd, for 70 s
    mon = HealthMonitor(_model(), HealthConfig(mc_windows=4000), thresholds=_thresholds())
    events, level = [], {}
    for a in range(0, len(t), int(RATE)):  # one second at a time, the status read after each
        events += mon.push(t[a:a + int(RATE)], x[a:a + int(RATE), :3], x[a:a + int(RATE), 3:])
        level[round(t[min(a + int(RATE), len(t)) - 1])] = mon.channel_status(t[min(a + int(RATE), len(t)) - 1])["gx"][0]
    assert [(e.effect, e.channels) for e in events] == [("vibration", ["gx"])]
    named = events[0].t_s
    assert 100.0 < named <= 105.0
    assert all(level[s] == "WARN" for s in level if named < s < 170), level
    cleared = [s for s in level if s >= 170 and level[s] == "OK"]
    assert cleared and min(cleared) <= 170 + 6, level
    assert all(level[s] == "OK" for s in level if s >= min(cleared))
    (note,) = mon.cleared
    assert note["channels"] == ["gx"] and 170.0 <= note["t_s"] <= 176.0
    st = statuses(mon, t[-1], {})["gx"]
    assert st.level == "OK" and "cleared" in st.message and st.cleared_s == note["t_s"]
    back = Event.from_dict(json.loads(cleared_event(note).to_json()))  # as the node publishes it
    assert back.cleared and (back.effect, back.channels, back.t_s) == ("vibration", ["gx"], note["t_s"])
    assert back.statistic["named_s"] == note["since_s"] and not events[0].cleared
