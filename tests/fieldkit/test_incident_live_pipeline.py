"""The shipped live incident pipeline validates, replays, knows its anchors, and runs the
offline incident pipeline's estimators with the same parameters."""
from __future__ import annotations

import yaml

from firenav_framework.building import load_building
from firenav_framework.cli.replay import replay_document
from firenav_framework.pipeline import load_pipeline, validate_document


def test_incident_live_validates_replays_and_maps_the_plan_anchors(repo, tmp_path):
    path = repo / "pipelines" / "incident-live.yaml"
    spec = load_pipeline(path)
    assert {c.plugin.name for c in spec.of_kind("source")} == {"can_bus", "mavlink",
                                                               "serial_lines"}
    uwb = next(c for c in spec.of_kind("sensor") if c.id == "uwb")
    anchors = [a.id for a in load_building(spec.building).anchors]
    # the player numbers anchors by their index in the plan: the sensor must agree
    assert {int(k): v for k, v in uwb.params.anchors.items()} == dict(enumerate(anchors))
    assert "uwb_entrance" in anchors
    for cid, suffix in (("can", ".log"), ("mav", ".tlog"), ("lines", ".lines")):
        (tmp_path / cid).mkdir()
        (tmp_path / cid / f"x-0000-20260101T000000{suffix}").write_bytes(b"")
    spec = validate_document(replay_document(str(path), tmp_path))
    assert {c.plugin.name for c in spec.of_kind("source")} == {"recording"}


def test_incident_live_runs_the_offline_estimators_and_sensor_settings(repo):
    live = yaml.safe_load((repo / "pipelines" / "incident-live.yaml").read_text())
    offline = yaml.safe_load((repo / "pipelines" / "incident.yaml").read_text())

    def settings(doc, section):
        return {c["id"]: {k: v for k, v in c.items() if k != "input"} for c in doc[section]}

    est_live, est_off = settings(live, "estimators"), settings(offline, "estimators")
    assert est_live == est_off
    sensors_live, sensors_off = settings(live, "sensors"), settings(offline, "sensors")
    # the foot IMUs come in on two links: only their link settings (frames, axes) differ
    assert sensors_off.pop("imu") == {"id": "imu", "plugin": "foot_imu"}
    for cid in ("imu_can", "imu_mav"):
        assert set(sensors_live[cid]) <= {"id", "plugin", "frames", "axes"}
    for cid, params in sensors_off.items():
        extra = {k: v for k, v in sensors_live[cid].items() if k not in params}
        assert {k: sensors_live[cid][k] for k in params} == params, cid
        assert set(extra) <= {"tags", "anchors"}, cid   # the wire numbers only
