"""End to end: the simulator acts as the devices, `field-live.yaml` runs live on CAN and
MAVLink, its tracks equal the offline run of the same scenario (harness docstring:
the tolerance), and `firenav replay` of its logs gives the identical tracks."""
from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from firenav_framework.cli.replay import replay_document
from firenav_framework.cli.run import execute
from firenav_framework.pipeline import apply_overrides, validate_document
from firenav_framework.tracks import Track

from .conftest import free_port
from .harness import AGENTS, PIPELINE, assert_matches_offline, offline_tracks, run_live



def csv_rows_by_agent(path: Path) -> dict[str, list[str]]:
    """Complete rows (ending in a newline) of a csv_tracks file, per agent."""
    rows: dict[str, list[str]] = defaultdict(list)
    for line in path.read_text().splitlines(keepends=True)[1:]:
        if line.endswith("\n"):
            rows[line.split(",")[1]].append(line)
    return dict(rows)


def replay_logs(raw: Path, out: Path, **pace):
    """`firenav replay RAW --pipeline field-live.yaml` (local ports), in this process."""
    doc = replay_document(str(PIPELINE), raw)
    done = apply_overrides(doc, ["sinks.live_view.port=0",
                                 f"sinks.mavlink_out.url=udpout:127.0.0.1:{free_port()}"])
    return execute(validate_document(doc, overrides=done), out, quiet=True, **pace)


def assert_identical(a: Track, b: Track, agent: str) -> None:
    for name in ("t", "position", "heading", "cov", "floor", "trusted"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), f"{agent}: {name} differs"
    assert a.frame == b.frame


def test_live_tracks_equal_offline_and_replay_is_identical(tmp_path):
    run = run_live(tmp_path / "live", speed=2.0)
    tracks = run.tracks()
    assert sorted(tracks) == list(AGENTS)
    offline = offline_tracks()
    for agent in AGENTS:
        assert len(offline[agent]) >= 5, "the scenario should give several steps"
        assert_matches_offline(tracks[agent], offline[agent], agent)
    # every frame the devices sent was received and decoded into samples
    assert run.count("can", "frames") == run.sent["can"]
    assert run.count("mav", "frames") == run.sent["mavlink"]
    for sensor in ("imu_can", "imu_mav"):
        assert run.count(sensor, "bad_frames") == run.count(sensor, "incomplete_samples") == 0

    live_csv = csv_rows_by_agent(tmp_path / "live" / "ins_pose.csv")
    assert sum(map(len, live_csv.values())) == sum(len(t) for t in tracks.values())
    for name, pace in (("replay", {}), ("paced", {"realtime": True, "speed": 4.0})):
        replay = replay_logs(tmp_path / "live" / "raw", tmp_path / name, **pace)
        replayed = replay.tracks["ins.pose"]
        assert sorted(replayed) == list(AGENTS)
        for agent in AGENTS:
            assert_identical(replayed[agent], tracks[agent], agent)
        assert csv_rows_by_agent(tmp_path / name / "ins_pose.csv") == live_csv
