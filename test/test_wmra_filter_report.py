"""wmra-report writes its plots and a markdown report with the numbers."""
from conftest import shared_data
from wmra_filter import report


def test_report_writes_plots_and_numbers(tmp_path):
    csv = shared_data("balzer_car", "2014-03-26-000-Data.csv")
    assert report.main(["--out", str(tmp_path), "--balzer", str(csv)]) == 0
    for png in ("rate_table.png", "road.png", "real_car.png", "real_car_residual_psd.png"):
        assert (tmp_path / png).stat().st_size > 10_000
    text = (tmp_path / "report.md").read_text()
    assert "| hard_soft | gz |" in text and "rise WMRA s" in text and "residual power at <= 5 Hz" in text
