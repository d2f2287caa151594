"""Write a case as the files a user hands the diagnosis (CSV and YAML), and its answer key apart."""
import json
from pathlib import Path

import numpy as np
import yaml


def _csv(path: Path, header, rows, fmt):
    np.savetxt(path, rows, delimiter=",", header=",".join(header), comments="", fmt=fmt)


def write_case(case, folder) -> Path:
    """Write ``case`` into ``folder``: imu.csv, scenario.yaml, model.yaml[, truth.csv, gnss.csv], answer.json."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _csv(folder / "imu.csv", case.imu_header, case.imu, ["%.6f"] + ["%.12g"] * 6 + ["%.3f"])
    if case.truth_rows is not None:
        _csv(folder / "truth.csv", ["t", "lat_deg", "lon_deg", "h_m", "roll_deg", "pitch_deg", "yaw_deg"],
             case.truth_rows, ["%.3f", "%.11f", "%.11f", "%.5f", "%.7f", "%.7f", "%.7f"])
    if case.gnss_rows is not None:
        _csv(folder / "gnss.csv", ["t", "lat_deg", "lon_deg", "h_m", "std_e", "std_n", "std_u"],
             case.gnss_rows, ["%.3f", "%.10f", "%.10f", "%.4f", "%.3f", "%.3f", "%.3f"])
    (folder / "scenario.yaml").write_text(yaml.safe_dump(case.scenario, sort_keys=False, width=120))
    (folder / "model.yaml").write_text(yaml.safe_dump(case.model, sort_keys=False, width=120))
    answer = dict(case.answer, meta=case.meta, files=sorted(p.name for p in folder.iterdir()))
    (folder / "answer.json").write_text(json.dumps(answer, indent=1, default=float))
    return folder
