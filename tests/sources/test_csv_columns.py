"""Column and unit mappings of IMU text files: given on the source, in a sidecar file,
over a public format's preset; sample-index time; bad rows and bad mappings."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.formats.base import ReaderError, ReadOptions
from firenav_framework.formats.csv_layout import CsvColumns
from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.sources.readers import find_reader
from firenav_framework.sources.recording import RecordingSource
from firenav_framework.testing import make_component
from firenav_framework.yaml_locations import ConfigError

G0 = 9.80665


def samples(n: int = 400, rate: float = 100.0):
    """(t [s], accel [m/s^2], gyro [rad/s]) with distinct values in every cell."""
    k = np.arange(n)
    t = k / rate
    accel = np.column_stack([0.1 * np.sin(k), 0.2 * np.cos(k), 9.81 + 0.05 * np.sin(3 * k)])
    gyro = np.column_stack([0.01 * k / n, -0.02 * np.cos(k), 0.3 * np.sin(2 * k)])
    return t, accel, gyro


def logger_file(path, rows, header="idx;ax_g;ay_g;az_g;wx_dps;wy_dps;wz_dps;temp"):
    """A logger's own CSV: semicolons, a sample counter, g and deg/s, an extra column."""
    with open(path, "w") as fh:
        fh.write(header + "\n")
        for line in rows:
            fh.write(line + "\n")
    return path


def logger_rows(t, accel, gyro, rate):
    return [f"{round(ti * rate)};" + ";".join(map(repr, (a / G0).tolist())) + ";"
            + ";".join(map(repr, np.degrees(w).tolist())) + ";21.5"
            for ti, a, w in zip(t, accel, gyro)]


MAPPING = {"time": "idx", "time_unit": "sample", "rate": 100.0, "delimiter": ";",
           "accel": ["ax_g", "ay_g", "az_g"], "gyro": ["wx_dps", "wy_dps", "wz_dps"],
           "accel_unit": "g", "gyro_unit": "deg/s"}


def read(path, columns=None, **options):
    opts = ReadOptions(columns=CsvColumns(**columns) if columns is not None else None,
                       **options)
    return list(find_reader(path)(path, opts))


def joined(msgs, device=None):
    blocks = [m for p, m in msgs if p == "imu" and (device is None or m.device == device)]
    return (np.concatenate([b.time for b in blocks]), np.concatenate([b.accel for b in blocks]),
            np.concatenate([b.gyro for b in blocks]))


def test_a_mapping_on_the_source_reads_a_logger_file_in_si(tmp_path):
    t, accel, gyro = samples()
    path = logger_file(tmp_path / "log.csv", logger_rows(t, accel, gyro, 100.0))
    rt, ra, rg = joined(read(path, MAPPING))
    np.testing.assert_allclose(rt, t, atol=1e-12)     # sample index / rate
    np.testing.assert_allclose(ra, accel, rtol=1e-12)
    np.testing.assert_allclose(rg, gyro, rtol=1e-12, atol=1e-15)


def test_a_sidecar_next_to_the_file_describes_it(tmp_path):
    t, accel, gyro = samples()
    path = logger_file(tmp_path / "log.csv", logger_rows(t, accel, gyro, 100.0))
    import yaml
    (tmp_path / "log.columns.yaml").write_text(yaml.safe_dump({"columns": MAPPING}))
    rt, ra, _ = joined(read(path))
    np.testing.assert_allclose(ra, accel, rtol=1e-12)
    # the source's keys replace the sidecar's: here the rate
    rt2, _, _ = joined(read(path, {"rate": 50.0}))
    np.testing.assert_allclose(rt2, 2 * t, atol=1e-12)


def test_a_folder_sidecar_serves_every_file_without_its_own(tmp_path):
    t, accel, gyro = samples(50)
    import yaml
    (tmp_path / "columns.yaml").write_text(yaml.safe_dump(MAPPING))
    for name in ("a.csv", "b.csv"):
        logger_file(tmp_path / name, logger_rows(t, accel, gyro, 100.0))
        assert len(joined(read(tmp_path / name))[0]) == 50


def test_time_in_milliseconds_and_no_time_column(tmp_path):
    t, accel, gyro = samples(100)
    path = tmp_path / "ms.csv"
    path.write_text("ms,a1,a2,a3,g1,g2,g3\n" + "".join(
        ",".join(map(repr, [1000 * ti, *a, *w])) + "\n"
        for ti, a, w in zip(t.tolist(), accel.tolist(), gyro.tolist())))
    cols = {"accel": ["a1", "a2", "a3"], "gyro": ["g1", "g2", "g3"]}
    rt, _, _ = joined(read(path, {**cols, "time": "ms", "time_unit": "ms"}))
    np.testing.assert_allclose(rt, t, atol=1e-12)
    rt, _, _ = joined(read(path, {**cols, "rate": 200.0}))          # the row number
    np.testing.assert_allclose(rt, np.arange(100) / 200.0, atol=1e-12)


def test_whitespace_columns_by_index_without_a_header(tmp_path):
    t, accel, gyro = samples(60)
    path = tmp_path / "plain.txt"
    path.write_text("".join(f"{ti!r}  {'  '.join(map(repr, a))}\t{' '.join(map(repr, w))}\n"
                            for ti, a, w in zip(t.tolist(), accel.tolist(), gyro.tolist())))
    rt, ra, rg = joined(read(path, {"header_rows": 0, "delimiter": "whitespace", "time": 0,
                                    "accel": [1, 2, 3], "gyro": [4, 5, 6]}))
    np.testing.assert_allclose(rt, t)
    np.testing.assert_allclose(rg, gyro)


def test_rows_that_cannot_be_read_are_counted_and_skipped(tmp_path):
    t, accel, gyro = samples(100)
    rows = logger_rows(t, accel, gyro, 100.0)
    rows[10] = "10;0.1;oops;1.0;0;0;0;21"      # text where a number belongs
    rows[20] = "20;0.1"                          # too few fields
    rows[30] = ""                                # a blank line is not a row
    path = logger_file(tmp_path / "log.csv", rows)
    counts = {}
    msgs = read(path, MAPPING, count=lambda what, n: counts.__setitem__(what, counts.get(what, 0) + n))
    assert counts == {"bad_rows": 2}
    assert len(joined(msgs)[0]) == 97


@pytest.mark.parametrize("columns, message", [
    ({**MAPPING, "accel": ["ax_g", "ay_g", "AZ_G"]}, "no column 'AZ_G'.*did you mean 'az_g'"),
    ({k: v for k, v in MAPPING.items() if k != "rate"}, "sample-index time column needs `rate`"),
    ({k: v for k, v in MAPPING.items() if k != "gyro"}, "`gyro` is missing"),
    ({**MAPPING, "devices": ["left"]}, "`devices` and '{device}'"),
])
def test_a_wrong_mapping_names_the_problem(tmp_path, columns, message):
    t, accel, gyro = samples(20)
    path = logger_file(tmp_path / "log.csv", logger_rows(t, accel, gyro, 100.0))
    with pytest.raises(ReaderError, match=message):
        read(path, columns)


def test_a_csv_nobody_knows_says_how_to_map_it(tmp_path):
    t, accel, gyro = samples(20)
    path = logger_file(tmp_path / "log.csv", logger_rows(t, accel, gyro, 100.0))
    with pytest.raises(ReaderError, match=r"lacks t, ax.*columns:.*log\.columns\.yaml"):
        read(path)


def test_the_mapping_is_a_checked_pipeline_parameter(tmp_path):
    text = ("sources:\n  - id: rec\n    plugin: recording\n    path: x.csv\n"
            "    columns: {accel_unit: furlong, rate: 60}\n")
    with pytest.raises(ConfigError) as err:
        load_pipeline_text(text, file="p.yaml", base_dir=tmp_path)
    assert "p.yaml:5:" in str(err.value) and "accel_unit" in str(err.value)


def test_the_recording_source_passes_the_mapping_to_the_reader(tmp_path):
    t, accel, gyro = samples(200)
    path = logger_file(tmp_path / "log.csv", logger_rows(t, accel, gyro, 100.0))
    src, _, _ = make_component(RecordingSource, {"path": str(path), "columns": MAPPING})
    blocks = [m for port, m in src.messages() if port == "imu"]
    assert sum(len(b) for b in blocks) == 200
    assert math.isclose(blocks[-1].t, t[-1])
