"""The file formats share their readers and writers (issue 20, size budget): tribometer runs are
read by the recordings' reader and time checks, and every CSV writer goes through one function.
What the sharing gives the formats that lacked it is checked here against the files' text."""

import numpy as np
import pytest

from surfhap.errors import MaterialFormatError, RecordingFormatError
from surfhap.exchange.hatt import bank_to_hatt, import_hatt_folder, write_hatt_xml
from surfhap.exchange.tribometer import read_tribometer, write_tribometer_csv
from surfhap.exchange.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from surfhap.lab.tribometer_synth import synthetic_tribometer
from surfhap.models.trajectory import constant_scan


def _tribometer_csv(tmp_path):
    rec = synthetic_tribometer(0.5, duration=2.0, sample_rate=2000.0)
    return rec, write_tribometer_csv(rec, tmp_path / "run.csv").read_text().splitlines()


def test_a_tribometer_csv_may_give_its_rate_instead_of_a_time_column(tmp_path):
    rec, lines = _tribometer_csv(tmp_path)
    assert lines[1] == "time[s],lateral_force[N],normal_force[N],level[1]"
    rows = [line.split(",", 1)[1] for line in lines[2:]]
    p = tmp_path / "rate.csv"
    p.write_text("# input: intensity\n# sample_rate: 2000\nlateral_force[N],normal_force[N],level[1]\n"
                 + "\n".join(rows) + "\n")
    back = read_tribometer(p)
    assert back.sample_rate == pytest.approx(2000.0) and back.time.size == rec.time.size
    np.testing.assert_allclose(back.lateral_force, rec.lateral_force, rtol=1e-8)


def test_a_gap_in_a_tribometer_csv_is_located_like_a_recording_gap(tmp_path):
    _, lines = _tribometer_csv(tmp_path)
    for i in range(102, 107):  # data rows 100..104 (1-based: 101..105) lose their lateral force
        t, _, fn, lv = lines[i].split(",")
        lines[i] = f"{t},,{fn},{lv}"
    p = tmp_path / "gap.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingFormatError) as err:
        read_tribometer(p)
    assert err.value.field == "lateral_force" and err.value.source == str(p)
    assert "a run of 5 sample(s) from row 101" in str(err.value), str(err.value)


def test_the_trajectory_writer_creates_its_folder(tmp_path):
    traj = constant_scan(0.1, 0.3, 0.2)
    path = write_trajectory_csv(traj, tmp_path / "new" / "traj.csv")
    assert path.read_text().splitlines()[0] == "time,x,y,load"
    np.testing.assert_allclose(read_trajectory_csv(path).x, traj.x, rtol=1e-8)


def test_a_hatt_folder_with_a_bad_model_set_writes_nothing(tmp_path, monkeypatch):
    """The folder import reads through the same guard as load_material: a model set the
    material refuses is one MaterialFormatError naming the file, before any JSON is written."""
    import surfhap.exchange.hatt as hatt
    from test_hatt import make_bank

    src = tmp_path / "hatt"
    src.mkdir()
    for name in ("A", "B"):
        write_hatt_xml(bank_to_hatt(make_bank(), name, 0.5), src / f"Models_{name}.xml")

    def refuse(ms, source, sha256=None, command=None):
        if ms.material == "B":
            raise ValueError("texture refused\nsecond line")
        return real(ms, source, sha256, command)

    real = hatt.hatt_to_material
    monkeypatch.setattr(hatt, "hatt_to_material", refuse)
    with pytest.raises(MaterialFormatError) as err:
        import_hatt_folder(src, tmp_path / "out")
    assert str(err.value) == f"{src / 'Models_B.xml'}: texture refused"
    assert not (tmp_path / "out").exists()
