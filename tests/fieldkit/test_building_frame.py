"""The bundled field pipeline in the building frame, live: pipelines/field-building.yaml.

Four firefighters go in by the main entrance of the three-storey office (data/
field_building.yaml), played as devices onto the pipeline's CAN and MAVLink links; their
barometers and the reference at the entrance send lines to its UDP port. The particle
filter places everyone in the building from the entrance; the ground station gets
their WGS84 positions through the plan's georeference; the MCAP file and the incident
log are written.
"""
from __future__ import annotations

import json
import socket
import threading
import time

import numpy as np

from firenav_framework.codecs.baro_lines import BaroLinesCodec, BaroReading
from firenav_framework.runner import Runner

from .harness import AGENTS, REPO, run_live, simulation

PIPELINE = REPO / "pipelines" / "field-building.yaml"
SCENARIO = REPO / "tests" / "fieldkit" / "data" / "field_building.yaml"
P_ENTRANCE = 101_325.0                         # Pa at the entrance level
OFFSETS = {"ff1": 60.0, "ff2": -45.0, "ff3": 20.0, "ff4": -90.0}   # Pa, each sensor's own


class Barometers:
    """Every barometer's lines at 10 Hz (the reference at 1 Hz) to the pipeline's UDP
    port, until stopped: all on the ground floor, each with its own sensor offset."""

    def __init__(self):
        self.stop = threading.Event()
        self.sent = 0

    def __call__(self, runner: Runner) -> None:
        port = runner.components["baro_link"].link.port
        threading.Thread(target=self._run, args=(port,), daemon=True).start()

    def _run(self, port: int) -> None:
        codec = BaroLinesCodec()
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        rng = np.random.default_rng(11)
        k = 0
        while not self.stop.is_set() and k < 20_000:
            readings = [BaroReading(0.0, f"{a}/baro", P_ENTRANCE + off + rng.normal(0, 2.0))
                        for a, off in OFFSETS.items()]
            if k % 10 == 0:
                readings.append(BaroReading(0.0, "base/baro", P_ENTRANCE, 293.15))
            for f in codec.encode(readings):
                sock.sendto(f.data + b"\n", ("127.0.0.1", port))
                self.sent += 1
            k += 1
            time.sleep(0.1)
        sock.close()


def test_field_kit_in_the_building_frame(tmp_path):
    baro = Barometers()
    try:
        run = run_live(tmp_path, pipeline=PIPELINE, scenario=SCENARIO, during=baro,
                       extra_overrides=("sinks.foxglove_live.port=0",
                                        "sources.baro_link.bind=127.0.0.1:0",
                                        "sensors.baro.calibrate_s=2"))
    finally:
        baro.stop.set()
    result = run.result
    assert not result.faults, result.faults
    sim = simulation(SCENARIO)
    building = result.building
    pf = result.tracks["pf.pose"]
    assert set(pf) == set(AGENTS)
    for agent in AGENTS:
        track = pf[agent]
        truth = sim.truth[agent]
        # in the building frame, on the ground floor, inside the building
        assert track.frame == "building" and set(track.floor) == {0}
        assert building.floor(0).inside(track.position[:, :2]).all(), agent
        # where the firefighter really is at the end of the walk (the device times are
        # on the receive clock: compare the last poses with the end of the truth)
        end = truth.position[-1, :2]
        assert np.hypot(*(track.position[-1, :2] - end)) < 1.5, agent
    # the ground station places them on the Earth: GLOBAL_POSITION_INT near the plan's
    # georeference, a type it lists, the origin of the local frame
    fixes = [m for m in run.gcs if m.get_type() == "GLOBAL_POSITION_INT"]
    assert len(fixes) == sum(len(t) for t in pf.values())
    ref = building.georef
    for m in fixes:
        assert abs(m.lat / 1e7 - ref.lat) < 3e-4 and abs(m.lon / 1e7 - ref.lon) < 4e-4
    assert any(m.get_type() == "GPS_GLOBAL_ORIGIN" for m in run.gcs)
    # the incident log and the MCAP file are written; the barometers were zeroed at the
    # entrance level and their heights (recorded in the MCAP file) are the ground floor's
    log = [json.loads(ln) for ln in (tmp_path / "diagnostics.jsonl").read_text().splitlines()]
    assert {ln["agent"] for ln in log if ln["code"] == "baro_zeroed"} == set(AGENTS)
    from mcap.reader import make_reader
    with open(tmp_path / "fused.mcap", "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        heights = [json.loads(m.data) for _, ch, m in reader.iter_messages()
                   if ch.topic.startswith("/baro.height/")]
    topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert topics["/pf.pose/ff1/fix"] == "foxglove.LocationFix"
    assert topics["/building"] == "foxglove.SceneUpdate"
    assert topics["/baro.height/ff3"] == "firenav.PressureHeight"
    assert {h["agent"] for h in heights} == set(AGENTS)
    assert all(abs(h["height"]) < 3 * h["sigma"] and h["sigma"] < 1.0 for h in heights)
