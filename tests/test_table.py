"""The one CSV reader behind recordings, IMU strokes, trajectories and tribometer runs."""

import numpy as np
import pytest

from surfhap.errors import InputError, RecordingFormatError, TrajectoryFormatError
from surfhap.exchange.imu_csv import read_imu_csv
from surfhap.exchange.recordings import read_recording
from surfhap.exchange.table import UNITS, read_csv_table, split_header
from surfhap.exchange.trajectory_csv import read_trajectory_csv
from surfhap.exchange.tribometer import read_tribometer

CH = {"time": UNITS["s"], "speed": UNITS["m/s"], "force": UNITS["N"]}


def test_header_forms():
    assert split_header("speed[mm/s]") == ("speed", "mm/s")
    assert split_header(" speed (mm/s) ") == ("speed", "mm/s")
    assert split_header("speed") == ("speed", None)


def test_units_metadata_and_rename(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("# participant: P3\n# trial: 2\ntime[ms],v_x[mm/s],force (mN),other\n0,10,250,x\n1,20,500,y\n")
    t = read_csv_table(p, CH, rename={"speed": "v_x"})
    assert t.meta == {"participant": "P3", "trial": "2"}
    np.testing.assert_allclose(t.columns["time"], [0.0, 1e-3])
    np.testing.assert_allclose(t.columns["speed"], [0.01, 0.02])
    np.testing.assert_allclose(t.columns["force"], [0.25, 0.5])
    assert "other" not in t.columns and t.n == 2 and len(t.sha256) == 64


@pytest.mark.parametrize("text, field, words", [
    ("time,speed\n0,1\n", "force", "missing column"),
    ("time[h],speed,force\n0,1,1\n", "time[h]", "unit 'h' is not a unit of time"),
    ("time,speed,force\n0,1,1\n1,abc,1\n", "speed", "row 2: 'abc' is not a number"),
    ("time,speed,force\n0,1,1\n1,,1\n", "speed", "row 2: a missing value is not a number"),
    ("time,speed,force\n0,1,1\n1,inf,1\n", "speed", "row 2: NaN or infinite value"),
])
def test_bad_input_names_file_and_field(tmp_path, text, field, words):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(RecordingFormatError) as err:
        read_csv_table(p, CH, required=("time", "speed", "force"), error=RecordingFormatError)
    assert err.value.source == str(p) and err.value.field == field and words in str(err.value)
    assert str(err.value).startswith(f"{p}: {field}: ") and "\n" not in str(err.value)


def test_nan_allowed_is_kept(tmp_path):
    p = tmp_path / "gap.csv"
    p.write_text("time,speed\n0,1\n1,\n2,nan\n3,4\n")
    t = read_csv_table(p, CH, allow_nan=True)
    assert np.isnan(t.columns["speed"][1:3]).all() and t.columns["speed"][3] == 4.0


def test_unreadable_and_not_utf8(tmp_path):
    with pytest.raises(InputError, match="cannot read file"):
        read_csv_table(tmp_path / "none.csv", CH)
    p = tmp_path / "bin.csv"
    p.write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        read_csv_table(p, CH)


def test_every_csv_reader_uses_it(tmp_path):
    """The same bad cell gives the same located line from all four readers (their own error class)."""
    cases = [
        (read_trajectory_csv, TrajectoryFormatError, "time,x,y,load\n", "{t},{b},0,0.3\n", "x"),
        (read_imu_csv, RecordingFormatError, "time,accel_x,accel_y,accel_z\n", "{t},{b},0,0\n", "accel_x"),
        (read_recording, RecordingFormatError, "time,speed,normal_force\n", "{t},{b},0.3\n", "speed"),
        (read_tribometer, RecordingFormatError, "# input: intensity\ntime,lateral_force,normal_force,level\n",
         "{t},{b},0.3,0\n", "lateral_force"),
    ]
    for reader, cls, header, row, field in cases:
        p = tmp_path / f"{reader.__name__}.csv"
        rows = [row.format(t=i * 0.01, b="1" if i != 5 else "oops") for i in range(40)]
        p.write_text(header + "".join(rows))
        with pytest.raises(cls) as err:
            reader(p)
        assert str(err.value) == f"{p}: {field}: row 6: 'oops' is not a number", reader.__name__


def test_units_reach_the_readers(tmp_path):
    p = tmp_path / "traj.csv"
    p.write_text("time[ms],x[mm],y[mm],load[mN]\n0,0,0,300\n10,1,0,300\n20,2,0,300\n")
    tr = read_trajectory_csv(p)
    np.testing.assert_allclose(tr.t, [0, 0.01, 0.02])
    np.testing.assert_allclose(tr.x, [0, 0.001, 0.002])
    np.testing.assert_allclose(tr.load, 0.3)
