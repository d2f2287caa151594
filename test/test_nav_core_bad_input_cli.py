"""A misspelt option on any CLI is a usage error (exit 2) naming the option meant, in the subcommand given."""
import pytest

from imu_driver import bp3010_emulator
from imu_sim import cli as sim_cli
from ins_gps_kf import replay as kf_cli
from nav_bringup import convert, demo
from wmra_filter import report


@pytest.mark.parametrize("main, argv, wrong, right", [
    (kf_cli.main, ["replay", "--recording", "r.csv", "--model", "default", "--out", "o.csv", "--no-plt"],
     "--no-plt", "--no-plot"),
    (sim_cli.main, ["simulate", "--scenario", "s.yaml", "--out", "o", "--rate-hzz", "5"], "--rate-hzz", "--rate-hz"),
    (convert.main, ["balzer", "--out", "o", "--froce"], "--froce", "--force"),
    (report.main, ["--out", "o", "--seeed", "3"], "--seeed", "--seed"),
    (demo.main, ["--out", "o", "--durations", "5"], "--durations", "--duration"),
    (bp3010_emulator.main, ["--sped", "3"], "--sped", "--speed"),
])
def test_a_misspelt_option_names_the_one_meant(tmp_path, monkeypatch, capsys, main, argv, wrong, right):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main(argv)  # was: argparse's "unrecognized arguments" alone
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and f"{wrong!r}: did you mean {right!r}?" in err, err
    assert not (tmp_path / "o").exists()
