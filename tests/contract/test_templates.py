"""Each file of extension_templates/, copied as it is (nothing filled in), passes the
conformance suite: the templates are working plugins, not sketches."""
from __future__ import annotations

import importlib

import pytest

from firenav_framework.messages import GroundTruth, PoseEstimate
from firenav_framework.testing import check_codec, check_plugin, sample_world

from .templates import KINDS, TEMPLATES, load


def test_there_is_a_template_per_kind_and_a_codec():
    assert sorted(p.stem for p in TEMPLATES.glob("*.py")) == sorted([*KINDS, "codec"])
    for name in [*KINDS, "codec"]:
        text = (TEMPLATES / f"{name}.py").read_text()
        assert "TODO" in text and "check_" in text, f"{name}.py lacks TODO markers or the test call"


@pytest.mark.parametrize("kind", ["sensor", "estimator", "constraint"])
def test_template_conforms_on_the_bundled_sample(kind, tmp_path):
    cls = load(kind, tmp_path)
    assert cls.kind == kind
    rec = check_plugin(cls)
    assert rec.records, f"the {kind} template did nothing with the sample"


def test_sink_template_conforms_and_writes_every_pose(tmp_path):
    cls = load("sink", tmp_path)
    check_plugin(cls, output_dir=tmp_path / "out")
    poses = [m for _, m in sample_world().messages if isinstance(m, PoseEstimate)]
    lines = (tmp_path / "out" / "poses.csv").read_text().splitlines()
    assert lines[0] == "t,agent,x,y,z,heading" and len(lines) == 1 + len(poses)


def test_source_template_conforms_on_a_file_and_counts_a_damaged_one(tmp_path):
    cls = load("source", tmp_path)
    good, bad = tmp_path / "points.csv", tmp_path / "damaged.csv"
    good.write_text("# t,agent,x,y,z\n1.0,ff1,0,0,0\n2.5,ff1,1.5,0.5,0\n3.0,ff2,4,4,3\n")
    bad.write_text("1.0,ff1,0,0,0\n2.0,ff1,nan,0,0\nbroken\n3.0,,1,1,1\n4.0,ff1,1,1,0\n")
    rec = check_plugin(cls, {"path": str(good)}, faulty_params=[{"path": str(bad)}])
    assert [(m.t, m.agent, m.position.tolist()) for m in rec.on("truth")] == [
        (1.0, "ff1", [0, 0, 0]), (2.5, "ff1", [1.5, 0.5, 0]), (3.0, "ff2", [4, 4, 3])]


def test_estimator_template_integrates_from_the_start_pose(tmp_path):
    cls = load("estimator", tmp_path)
    truth = [m for _, m in sample_world().messages
             if isinstance(m, GroundTruth) and m.agent == "ff1"]
    start = truth[0]
    rec = check_plugin(cls, {"start": {"mode": "pose", "position": tuple(start.position),
                                       "heading": start.heading}})
    last = [m for m in rec.on("pose") if m.agent == "ff1"][-1]
    at = next(m for m in truth if m.t == last.t)
    # the sample's odometry is the true motion: dead reckoning ends where ff1 truly is
    assert last.frame == "building"
    assert last.position == pytest.approx(at.position, abs=1e-6)
    assert last.heading == pytest.approx(at.heading, abs=1e-6)


def test_codec_template_conforms(tmp_path):
    cls = load("codec", tmp_path)
    record = cls.record
    results = check_codec(cls, records=[record(1.0, "link/tag7", "uwb_entrance", 7.25),
                                        record(1.1, "link/tag7", "a2", 12.5)], address="tag7")
    assert results == {"class": "passed", "round_trip": "passed", "bad_frames": "passed",
                       "deterministic": "passed"}


def test_the_readme_vendor_example_conforms(tmp_path, monkeypatch):
    """The example as a vendor would use it: saved as a module and imported (its parameter
    descriptions are the docstrings in that file)."""
    readme = (TEMPLATES.parent / "README.md").read_text()
    section = readme[readme.index("## Writing a sensor plugin"):]
    start = section.index("```python\n") + len("```python\n")
    (tmp_path / "acme_readme_sensor.py").write_text(section[start:section.index("```\n", start)])
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("acme_readme_sensor")
    rec = check_plugin(module.AcmeRangeSensor)
    assert rec.on("range")
