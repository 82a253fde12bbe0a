"""The firenav IMU CSV format: exact round trips, units, labels, bad rows and headers."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.messages import ImuBlock
from firenav_framework.sources.readers import ReaderError, ReadOptions, imu_blocks
from firenav_framework.formats.imu_csv import ImuCsvReader, write_imu_csv


def make_blocks(n=500, seed=3, agent="ff1", device="ff1/imu", mag=True, t0=100.0):
    rng = np.random.default_rng(seed)
    t = t0 + np.cumsum(rng.uniform(0.004, 0.006, n))
    a = rng.normal(0, 20, (n, 3))
    g = rng.normal(0, 3, (n, 3))
    m = rng.normal(0, 40, (n, 3)) if mag else None
    return list(imu_blocks(t, a, g, mag=m, block_s=0.1, agent=agent, device=device))


def read(path, **options):
    counts = {}
    opts = ReadOptions(count=lambda what, n: counts.__setitem__(what, counts.get(what, 0) + n),
                       **options)
    items = list(ImuCsvReader(path, opts))
    assert {p for p, _ in items} <= {"imu"}
    return [m for _, m in items], counts


def cat(blocks, field):
    return np.concatenate([getattr(b, field) for b in blocks])


def test_si_round_trip_is_bit_exact_with_labels_in_the_header(tmp_path):
    blocks = make_blocks()
    path = write_imu_csv(tmp_path / "a.csv", blocks)
    text = path.read_text().splitlines()
    assert text[0] == "# firenav imu-csv 1" and "# device: ff1/imu" in text
    back, counts = read(path, agent="other")
    assert counts == {}
    for f in ("time", "accel", "gyro", "mag"):
        assert np.array_equal(cat(back, f), cat(blocks, f)), f
    assert {(b.agent, b.device, b.frame) for b in back} == {("ff1", "ff1/imu", "device")}
    assert all(b.t == b.time[-1] for b in back)


def test_units_in_g_and_deg_per_s_read_back_in_si(tmp_path):
    blocks = make_blocks(mag=False)
    path = write_imu_csv(tmp_path / "u.csv", blocks, accel_unit="g", gyro_unit="deg/s")
    back, _ = read(path)
    np.testing.assert_allclose(cat(back, "accel"), cat(blocks, "accel"), rtol=1e-14)
    np.testing.assert_allclose(cat(back, "gyro"), cat(blocks, "gyro"), rtol=1e-14)
    assert all(b.mag is None for b in back)


def test_several_devices_get_label_columns_and_are_split_again(tmp_path):
    left = make_blocks(seed=1, agent="ff1", device="ff1/left")
    right = make_blocks(seed=2, agent="ff2", device="ff2/imu")
    interleaved = sorted(left + right, key=lambda b: b.t)
    path = write_imu_csv(tmp_path / "two.csv", interleaved)
    assert "t,ax,ay,az,gx,gy,gz,mx,my,mz,agent,device" in path.read_text().splitlines()
    back, _ = read(path)
    for original in (left, right):
        dev = original[0].device
        got = [b for b in back if b.device == dev]
        assert np.array_equal(cat(got, "time"), cat(original, "time"))
        assert np.array_equal(cat(got, "accel"), cat(original, "accel"))
        assert {b.agent for b in got} == {original[0].agent}
    assert [b.t for b in back] == sorted(b.t for b in back)


def test_hand_written_file_with_defaults_and_bad_rows(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text(
        "# accel_unit: g\n"
        "t, ax, ay, az, gx, gy, gz\n"
        "0.000, 0, 0, -1, 0, 0, 0\n"
        "0.005, 0, 0, -1, 0, 0\n"          # a field short
        "0.010, 0, zero, -1, 0, 0, 0\n"    # text
        "0.015, 0, 0, , 0, 0, 0\n"         # empty inertial field
        "# a comment in the middle\n"
        "0.020, nan, 0, -1, 0, 0, inf\n"   # passed on for the sensor to judge
        "0.025, 0, 0, -1, 0, 0, 0\n")
    back, counts = read(path, agent="ff7")
    assert counts == {"bad_rows": 3}
    assert np.allclose(cat(back, "time"), [0.0, 0.02, 0.025])
    acc = cat(back, "accel")
    assert np.isnan(acc[1, 0]) and np.isinf(cat(back, "gyro")[1, 2])
    assert acc[0, 2] == -9.80665
    assert {(b.agent, b.device) for b in back} == {("ff7", "ff7/imu")}


@pytest.mark.parametrize("text, message", [
    ("t,ax,ay,az,gx,gy\n", "lacks gz"),
    ("# gyro_unit: rpm\nt,ax,ay,az,gx,gy,gz\n", "gyro_unit 'rpm'"),
    ("t,ax,ay,az,gx,gy,gz,mx\n", "all of mx, my, mz"),
    ("t,ax,ay,az,gx,gy,gz,speed\n", "unknown or repeated columns speed"),
    ("# only comments\n", "no column header"),
])
def test_bad_headers_are_refused_with_the_reason(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ReaderError, match=message):
        ImuCsvReader(path, ReadOptions())


def test_writer_refuses_mixed_frames_and_unknown_units(tmp_path):
    a = make_blocks(20)
    b = [ImuBlock.from_arrays(x.time, x.accel, x.gyro, frame="FLU") for x in a]
    with pytest.raises(ValueError, match="different frames"):
        write_imu_csv(tmp_path / "x.csv", a + b)
    with pytest.raises(ValueError, match="accel_unit"):
        write_imu_csv(tmp_path / "x.csv", a, accel_unit="ft/s^2")


def test_long_files_are_read_in_chunks_without_losing_or_reordering_rows(tmp_path, monkeypatch):
    import firenav_framework.formats.imu_csv as mod

    monkeypatch.setattr(mod, "CHUNK_ROWS", 97)
    blocks = make_blocks(1000)
    back, _ = read(write_imu_csv(tmp_path / "long.csv", blocks))
    assert np.array_equal(cat(back, "time"), cat(blocks, "time"))


def test_imu_blocks_partition_the_samples_into_block_length_pieces():
    t = np.arange(1003) * 0.005 + 7.0
    a = np.arange(3009.0).reshape(-1, 3)
    out = list(imu_blocks(t, a, -a, block_s=0.1, agent="a", device="d"))
    assert np.array_equal(np.concatenate([b.time for b in out]), t)
    assert np.array_equal(np.concatenate([b.gyro for b in out]), -a)
    assert all(b.time[-1] - b.time[0] < 0.1 and b.t == b.time[-1] for b in out)
    assert len(out) == 51


def test_quoted_header_names_and_a_stray_non_utf8_byte_cost_only_that_row(tmp_path):
    path = tmp_path / "export.csv"
    path.write_bytes(b'"t","ax","ay","az","gx","gy","gz"\n'
                     b"0.000,0,0,9.8,0,0,0\n"
                     b"0.005,0,0,9.8,0,0\xff,0\n"      # a corrupt byte inside a field
                     b"0.010,0,0,9.8,0,0,0\n")
    back, counts = read(path, agent="ff1")
    assert counts == {"bad_rows": 1}
    assert np.allclose(cat(back, "time"), [0.0, 0.01])
