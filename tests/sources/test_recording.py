"""The recording source: reader table, parameters, pipelines and the command line.

The end-to-end test plants every bad-input case in a recorded file at a known place
and checks the exact counts in the run summary.
"""
from __future__ import annotations

import json
import types
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

import firenav_framework.sources.readers as readers
from firenav_framework.cli import main
from firenav_framework.contract import Sink
from firenav_framework.messages import IMU_FLAG_BITS, ImuBlock
from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.registry import load_registry
from firenav_framework.runner import PipelineBuildError, Runner
from firenav_framework.sources.readers import (ReaderError, ReaderTable, ReadOptions,
                                               find_reader, imu_blocks, reader_table)
from firenav_framework.formats.imu_csv import ImuCsvReader, write_imu_csv
from firenav_framework.sources.readers.imu_csv import read_imu_text
from firenav_framework.sources.recording import RecordingSource
from firenav_framework.summary import summary_dict
from firenav_framework.testing import make_component
from firenav_framework.yaml_locations import ConfigError

G = 9.81


# -- the reader table ----------------------------------------------------------------------

def test_table_has_the_built_in_formats_and_ports():
    table = reader_table()
    assert {".mat", ".csv"} <= set(table.by_suffix)
    assert {"pyshoe_vicon", "indoor_walk", "imu_csv"} <= set(table.by_name)
    assert {"imu", "truth", "reference", "raw"} <= set(table.ports)
    assert table.errors == []


def test_lookup_by_suffix_name_or_suffix_name():
    assert find_reader("x/WALK.CSV") is read_imu_text
    assert find_reader("anything", "imu_csv") is ImuCsvReader
    assert find_reader("anything.bin", "csv") is read_imu_text
    with pytest.raises(ReaderError, match=r"no reader for '\.xyz' files; known: .*\.csv"):
        find_reader("a.xyz")
    with pytest.raises(ReaderError, match="unknown recording format 'cvs'"):
        find_reader("a.csv", "cvs")


def test_clashing_entries_and_broken_modules_are_reported_not_fatal(monkeypatch):
    table = ReaderTable()
    first, second = object(), object()
    table.add_module("a", types.SimpleNamespace(READERS={".x": first}, FORMATS={"x": first}))
    table.add_module("b", types.SimpleNamespace(READERS={".X": second, "y": second},
                                                PORTS={"imu": object}))
    assert table.by_suffix == {".x": first} and table.by_name == {"x": first}
    assert len(table.errors) == 3

    real_import = readers.importlib.import_module

    def failing(name, *a):
        if name.endswith(".imu_csv"):
            raise ImportError("no such library")
        return real_import(name, *a)

    monkeypatch.setattr(readers.importlib, "import_module", failing)
    table = readers.reader_table.__wrapped__()
    assert ".csv" not in table.by_suffix and ".mat" in table.by_suffix
    assert any("imu_csv failed to import: ImportError" in e for e in table.errors)


# -- the source ----------------------------------------------------------------------------

def csv_file(tmp_path: Path, n=300, t0=0.0) -> Path:
    t = t0 + np.arange(n) * 0.005
    accel = np.tile([0.0, 0.0, -G], (n, 1)) + np.sin(np.arange(3 * n)).reshape(n, 3) * 0.1
    gyro = np.cos(np.arange(3 * n)).reshape(n, 3) * 0.01
    return write_imu_csv(tmp_path / "rec.csv", imu_blocks(t, accel, gyro, block_s=0.1,
                                                           agent="ff1", device="ff1/imu"))


def test_time_offset_shifts_messages_and_block_length_is_honoured(tmp_path):
    path = csv_file(tmp_path)
    src, _, _ = make_component(RecordingSource, {"path": str(path), "time_offset": 1000.0,
                                                 "block_s": 0.25})
    out = [m for _, m in src.messages()]
    assert out[0].time[0] == 1000.0 and out[-1].t == pytest.approx(1000.0 + 299 * 0.005)
    assert len(out) == 6 and all(b.time[-1] - b.time[0] < 0.25 for b in out)


def test_relative_paths_resolve_against_the_pipeline_folder(tmp_path):
    csv_file(tmp_path)
    src, _, _ = make_component(RecordingSource, {"path": "rec.csv"}, base_dir=tmp_path)
    assert src.path == tmp_path / "rec.csv"


@pytest.mark.parametrize("params, error, message", [
    ({"format": "wav"}, ValidationError, "unknown recording format 'wav'"),
    ({}, ReaderError, "run with --input FILE"),
    ({"path": "missing.csv"}, ReaderError, "not found"),
])
def test_bad_source_parameters_say_what_is_wrong(tmp_path, params, error, message):
    with pytest.raises(error, match=message):
        make_component(RecordingSource, params, base_dir=tmp_path)


def test_unknown_suffix_is_a_located_pipeline_error(tmp_path):
    text = "sources:\n  - id: rec\n    plugin: recording\n    path: walk.xyz\n"
    with pytest.raises(ConfigError) as err:
        load_pipeline_text(text, file="p.yaml", base_dir=tmp_path)
    assert "p.yaml:2:" in str(err.value) and "no reader for '.xyz'" in str(err.value)


def test_mat_files_of_unknown_content_are_refused(tmp_path):
    import scipy.io

    scipy.io.savemat(tmp_path / "other.mat", {"speed": np.arange(5.0)})
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all" * 10)
    with pytest.raises(ReaderError, match="unknown .mat content .*speed"):
        make_component(RecordingSource, {"path": str(tmp_path / "other.mat")})
    with pytest.raises(ReaderError, match="not a readable MATLAB file"):
        make_component(RecordingSource, {"path": str(tmp_path / "junk.mat")})


# -- every bad-input case, end to end, in the run summary ------------------------------------

def planted_file(tmp_path: Path) -> tuple[Path, int]:
    """A z-down recording with each bad case planted once; returns (path, good samples)."""
    n = 1000
    rng = np.random.default_rng(7)
    t = np.arange(n) * 0.005
    a = (np.array([0.0, 0.0, -G]) + rng.normal(0, 0.2, (n, 3))).tolist()
    g = rng.normal(0, 0.02, (n, 3)).tolist()
    t = t.tolist()
    a[100][0] = float("nan")           # nonfinite
    g[101][2] = float("inf")           # nonfinite
    a[200][1] = 1000.0                 # out of range (limit 400 m/s^2)
    t[300] += 50.0                     # a corrupt timestamp
    t[500] = t[498]                    # time backwards (other values)
    a[700][0] = 160.0                  # saturated (full scale 156.9 m/s^2)
    rows = np.r_[0:400, 399, 400:600, 610:n]   # a duplicate of 399; a 55 ms gap
    lines = [",".join(map(repr, [t[i], *a[i], *g[i]])) for i in rows.tolist()]
    lines.insert(50, "0.25,1,2,three,4,5,6")  # a row the reader cannot parse
    path = tmp_path / "planted.csv"
    path.write_text("t,ax,ay,az,gx,gy,gz\n" + "\n".join(lines) + "\n")
    return path, n - 10 - 5


class CollectImu(Sink):
    """Keeps the ImuBlocks it receives (test sink)."""

    name = "collect_imu"
    inputs = (ImuBlock,)

    def start(self) -> None:
        self.blocks: list[ImuBlock] = []

    def handle(self, stream: str, msg: ImuBlock) -> None:
        self.blocks.append(msg)


PIPELINE = """\
name: planted
sources: [{{id: rec, plugin: recording, path: "{path}"}}]
sensors:
  - {{id: imu, plugin: foot_imu, input: rec.imu, axes: [x, -y, -z],
       screening: {{accel_saturation: 156.9}}}}
sinks:
  - {{id: collect, plugin: collect_imu, input: imu.imu}}
  - {{plugin: diagnostics_log, input: "*.diagnostics"}}
"""


def test_every_bad_input_case_is_counted_in_the_run_summary(tmp_path):
    path, good = planted_file(tmp_path)
    registry = load_registry()
    registry.add(CollectImu, package="tests")
    spec = load_pipeline_text(PIPELINE.format(path=path), base_dir=tmp_path, registry=registry)
    result = Runner(spec, output_dir=tmp_path / "out").run()
    blocks = result.components["collect"].blocks
    summary = summary_dict(result)
    assert summary["counts"]["rec"] == {"bad_rows": 1}
    assert summary["counts"]["imu"] == {
        "nonfinite_samples": 2, "out_of_range_samples": 1, "time_outlier_samples": 1,
        "duplicate_samples": 1, "time_backwards_samples": 1, "saturated_samples": 1,
        "gaps": 1}
    times = np.concatenate([b.time for b in blocks])
    flags = np.concatenate([b.flags for b in blocks])
    assert len(times) == good and np.all(np.diff(times) > 0)
    assert times[flags & IMU_FLAG_BITS["saturated"] != 0].tolist() == [3.5]
    assert times[flags & IMU_FLAG_BITS["gap_before"] != 0].tolist() == [pytest.approx(3.05)]
    logged = [json.loads(x) for x in (tmp_path / "out" / "diagnostics.jsonl").read_text().splitlines()]
    assert {d["code"] for d in logged} == {"imu_nonfinite", "imu_out_of_range", "imu_time_outlier",
                                           "imu_time_backwards", "imu_saturated", "imu_gaps"}


# -- the command line on the real datasets ---------------------------------------------------

RUN_PIPELINE = """\
name: real
sources: [{id: rec, plugin: recording}]
sensors: [{id: imu, plugin: foot_imu, input: rec.imu, axes: [x, -y, -z]}]
sinks:
  - {plugin: csv_tracks, input: rec.reference}
  - {plugin: diagnostics_log, input: "*.diagnostics"}
"""


@pytest.mark.parametrize("name", ["pyshoe-vicon/2017-11-22-11-48-35.mat",
                                  "indoor-walks/walk_34.mat"])
def test_firenav_run_input_replays_a_real_file(shared_data, tmp_path, capsys, name):
    pipe = tmp_path / "real.yaml"
    pipe.write_text(RUN_PIPELINE)
    out = tmp_path / "out"
    assert main(["run", str(pipe), "--input", str(shared_data / name), "--output", str(out),
                 "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    msgs = summary["messages"]
    assert msgs["imu.imu"] == msgs["rec.imu"] > 100
    assert summary["counts"] == {}
    assert msgs["rec.truth"] > 20
    if name.startswith("indoor"):
        assert (out / "rec_reference.csv").is_file() and msgs["rec.reference"] > 100
    else:
        assert "rec.reference" not in msgs


def test_missing_input_file_is_a_usage_error(tmp_path, capsys):
    pipe = tmp_path / "real.yaml"
    pipe.write_text(RUN_PIPELINE)
    assert main(["run", str(pipe), "--input", str(tmp_path / "nope.mat")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_a_source_without_path_cannot_be_built(tmp_path):
    spec = load_pipeline_text(RUN_PIPELINE, base_dir=tmp_path)
    with pytest.raises(PipelineBuildError, match="run with --input FILE"):
        Runner(spec, output_dir=tmp_path).run()


def test_read_options_default_device_follows_agent():
    assert ReadOptions(agent="ff4").device == "ff4/imu"
    with pytest.raises(ValueError, match="block_s"):
        ReadOptions(block_s=0)
