"""A live incident on the commander's page in a real headless Chromium.

Three firefighters in the three-storey plan on a live link's clock (UNIX seconds): ff1
searches the ground floor, ff2 the first, ff3 climbs to the second floor and stops
there. After 30 s without motion ff3's man-down is raised; then ff3's device goes
silent: the alarm stays latched (silence never clears it), the page brings the second
floor forward, and the commander acknowledges it in the page. Every alarm and the
acknowledgement go to the incident log (``diagnostics_log`` and ``mcap_recorder``
wired to the view's diagnostics as a pipeline does). Screenshots a person would read
are written to the test folder (with ``FIRENAV_DOCS_SCREENSHOTS=1`` also to
``docs/images/``, as committed).

Needs Debian's ``chromium`` (apt-get install chromium) and the ``playwright`` Python
package (pip install playwright; its own browser download is not used).
"""
from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.messages import Diagnostic, PoseEstimate, Tick
from firenav_framework.sinks.diagnostics_log import DiagnosticsLogSink
from firenav_framework.sinks.live_view import LiveViewSink
from firenav_framework.sinks.mcap_recorder import McapRecorderSink
from firenav_framework.testing import make_component
from firenav_framework.timefmt import wall_text

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DOCS_IMAGES = Path(__file__).resolve().parents[2] / "docs" / "images"
T0 = 1_764_601_200.0  # the live link's clock: UNIX seconds
FF1_RGB = (0xE6, 0x19, 0x4B)  # first palette colour in app.js (agents in name order)
COV = np.diag([0.25, 0.2, 0.05, 0.01])
WAIT_MS = 60_000


def there_and_back(k: int, n: int) -> int:
    """0, 1, ..., n, n - 1, ..., 0, 1, ...: steps along a corridor and back."""
    return n - abs(k % (2 * n) - n)


def walk(k: int) -> list[PoseEstimate]:
    """The three firefighters' poses at second k (one per second)."""
    ff1 = (2.0 + 0.8 * there_and_back(k, 30), 6.5, 0.0, 0)    # the ground corridor
    ff2 = (24.0 - 0.5 * there_and_back(k, 36), 6.5, 3.5, 1)   # the first-floor corridor
    if k < 12:
        ff3 = (8.0 + 0.5 * k, 6.5, 7.0, 2)                # walks, then stops in office 2.S3
    else:
        ff3 = (14.0, 3.0, 7.0, 2)
    out = []
    for agent, (x, y, z, floor), trusted, radius in (
            ("ff1", ff1, True, 1.2), ("ff2", ff2, k < 25, 1.5 if k < 25 else 4.5),
            ("ff3", ff3, True, 1.8)):
        out.append(PoseEstimate(t=T0 + k, agent=agent, position=np.array([x, y, z]),
                                heading=0.0, cov=COV, floor=floor, trusted=trusted,
                                protection_radius=radius))
    return out


def quantised_copy(src: Path, dst: Path) -> None:
    """A small PNG for the docs (256 colours, no dithering: the firefighters' colours
    stay theirs)."""
    from PIL import Image
    dst.parent.mkdir(parents=True, exist_ok=True)
    img = Image.open(src).convert("RGB")
    img.quantize(colors=256, method=Image.Quantize.MAXCOVERAGE,
                 dither=Image.Dither.NONE).save(dst, optimize=True)


@pytest.fixture
def incident(tmp_path):
    building = load_building(bundled_plan("three_storey"))
    view, rec, _ = make_component(LiveViewSink, {"port": 0, "push_period": 0.05},
                                  building=building, output_dir=tmp_path, cid="view")
    log, _, _ = make_component(DiagnosticsLogSink, {}, output_dir=tmp_path, cid="log")
    mcap, _, _ = make_component(McapRecorderSink, {}, building=building,
                                output_dir=tmp_path, cid="mcap")
    for s in (view, log, mcap):
        s.start()
    logged = [0]

    def feed(stream, msg):
        """One message to the view, and what the view published to the incident log."""
        view.handle(stream, msg)
        mcap.handle(stream, msg)
        for d in rec.on("diagnostics")[logged[0]:]:
            log.handle("view.diagnostics", d)
            mcap.handle("view.diagnostics", d)
        logged[0] = len(rec.on("diagnostics"))

    done = []

    def close():
        """The end of the run: every sink finishes (the MCAP file gets its summary)."""
        if not done:
            done.append(True)
            for s in (view, log, mcap):
                s.finish()

    yield view, feed, close, tmp_path
    close()


def test_live_incident_in_chromium(incident):
    if CHROMIUM is None:
        pytest.skip("Chromium not installed (Debian: apt-get install -y chromium)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    from PIL import Image  # matplotlib's dependency, always present here

    view, feed, close, out = incident
    shots = {}
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True,
                                     args=["--no-sandbox", "--disable-gpu",
                                           "--disable-background-networking"])
        try:
            # no blinking in the screenshots (the page honours reduced motion)
            page = browser.new_page(viewport={"width": 1280, "height": 760},
                                    reduced_motion="reduce")
            page.goto(view.url, timeout=WAIT_MS)
            page.wait_for_selector("#plan line.wall", state="attached", timeout=WAIT_MS)
            for k in range(20):  # the timeline's tick of each second, then its poses
                feed("ticks", Tick(t=T0 + k, period=1.0))
                for p in walk(k):
                    feed("pf.pose", p)
            for k in range(12):  # link health chatter that must not bury an alarm
                feed("can.diagnostics", Diagnostic(t=T0 + 19.5, component="can", level="info",
                                                   code="link_health", text=f"can0: {k} ok"))
            page.wait_for_selector("#agents li[data-agent=ff3]", timeout=WAIT_MS)
            # the plan as drawn: rooms named, stairs, the entrance, scale bar, true north
            page.click("#floors button[data-floor='0']")
            page.wait_for_selector("#labels text.room-name", state="attached", timeout=WAIT_MS)
            names = page.locator("#labels text.room-name").all_text_contents()
            assert "entrance lobby" in names and "corridor" in names
            assert page.locator("#plan [data-stair=stair01]").count() >= 1
            assert page.locator("#plan [data-entrance=main]").count() == 1
            assert page.locator("#scale text").all_text_contents()[-1].endswith(" m")
            north = page.locator("#north")
            assert "true north" in north.text_content()
            # plan +y is 20 deg clockwise of north: north is drawn turned 20 deg anticlockwise
            assert float(north.get_attribute("data-bearing")) == pytest.approx(-20.0, abs=0.2)
            # firefighters on their floors: the ground floor shows ff1 only
            assert page.locator("#markers circle.marker").evaluate_all(
                "els => els.map(e => e.dataset.agent)") == ["ff1"]
            counts = page.locator("#floors button .n").all_text_contents()
            assert counts == ["(1)", "(1)", "(1)"]
            shots["plan"] = out / "live-view-plan.png"
            page.screenshot(path=str(shots["plan"]))
            # ff2's poses are untrusted from k=25: marked, with its protection radius drawn
            for k in range(20, 47):
                feed("ticks", Tick(t=T0 + k, period=1.0))
                for p in walk(k):
                    feed("pf.pose", p)
            # ff3 stopped at k=12: man down at k=42; the page brings the second floor forward
            page.wait_for_selector("#alarms li.unacknowledged[data-agent=ff3]", timeout=WAIT_MS)
            page.wait_for_function("() => document.querySelector('#floors button.active')"
                                   ".dataset.floor === '2'", timeout=WAIT_MS)
            # ... and ff3's device goes silent: still latched, a second alarm beside it
            feed("mav.diagnostics", Diagnostic(t=T0 + 47.5, agent="ff3", device="sys3/comp1",
                                               component="mav", level="error",
                                               code="device_silent", text="no frames for 2 s"))
            for k in range(48, 80):   # 30 s of silence
                feed("ticks", Tick(t=T0 + k, period=1.0))
                for p in walk(k)[:2]:
                    feed("pf.pose", p)
            page.wait_for_selector("#alarms li[data-agent=ff3] >> text=DEVICE SILENT",
                                   timeout=WAIT_MS)
            first = page.locator("#alarms li").first
            assert first.get_attribute("data-agent") == "ff3"
            titles = page.locator("#alarms li .what").all_text_contents()
            assert "ff3 MAN DOWN" in titles and "ff3 DEVICE SILENT" in titles
            assert "ff2 POSITION UNTRUSTED" in titles
            # alarms stand apart from link health: hidden by default, counted
            assert page.locator("#diagnostics li.link").count() == 0
            assert "13 hidden" in page.inner_text("#link-hidden")  # 12 + the device_silent report
            assert page.locator("#diagnostics li.alarm").count() >= 3
            # no UNIX seconds anywhere a person reads
            body = page.inner_text("body")
            assert str(int(T0))[:4] not in body, "epoch seconds on the page"
            assert f"since {wall_text(T0 + 42)}" in page.inner_text("#alarms")
            page.click("#floors button[data-floor='1']")
            radius = page.locator("#markers circle.protection.untrusted[data-agent=ff2]")
            assert float(radius.get_attribute("r")) == pytest.approx(4.5)
            assert page.locator("#markers circle.marker.untrusted[data-agent=ff2]").count() == 1
            page.click("#floors button[data-floor='2']")
            page.wait_for_timeout(300)
            shots["alarm"] = out / "live-view-alarm.png"
            page.screenshot(path=str(shots["alarm"]))
            # the commander acknowledges the man-down in the page
            page.fill("#operator", "IC Berger")
            man_down = page.locator("#alarms li", has_text="MAN DOWN")
            man_down.locator("button.ack").click()
            for k in range(80, 83):  # the pipeline takes the acknowledgement in at its tick
                feed("ticks", Tick(t=T0 + k, period=1.0))
                time.sleep(0.2)
            page.wait_for_selector("#alarms li.acknowledged[data-agent=ff3]", timeout=WAIT_MS)
            shots["acknowledged"] = out / "live-view-acknowledged.png"
            page.screenshot(path=str(shots["acknowledged"]))
            states = page.locator("#alarms li").evaluate_all(
                "els => els.map(e => [e.querySelector('.what').textContent, e.className])")
        finally:
            browser.close()
    close()
    # acknowledged, but ff3 is still silent and unseen: shown, muted, below the others
    assert states[-1] == ["ff3 MAN DOWN", "acknowledged"]
    assert ["ff3 DEVICE SILENT", "unacknowledged"] in states
    # what the page showed: ff1's track in its colour across a good part of the map
    img = np.asarray(Image.open(shots["plan"]).convert("RGB")).astype(int)
    track = np.all(np.abs(img - np.array(FF1_RGB)) <= 8, axis=2)
    assert track.sum() > 200, f"ff1's track colour covers only {track.sum()} pixels"
    cols = np.flatnonzero(track.any(axis=0))
    assert cols.max() - cols.min() > 200, "the track should span a good part of the map"
    alarm = np.asarray(Image.open(shots["alarm"]).convert("RGB")).astype(int)
    red = np.all(np.abs(alarm - np.array([0xDD, 0x00, 0x00])) <= 40, axis=2)
    assert red[:, 900:].sum() > 2000, "the alarm list is not red"
    # the incident log: diagnostics.jsonl with the local clock and the wall clock ...
    lines = [json.loads(ln) for ln in (out / "diagnostics.jsonl").read_text().splitlines()]
    codes = [(ln["code"], ln["agent"]) for ln in lines]
    assert codes.index(("alarm_man_down", "ff3")) < codes.index(("alarm_device_silent", "ff3")) \
        < codes.index(("alarm_acknowledged", "ff3"))
    ack = lines[codes.index(("alarm_acknowledged", "ff3"))]
    assert "MAN DOWN" in ack["text"] and "by 'IC Berger' from 127.0.0.1" in ack["text"]
    raised = lines[codes.index(("alarm_man_down", "ff3"))]
    assert raised["when"].endswith(wall_text(T0 + 42)) and raised["wall"][:2] == "20"
    assert not any(c == ("alarm_man_down", "ff3") and not ln["active"]
                   for c, ln in zip(codes, lines)), "silence cleared the man-down"
    # ... and the MCAP file
    from mcap.reader import make_reader
    with open(out / "fused.mcap", "rb") as fh:
        logged = [json.loads(m.data) for _, ch, m in make_reader(fh).iter_messages()
                  if ch.topic == "/incident_log"]
    assert [e["code"] for e in logged if e["agent"] == "ff3"][:3] == \
        ["alarm_man_down", "alarm_device_silent", "alarm_acknowledged"]
    assert all(e["wall"][:2] == "20" and e["when"] for e in logged)
    if os.environ.get("FIRENAV_DOCS_SCREENSHOTS"):
        for name, path in shots.items():
            quantised_copy(path, DOCS_IMAGES / path.name)
