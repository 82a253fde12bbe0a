"""pipelines/incident.yaml end to end on a short copy of the incident (tests/team/
incident_short.yaml, tuning seed 101, 200 particles): every method runs, team_fusion
publishes a pose for every firefighter, beats INS alone on the pooled error, keeps the
floor, and says when an input is left out; the particle filter is not trusted while
off; the commander's outputs (the live view and MAVLink out to a ground station) carry
the fused team."""
from __future__ import annotations

import json
import socket
import threading
from pathlib import Path

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import metrics_of, pooled_metrics, track_errors
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline
from firenav_framework.transports.mavlink_link import mavutil

# under a loaded machine the run can take minutes (about 20 s of CPU alone)
pytestmark = pytest.mark.timeout(900)

REPO = Path(__file__).resolve().parents[2]
SHORT = Path(__file__).with_name("incident_short.yaml")


AGENTS = ("ff1", "ff2", "ff3", "ff4")


class GroundStation:
    """A UDP port that parses every MAVLink message sent to it, on its own thread."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.messages: list = []
        self._stop = threading.Event()
        self._parser = mavutil().mavlink.MAVLink(None)
        self._parser.robust_parsing = True
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            try:
                data = self.sock.recv(65535)
            except socket.timeout:
                continue
            self.messages += [m for m in self._parser.parse_buffer(data) or []
                              if m.get_type() != "BAD_DATA"]

    def close(self):
        self._stop.set()
        self._thread.join(5.0)
        self.sock.close()


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    gcs = GroundStation()
    sinks = [{"id": "view", "plugin": "live_view", "port": 0, "input": ["team.pose"]},
             {"id": "gcs", "plugin": "mavlink_out", "url": f"udpout:127.0.0.1:{gcs.port}",
              "input": ["team.pose"], "system_ids": {a: k + 1 for k, a in enumerate(AGENTS)}}]
    spec = load_pipeline(REPO / "pipelines" / "incident.yaml",
                         [f"sources.sim.scenario={SHORT}", "sources.sim.seed=101",
                          f"sinks={json.dumps(sinks)}", "estimators.pf.particles=200"])
    try:
        result = run_pipeline(spec, output_dir=tmp_path_factory.mktemp("incident"))
        deadline = 50
        while deadline and sum(m.get_type() == "GLOBAL_POSITION_INT" for m in gcs.messages) \
                < sum(len(tr) for tr in result.tracks["team.pose"].values()):
            threading.Event().wait(0.1)
            deadline -= 1
    finally:
        gcs.close()
    result.gcs = gcs.messages
    return result


def _pooled(run, stream):
    levels = np.array([f.z for f in run.building.floors])
    errs = [track_errors(tr, run.truth[a], levels) for a, tr in run.tracks[stream].items()]
    return pooled_metrics(errs)


def test_every_method_and_the_fusion_run_for_their_crews(run):
    assert not run.faults
    agents = {"ff1", "ff2", "ff3", "ff4"}
    for stream in ("dr.pose", "pf.pose", "mm.pose", "ekf.pose", "gen.pose", "team.pose"):
        assert set(run.tracks[stream]) == agents, stream
    # the breadcrumb crew's radio ranged to its breadcrumbs and the base station
    assert run.stats.counts["gen"].get("range_thinned", 0) + \
        run.stats.counts["gen"].get("ranges_near", 0) > 0


def test_the_barometers_heights_reach_team_fusion_for_the_crews_wearing_one(run):
    # crews A and B wear barometers, crew C (ff4) does not: the heights, zeroed at the
    # entrance, arrive and are kept for the floor vote; none is refused
    assert run.stats.messages["baro.height"] > 0
    team = run.components["team"]
    for agent in ("ff1", "ff2", "ff3"):
        baro = team.state[agent].baro
        assert baro is not None, agent
        truth = run.truth[agent]
        z = float(np.interp(baro.t, truth.t, truth.position[:, 2]))
        assert abs(baro.height - z) < 1.5, agent       # the floor's level to within a storey's half
    assert team.state["ff4"].baro is None
    assert "bad_heights" not in run.stats.counts["team"]


def test_team_fusion_beats_ins_alone_and_keeps_the_floor(run):
    team, ins = _pooled(run, "team.pose"), _pooled(run, "dr.pose")
    assert team.rmse_m < ins.rmse_m
    assert team.p95_m < ins.p95_m
    assert team.floor_accuracy >= 0.98
    # every fused pose has a finite protection radius and trusted follows it
    for tr in run.tracks["team.pose"].values():
        assert np.all(np.isfinite(tr.protection_radius))
        assert not np.any(tr.trusted & (tr.protection_radius > 3.0))


def test_the_incidents_particle_filter_is_never_confidently_wrong(run):
    # The PF of pipelines/incident.yaml runs with the field rules (walls that may be wrong,
    # look-alike jumps and plan contradictions untrusted, a drift spread for the incident's
    # uncalibrated INS). Without them (fe62e04's settings) on this run it was trusted while
    # more than 3 m off 23 % (ff1) and 24 % (ff2) of the time, and its pooled RMSE only 17 %
    # under INS alone's; the goals are <= 2 % in every track and >= 30 % better.
    levels = np.array([f.z for f in run.building.floors])
    for agent, track in run.tracks["pf.pose"].items():
        m = metrics_of(track_errors(track, run.truth[agent], levels))
        assert m.trusted_off_fraction <= 0.02, (agent, m.trusted_off_fraction)
    assert _pooled(run, "pf.pose").rmse_m <= 0.7 * _pooled(run, "dr.pose").rmse_m


def test_the_ground_station_gets_every_fused_pose_of_every_firefighter(run):
    team = run.tracks["team.pose"]
    georef = run.building.georef
    fixes = [m for m in run.gcs if m.get_type() == "GLOBAL_POSITION_INT"]
    for k, agent in enumerate(AGENTS):
        mine = [m for m in fixes if m.get_srcSystem() == k + 1]
        track = team[agent]
        assert len(mine) == len(track), agent
        # WGS84 of the fused positions (not of any single method's) through the plan's georef
        lonlat = georef.to_wgs84(track.position)[:, :2]
        got = np.array([[m.lon * 1e-7, m.lat * 1e-7] for m in mine])
        np.testing.assert_allclose(got, lonlat, atol=1.5e-7)
        assert [m.time_boot_ms for m in mine] == [int(t * 1000) for t in track.t]
    assert {m.get_srcSystem() for m in run.gcs if m.get_type() == "HEARTBEAT"} == {1, 2, 3, 4}


def test_the_live_view_shows_the_fused_team(run):
    view = run.components["view"]
    state = json.loads(b"".join(view.feed.snapshot.full_parts()))
    team = run.tracks["team.pose"]
    agents = {a["agent"]: a for a in state["agents"]}
    assert set(agents) == set(AGENTS) == set(state["tracks"])
    for agent in AGENTS:
        track, shown = team[agent], agents[agent]
        # the last fused pose (the view rounds to millimetres), its radius and trust flag
        assert (shown["x"], shown["y"]) == pytest.approx(tuple(track.position[-1, :2]), abs=6e-4)
        assert shown["protection_radius"] == pytest.approx(track.protection_radius[-1], abs=6e-4)
        assert shown["trusted"] == bool(track.trusted[-1])
        # the whole fused track: one point (t - t0, x, y, z, floor, untrusted) per pose
        rows = np.array(state["tracks"][agent], float)
        assert len(rows) == len(track)
        np.testing.assert_allclose(rows[:, 1:3], track.position[:, :2], atol=6e-4)
        np.testing.assert_array_equal(rows[:, 5], (~track.trusted).astype(float))
