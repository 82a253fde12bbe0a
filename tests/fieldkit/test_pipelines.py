"""The shipped field pipeline validates, and its replay form too."""
from __future__ import annotations

from firenav_framework.cli.replay import replay_document
from firenav_framework.pipeline import load_pipeline, validate_document


def test_field_live_pipeline_validates_and_replays(repo, tmp_path):
    path = repo / "pipelines" / "field-live.yaml"
    spec = load_pipeline(path)
    assert {c.plugin.name for c in spec.of_kind("source")} == {"can_bus", "mavlink"}
    for cid, suffix in (("can", ".log"), ("mav", ".tlog")):
        (tmp_path / cid).mkdir()
        (tmp_path / cid / f"x-0000-20260101T000000{suffix}").write_bytes(b"")
    spec = validate_document(replay_document(str(path), tmp_path))
    assert {c.plugin.name for c in spec.of_kind("source")} == {"recording"}


def test_field_building_pipeline_validates_and_replays(repo, tmp_path):
    path = repo / "pipelines" / "field-building.yaml"
    spec = load_pipeline(path)
    assert spec.building is not None and spec.building.exists()
    assert {c.plugin.name for c in spec.of_kind("source")} == {"can_bus", "mavlink", "udp_lines"}
    pf = next(c for c in spec.of_kind("estimator") if c.id == "pf")
    assert pf.params.start.mode == "entrance" and pf.params.start.entrance == "main"
    from firenav_framework.building import load_building
    assert "main" in {e.id for e in load_building(spec.building).entrances}
    for cid, suffix in (("can", ".log"), ("mav", ".tlog"), ("baro_link", ".lines")):
        (tmp_path / cid).mkdir()
        (tmp_path / cid / f"x-0000-20260101T000000{suffix}").write_bytes(b"")
    spec = validate_document(replay_document(str(path), tmp_path))
    assert {c.plugin.name for c in spec.of_kind("source")} == {"recording"}
