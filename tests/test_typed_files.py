"""Issue 20 (types, not strings; one reader per concern): the JSON files surfhap reads share one
reader and one located error line; batch jobs are typed objects (no CLI text rebuilt below cli/)."""

import json
import sys

import numpy as np
import pytest

from surfhap.batch.jobs import FitImuJob, fit_imu_to_file
from surfhap.cli import main
from surfhap.cli._scan import scan_trajectory, trajectory_from_options
from surfhap.errors import ConfigError, InputError
from surfhap.exchange.display_file import load_display, read_display_json
from surfhap.exchange.material_json import read_material_json
from surfhap.exchange.shape_files import read_calibration
from surfhap.lab.schema import load_design
from surfhap.models.trajectory import constant_scan, strokes

READERS = [read_display_json, read_material_json, read_calibration, load_design]


@pytest.mark.parametrize("reader", READERS, ids=lambda r: r.__name__)
@pytest.mark.parametrize("text, message", [("{ oops", "malformed JSON at line 1 column 3"),
                                           ("[1, 2]", "top level must be a JSON object")])
def test_every_json_reader_gives_the_same_located_line(reader, text, message, tmp_path):
    path = tmp_path / "f.json"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        reader(path)
    assert str(err.value).startswith(f"{path}: {message}")


def test_design_field_error_names_file_and_field(tmp_path):
    path = tmp_path / "d.json"
    path.write_text(json.dumps({"kind": "nafc", "name": "x", "participants": 0}))
    with pytest.raises(InputError) as err:
        load_design(path)
    assert err.value.source == str(path) and err.value.field == "participants"


@pytest.mark.parametrize("text, field", [("k=-1", "k"), ("mu_panel=inf", "mu_panel"), ("area=abc", "area")])
def test_display_option_values_are_checked_by_the_model(text, field):
    with pytest.raises(ConfigError) as err:
        load_display(text)
    assert err.value.source == "--display" and err.value.field == field


def test_display_option_accepts_both_leakage_names():
    assert load_display("leakage=0.05").leakage_time_constant == 0.05


@pytest.mark.parametrize("toml, field", [("k = true", "display.k"), ("load_range = [0.1]", "display.load_range"),
                                         ("kk = 1", "display.kk")])
def test_bad_display_section_is_one_line_exit_2(toml, field, tmp_path, capsys):
    cfg = tmp_path / "lab.toml"
    cfg.write_text(f"[display]\n{toml}\n")
    code = main(["render", "wood", "--scan", "speed=0.1,load=0.3,duration=0.2", "--out", str(tmp_path / "o"),
                 "--config", str(cfg), "--no-figure"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and f"{cfg}: {field}" in err


def test_scan_is_built_from_typed_values():
    v = {"speed": 0.1, "load": 0.3, "duration": 0.5}
    a, b = scan_trajectory(v), constant_scan(0.1, 0.3, 0.5, sensor_rate=125.0)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.load, b.load)
    c = trajectory_from_options("speed=0.1,load=0.3,duration=0.5,length=0.02", None)
    d = strokes(0.1, 0.3, 0.5, length=0.02, sensor_rate=125.0)
    assert np.array_equal(c.x, d.x)
    with pytest.raises(ConfigError) as err:
        scan_trajectory({"speed": 0.1, "load": 0.3})
    assert err.value.source == "--scan" and err.value.field == "duration"


def test_fit_imu_job_stores_the_command_it_is_given(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(2000) / 100.0
    rec = tmp_path / "r.csv"
    np.savetxt(rec, np.column_stack([t, rng.normal(size=(t.size, 3))]), delimiter=",", comments="",
               header="time,accel_x,accel_y,accel_z")
    base = sys.modules["surfhap"].__path__[0] + "/models/builtin/leather.json"
    target = tmp_path / "m.json"
    fit_imu_to_file(FitImuJob("r", rec, base, target, order=4, command="surfhap fit imu r.csv --order 4"))
    prov = json.loads(target.read_text())["texture"]["provenance"]
    assert prov["command"] == "surfhap fit imu r.csv --order 4"
