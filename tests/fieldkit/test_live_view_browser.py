"""The commander's page in a real headless Chromium: tracks drawn, states shown.

Needs Debian's ``chromium`` (apt-get install chromium) and the ``playwright`` Python
package (pip install playwright; its own browser download is not used).
"""
from __future__ import annotations

import json
import shutil
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from firenav_framework.building import load_building, bundled_plan
from firenav_framework.messages import Diagnostic, PoseEstimate, Tick
from firenav_framework.sinks.live_view import LiveViewSink
from firenav_framework.testing import make_component

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FF1_RGB = (0xE6, 0x19, 0x4B)  # first palette colour in app.js


def _poses():
    out = []
    for k in range(60):   # ff1 walks east along y=2, ff2 walks north and then stops
        out.append(PoseEstimate(t=0.5 * k, agent="ff1", position=np.array([1.0 + 0.25 * k, 2.0, 0.0]),
                                heading=0.0, cov=np.diag([0.3, 0.1, 0.1, 0.01]), floor=0))
        out.append(PoseEstimate(t=0.5 * k, agent="ff2", position=np.array([2.0, 1.0 + 0.1 * min(k, 20), 0.0]),
                                heading=1.57, cov=np.diag([0.2, 0.2, 0.1, 0.01]), floor=0,
                                trusted=k < 50))
    return out


@pytest.fixture
def view(tmp_path):
    plan = bundled_plan("office_loop")
    building = load_building(plan)
    sink, _, _ = make_component(LiveViewSink, {"port": 0, "push_period": 0.05}, building=building,
                                output_dir=tmp_path)
    sink.start()
    yield sink
    sink.finish()


def test_state_api_serves_tracks_and_flags(view):
    for k, p in enumerate(_poses()):
        view.handle("ins.pose", p)
        if k % 2:
            view.handle("ticks", Tick(t=p.t, period=1.0))
    view.handle("can.diagnostics", Diagnostic(t=40.0, agent="ff1", device="can0/0x110",
                                              component="can", level="error",
                                              code="device_silent", text="silent"))
    state = json.loads(urllib.request.urlopen(view.url + "api/state", timeout=30).read())
    assert len(state["tracks"]["ff1"]) == 60
    assert state["tracks"]["ff1"][-1][1:3] == [15.75, 2.0]
    agents = {a["agent"]: a for a in state["agents"]}
    assert agents["ff1"]["flags"]["stale"] and not agents["ff1"]["flags"]["man_down"]
    assert agents["ff2"]["flags"]["untrusted"]
    assert state["building"]["floors"] and state["building"]["floors"][0]["walls"]
    assert any(d["code"] == "device_silent" for d in state["diagnostics"])


def test_page_draws_tracks_in_chromium(view, tmp_path):
    if CHROMIUM is None:
        pytest.skip("Chromium not installed (Debian: apt-get install -y chromium)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    from PIL import Image  # matplotlib's dependency, always present here

    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True,
                                     args=["--no-sandbox", "--disable-gpu",
                                           "--disable-background-networking"])
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 800})
            page.goto(view.url, timeout=60_000)
            page.wait_for_selector("#plan line.wall", state="attached", timeout=60_000)
            for k, p in enumerate(_poses()):
                view.handle("ins.pose", p)
                if k % 2:
                    view.handle("ticks", Tick(t=p.t, period=1.0))
            page.wait_for_function(
                "() => { const l = document.querySelector('polyline.track[data-agent=ff1]');"
                " return l && l.getAttribute('points').split(' ').length === 60; }",
                timeout=60_000)
            page.wait_for_selector("#agents li[data-agent=ff2] .badge.untrusted", timeout=60_000)
            shot = tmp_path / "view.png"
            page.screenshot(path=str(shot))
            # ff2 stopped at t=10 s; 30 s later on the timeline clock: man down
            view.handle("ticks", Tick(t=41.0, period=1.0))
            page.wait_for_selector("#agents li[data-agent=ff2] .badge.man_down", timeout=60_000)
            page.wait_for_selector("#markers circle.alarm", state="attached", timeout=60_000)
            badges = page.locator("#agents li[data-agent=ff2] .badge").all_inner_texts()
            ff1_badges = page.locator("#agents li[data-agent=ff1] .badge").all_inner_texts()
        finally:
            browser.close()
    assert "UNTRUSTED" in badges and "MAN DOWN" in badges
    assert "MAN DOWN" not in ff1_badges  # ff1 kept walking
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    track = np.all(np.abs(img - np.array(FF1_RGB)) <= 8, axis=2)
    assert track.sum() > 200, f"ff1's track colour covers only {track.sum()} pixels"
    cols = np.flatnonzero(track.any(axis=0))
    assert cols.max() - cols.min() > 100, "the track should span a good part of the map"
