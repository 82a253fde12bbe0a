"""The live view's server: Host check, token, acknowledgements over HTTP into the
incident log, the snapshot protocol (full state, then deltas)."""
from __future__ import annotations

import http.client
import json

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.messages import Diagnostic, PoseEstimate, Tick
from firenav_framework.sinks.live_view import LiveViewSink
from firenav_framework.testing import make_component

COV = np.diag([0.2, 0.2, 0.1, 0.01])


def _pose(t, agent, x, y, floor=0, trusted=True, radius=1.0):
    return PoseEstimate(t=t, agent=agent, position=np.array([x, y, 3.5 * floor]), heading=0.0,
                        cov=COV, floor=floor, trusted=trusted, protection_radius=radius)


@pytest.fixture
def view(tmp_path):
    made = []

    def make(**params):
        sink, rec, stats = make_component(LiveViewSink, {"port": 0, "push_period": 0.05,
                                                         **params},
                                          building=load_building(bundled_plan("three_storey")),
                                          output_dir=tmp_path)
        sink.start()
        made.append(sink)
        return sink, rec, stats

    yield make
    for sink in made:
        sink.finish()


def request(sink, method, path, *, host=None, body=None, headers=None):
    port = sink.server.httpd.server_address[1]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    hdrs = {"Host": host or f"127.0.0.1:{port}", **(headers or {})}
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        hdrs["Content-Type"] = "application/json"
    conn.request(method, path, body=data, headers=hdrs)
    r = conn.getresponse()
    out = r.status, dict(r.getheaders()), r.read()
    conn.close()
    return out


def test_host_header_of_another_site_is_refused(view):
    sink, _, _ = view()
    port = sink.server.httpd.server_address[1]
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}"):
        assert request(sink, "GET", "/api/building", host=host)[0] == 200, host
    # DNS rebinding: the attacker's name resolved to 127.0.0.1, the browser says its name
    for host in (f"attacker.example:{port}", "evil.localhost.example", "127.0.0.1.evil:80"):
        status, _, body = request(sink, "GET", "/api/state", host=host)
        assert status == 421 and b"DNS rebinding" in body, host
    assert sink.server.refused["host"] == 3


def test_allowed_hosts_extend_the_list(view):
    sink, _, _ = view(allowed_hosts=["kit.local"])
    assert request(sink, "GET", "/api/building", host="kit.local:8765")[0] == 200
    assert request(sink, "GET", "/api/building", host="other.local:8765")[0] == 421


def test_token_is_required_when_set_and_logs_in_by_cookie(view):
    sink, _, _ = view(token="s3cret-token")
    assert request(sink, "GET", "/")[0] == 401
    assert request(sink, "GET", "/api/state")[0] == 401
    assert request(sink, "GET", "/events")[0] == 401
    assert request(sink, "GET", "/api/state", headers={"Cookie": "firenav_view_token=wrong"})[0] == 401
    # the printed URL logs the browser in and leaves the token out of the address bar
    status, headers, _ = request(sink, "GET", "/?token=s3cret-token")
    assert status == 303 and headers["Location"] == "/"
    cookie = headers["Set-Cookie"]
    assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
    jar = cookie.split(";")[0]
    assert request(sink, "GET", "/api/state", headers={"Cookie": jar})[0] == 200
    assert request(sink, "GET", "/api/state",
                   headers={"Authorization": "Bearer s3cret-token"})[0] == 200
    # the token only logs in on the page itself, not on the data routes
    assert request(sink, "GET", "/api/state?token=s3cret-token")[0] == 401
    assert sink.server.refused["token"] == 5


def test_acknowledgement_over_http_is_recorded_and_unlatches(view):
    sink, rec, stats = view()
    t0 = 1_764_600_000.0
    for k in range(40):   # ff3 stands still on floor 1
        sink.handle("pf.pose", _pose(t0 + k, "ff3", 4.0, 2.5, floor=1))
        sink.handle("ticks", Tick(t=t0 + k, period=1.0))
    # its device goes silent: the man-down raised at 30 s stays
    sink.handle("can.diagnostics", Diagnostic(t=t0 + 40.5, agent="ff3", device="sys3/comp1",
                                              component="mav", level="error",
                                              code="device_silent", text="silent"))
    for k in range(41, 60):
        sink.handle("ticks", Tick(t=t0 + k, period=1.0))
    sink.feed.publish()
    state = json.loads(request(sink, "GET", "/api/state")[2])
    alarms = {a["condition"]: a for a in state["alarms"]}
    assert set(alarms) == {"man_down", "device_silent"}
    assert all(a["state"] == "unacknowledged" for a in alarms.values())
    md = alarms["man_down"]
    assert (md["agent"], md["floor"], md["raised_t"]) == ("ff3", 1, t0 + 30)
    # a cross-site form cannot acknowledge; bad bodies are refused with a reason
    port = sink.server.httpd.server_address[1]
    assert request(sink, "POST", "/api/ack", body={"id": md["id"]},
                   headers={"Origin": "http://attacker.example"})[0] == 403
    status, _, body = request(sink, "POST", "/api/ack", body={"id": "1; drop"})
    assert status == 400 and b"alarm number" in body
    status, _, _ = request(sink, "POST", "/api/ack", body={"id": md["id"], "by": "IC Berger"},
                           headers={"Origin": f"http://127.0.0.1:{port}"})
    assert status == 202
    sink.handle("ticks", Tick(t=t0 + 60, period=1.0))  # the pipeline takes it in
    log = [m for m in rec.on("diagnostics") if m.code.startswith("alarm")]
    assert [(m.code, m.active) for m in log] == [("alarm_man_down", True),
                                                 ("alarm_device_silent", True),
                                                 ("alarm_acknowledged", True)]
    assert "by 'IC Berger' from 127.0.0.1" in log[-1].text
    # acknowledged but the condition holds: shown muted; moving again closes it
    sink.handle("can.diagnostics", Diagnostic(t=t0 + 61, agent="ff3", device="sys3/comp1",
                                              component="mav", level="info",
                                              code="device_silent", text="", active=False))
    sink.handle("pf.pose", _pose(t0 + 62, "ff3", 9.0, 2.5, floor=1))
    sink.feed.publish()
    state = json.loads(request(sink, "GET", "/api/state")[2])
    assert [(a["condition"], a["state"]) for a in state["alarms"]] == \
        [("device_silent", "returned")]
    assert [m.code for m in rec.on("diagnostics")][-2:] == ["alarm_device_silent", "alarm_closed"]
    # the page lists alarm entries in their own category, apart from link health
    cats = {d["code"]: d["category"] for d in state["diagnostics"]}
    assert cats["alarm_man_down"] == "alarm" and cats["device_silent"] == "link"
    assert stats.counts.get(sink.ctx.id, {}).get("waits_over_bound", 0) == 0


def test_events_stream_full_state_then_deltas(view):
    sink, _, _ = view()
    sink.handle("pf.pose", _pose(5.0, "ff1", 1.0, 2.0))
    sink.feed.publish()
    port = sink.server.httpd.server_address[1]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.request("GET", "/events", headers={"Host": f"127.0.0.1:{port}"})
    r = conn.getresponse()
    assert r.status == 200 and r.getheader("Content-Type") == "text/event-stream"

    def event():
        line = r.fp.readline()
        while line in (b"\n", b": keep-alive\n"):
            line = r.fp.readline()
        assert line.startswith(b"data: ")
        r.fp.readline()
        return json.loads(line[6:])

    first = event()
    assert first["type"] == "full" and first["tracks"] == {"ff1": [[0.0, 1.0, 2.0, 0.0, 0, 0]]}
    sink.handle("pf.pose", _pose(6.5, "ff1", 1.5, 2.0, trusted=False, radius=4.0))
    sink.feed.publish()
    second = event()
    assert second["type"] == "delta" and second["seq"] == first["seq"] + 1
    assert second["tracks"] == {"ff1": [[1.5, 1.5, 2.0, 0.0, 0, 1]]}
    (agent,) = second["agents"]
    assert (agent["protection_radius"], agent["trusted"]) == (4.0, False)
    conn.close()
