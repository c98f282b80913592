"""Recording readers: named, unit-checked channels and one clear error per problem."""

import numpy as np
import pytest

from surfhap.errors import RecordingFormatError
from surfhap.exchange.recordings import (Recording, parse_column_map, read_recording, read_recordings, write_recording_csv,
                                         write_recording_npz)


def table(tmp_path, header, cols, name="r.csv", meta=""):
    path = tmp_path / name
    body = "\n".join(",".join(f"{v:.9g}" if isinstance(v, float) else str(v) for v in row) for row in zip(*cols))
    path.write_text(meta + header + "\n" + body + "\n")
    return path


def test_csv_units_are_converted_to_si(tmp_path):
    t = np.arange(100) * 0.5  # ms
    path = table(tmp_path, "time[ms],normal_force[mN],cof,speed (mm/s),acceleration[g]",
                 [t, np.full(100, 500.0), np.full(100, 0.4), np.full(100, 80.0), np.full(100, 1.0)], meta="# participant: P7\n")
    rec = read_recording(path)
    assert rec.sample_rate == 2000.0 and rec.participant == "P7"
    np.testing.assert_allclose(rec.get("normal_force"), 0.5)
    np.testing.assert_allclose(rec.get("speed"), 0.08)
    np.testing.assert_allclose(rec.get("shear_force"), 0.2)  # from cof * normal
    np.testing.assert_allclose(rec.get("acceleration"), 9.80665)
    assert len(rec.sha256) == 64


def test_column_map_and_position(tmp_path):
    t = np.arange(200) / 1000
    path = table(tmp_path, "t,Fz,Fx,x_mm", [t, np.ones(200), 0.3 * np.ones(200), 100.0 * t])
    rec = read_recording(path, parse_column_map("time=t,normal_force=Fz,shear_force=Fx,position=x_mm[mm]"))
    np.testing.assert_allclose(rec.get("speed"), 0.1, rtol=1e-9)


def test_npz_with_sample_rate(tmp_path):
    path = tmp_path / "r.npz"
    np.savez(path, sample_rate=1000.0, normal_force=np.ones(50), **{"speed[mm/s]": np.full(50, 50.0)}, participant=np.array("A"))
    rec = read_recording(path)
    assert rec.participant == "A" and rec.n == 50
    np.testing.assert_allclose(rec.time[1], 1e-3)
    np.testing.assert_allclose(rec.get("speed"), 0.05)


def test_writers_round_trip(tmp_path):
    t = np.arange(64) / 2000
    rec = Recording.from_arrays(t, source="x", participant="P2", normal_force=np.linspace(0.1, 1, 64), shear_force=np.linspace(0, 0.5, 64),
                                speed=np.full(64, 0.1))
    for path in (write_recording_csv(rec, tmp_path / "a.csv"), write_recording_npz(rec, tmp_path / "a.npz")):
        back = read_recording(path)
        assert back.participant == "P2"
        for k in rec.channels:
            np.testing.assert_allclose(back.get(k), rec.get(k), rtol=1e-8)
    assert len(read_recordings([tmp_path / "a.csv", tmp_path / "a.npz"])) == 2


@pytest.mark.parametrize("header,mutate,field,words", [
    ("time,normal_force,shear_force,speed", lambda c: c[0].__setitem__(30, c[0][10]), "time", "not strictly increasing"),
    ("time,normal_force,shear_force,speed", lambda c: c[1].__setitem__(slice(40, 46), np.nan), "normal_force", "run of 6"),
    ("time,normal_force,shear_force,speed[km/h]", lambda c: None, "speed", "not a unit of speed"),
    ("time,normal_force,shear_force,speed", lambda c: c[0].__setitem__(slice(50, None), c[0][50:] + 0.5), "time", "not uniformly sampled"),
])
def test_malformed_recordings_name_file_and_field(tmp_path, header, mutate, field, words):
    cols = [np.arange(100) / 1000, np.ones(100), 0.5 * np.ones(100), 0.1 * np.ones(100)]
    mutate(cols)
    path = table(tmp_path, header, cols)
    with pytest.raises(RecordingFormatError) as err:
        read_recording(path)
    assert err.value.field.startswith(field) and err.value.source == str(path) and words in str(err.value)
    assert "\n" not in str(err.value)


def test_missing_channel_is_reported(tmp_path):
    path = table(tmp_path, "time,normal_force", [np.arange(100) / 1000, np.ones(100)])
    rec = read_recording(path)
    with pytest.raises(RecordingFormatError) as err:
        rec.require("normal_force", "shear_force")
    assert err.value.field == "shear_force" and "--columns" in str(err.value)
    with pytest.raises(RecordingFormatError):
        read_recording(path, {"speed": "nope"})
    with pytest.raises(RecordingFormatError):
        parse_column_map("velocity=v")
