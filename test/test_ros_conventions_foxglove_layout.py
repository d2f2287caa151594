"""The Foxglove layout for the demo's bag shows only what the bag holds: recorded topics, published frames."""
import json
import re
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
LAYOUT = json.loads((REPO / "config" / "foxglove" / "demo_layout.json").read_text())
PARAMS = yaml.safe_load((REPO / "config" / "navigation.yaml").read_text())


def _panel_ids(node) -> set:
    if isinstance(node, str):
        return {node}
    return _panel_ids(node["first"]) | _panel_ids(node["second"])


def _script():
    (node,) = LAYOUT["userNodes"].values()
    source = node["sourceCode"]
    inputs = json.loads(re.search(r"export const inputs = (\[.*?\]);", source).group(1))
    output = re.search(r'export const output = "([^"]+)";', source).group(1)
    return inputs, output


def _topics_used() -> set:
    used = set()
    for panel_id, cfg in LAYOUT["configById"].items():
        used |= set(cfg.get("topics", {}))
        used |= {cfg["topicToRender"]} if "topicToRender" in cfg else set()
        paths = cfg.get("paths", []) + ([cfg["xAxisPath"]] if "xAxisPath" in cfg else [])
        used |= {re.match(r"(/[\w/]+?)(?=\.|$)", p["value"]).group(1) for p in paths}
    return used


def test_every_panel_in_the_layout_tree_is_configured_and_every_configured_panel_is_shown():
    assert _panel_ids(LAYOUT["layout"]) == set(LAYOUT["configById"])


def test_the_layout_reads_only_topics_the_demo_bag_records_and_the_script_output():
    recorded = {"/" + t.lstrip("/") for t in PARAMS["bag_record"]["ros__parameters"]["topics"]}
    inputs, output = _script()
    assert set(inputs) <= recorded
    assert output.startswith("/studio_script/")
    assert _topics_used() <= recorded | {output}, _topics_used() - recorded - {output}
    assert {"/tf", "/tf_static", "/odometry/filtered", "/truth/odometry", "/diagnostics"} <= _topics_used()


def test_the_3d_panel_follows_and_shows_the_frames_the_fusion_node_publishes():
    kf = PARAMS["ins_gps_kf_node"]["ros__parameters"]
    published = {kf["frame_id"], kf["odom_frame_id"], kf["child_frame_id"], kf["imu_frame_id"], kf["gps_frame_id"]}
    panel = LAYOUT["configById"]["3D!nav"]
    assert panel["followTf"] == kf["child_frame_id"]
    assert {k.removeprefix("frame:") for k in panel["transforms"]} == published
    assert panel["layers"]["grid"]["frameId"] == kf["frame_id"]
