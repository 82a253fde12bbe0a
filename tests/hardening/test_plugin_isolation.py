"""One plugin's hang, exit, interrupt or in-place change costs only that plugin."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import run_pipeline

from tests.core.toys import toy_registry
from tests.hardening.rogues import RogueEstimator
from tests.hardening.vendor import REPO, make_dist

REG = toy_registry()
REG.add(RogueEstimator, package="rogues")
STEPS = [[float(t), a, 1.0] for t in range(1, 11) for a in ("ff1", "ff2")]


def pipeline(mode: str, watchdog: float = 0.3, extra: str = "") -> str:
    return f"""
sources: [{{id: src, plugin: script, steps: {json.dumps(STEPS)}}}]
estimators:
  - {{id: rogue, plugin: rogue, input: src.odo, mode: {mode}, watchdog: {watchdog}{extra}}}
  - {{id: other, plugin: integrate, input: src.odo}}
sinks: [{{id: keep, plugin: collect, input: "*.pose"}}]
"""


def run(text: str, tmp_path):
    spec = load_pipeline_text(text, registry=REG, base_dir=tmp_path)
    return run_pipeline(spec, output_dir=tmp_path)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("mode, error", [
    ("hang", "PluginTimeout: handle of 'rogue' did not return within 0.3 s (watchdog)"),
    ("sleep", "PluginTimeout: handle of 'rogue' did not return within 0.3 s (watchdog)"),
    ("exit", "SystemExit: rogue wants out"),
    ("interrupt", "KeyboardInterrupt"),
])
def test_a_hang_exit_or_interrupt_costs_only_that_plugin_and_that_firefighter(
        tmp_path, mode, error):
    res = run(pipeline(mode), tmp_path)
    (fault,) = res.faults
    assert (fault.component, fault.agent, fault.t) == ("rogue", "ff1", 3.0)
    assert fault.error.startswith(error) and fault.action == "disabled for agent 'ff1'"
    assert len(res.tracks["rogue.pose"]["ff1"]) == 2           # steps 1 and 2, then disabled
    assert len(res.tracks["rogue.pose"]["ff2"]) == 10          # the other firefighter: all
    assert len(res.tracks["other.pose"]["ff1"]) == 10          # the other plugin: all
    assert res.stats.counts["rogue"]["skipped_after_fault"] == 7


@pytest.mark.timeout(60)
def test_the_disable_policy_takes_a_hung_plugin_out_entirely(tmp_path):
    res = run(pipeline("hang", extra=", on_error: disable"), tmp_path)
    assert [f.action for f in res.faults] == ["disabled"]
    assert len(res.tracks["rogue.pose"]["ff2"]) == 2           # nothing after the hang
    assert len(res.tracks["other.pose"]["ff2"]) == 10


def test_a_plugin_cannot_change_what_the_others_receive(tmp_path):
    res = run(pipeline("mutate"), tmp_path)
    (fault,) = res.faults
    assert fault.error.startswith("ValueError: assignment destination is read-only")
    other = res.tracks["other.pose"]["ff1"]
    np.testing.assert_array_equal(other.position[:, 0], np.arange(1.0, 11.0))  # untouched


def test_a_plugin_publishing_for_an_agent_it_never_received_is_reported(tmp_path):
    res = run(pipeline("relabel"), tmp_path)
    assert res.stats.counts["rogue"]["agent_relabelled"] == 8   # steps 3..10 of ff1
    (diag,) = [d for d in res.diagnostics if d.code == "agent_relabelled"]
    assert "'rogue' published a PoseEstimate of agent 'ghost'" in diag.text
    assert "received data only of ff1, ff2" in diag.text
    assert "other" not in res.stats.counts or "agent_relabelled" not in res.stats.counts["other"]


def test_a_plugin_publishing_one_firefighters_device_as_another_is_reported(tmp_path):
    res = run(pipeline("swap"), tmp_path)
    assert res.stats.counts["rogue"]["agent_relabelled"] == 8
    (diag,) = [d for d in res.diagnostics if d.code == "agent_relabelled"]
    assert "of agent 'ff2' but has received device 'ff1/imu' of another firefighter" in diag.text


@pytest.mark.timeout(60)
def test_ctrl_c_stops_the_run_cleanly_even_while_a_plugin_hangs(tmp_path):
    """A real SIGINT is no plugin's KeyboardInterrupt: the run stops, what arrived is used,
    and only the call that does not return within the grace is cut short."""
    import threading
    from firenav_framework.runner import Runner
    spec = load_pipeline_text(pipeline("sleep", watchdog=0), registry=REG, base_dir=tmp_path)
    timer = threading.Timer(0.5, signal.pthread_kill, (threading.main_thread().ident,
                                                        signal.SIGINT))
    timer.start()
    res = Runner(spec, output_dir=tmp_path).run()
    (fault,) = res.faults
    assert fault.error == ("PluginInterrupted: handle of 'rogue' did not return within 2 s "
                           "of the request to stop") and fault.action == "disabled"
    # reading stops at the request; what had entered the timeline is delivered
    assert len(res.tracks["other.pose"]["ff1"]) >= 3


# -- the command line: SIGTERM and code that cannot be interrupted ------------------------

@pytest.fixture(scope="module")
def site(tmp_path_factory):
    site = tmp_path_factory.mktemp("rogue_site")
    make_dist(site, "rogue-plugins", {}, {"firenav.plugins": {
        "estimator.rogue": "tests.hardening.rogues:RogueEstimator",
        "estimator.integrate": "tests.core.toys:Integrate",
        "source.script": "tests.core.toys:ScriptSource"}})
    return site


def start_run(site, tmp_path, mode: str, watchdog: float) -> subprocess.Popen:
    marker = tmp_path / "marker"
    path = tmp_path / "p.yaml"
    path.write_text(f"watchdog: {watchdog}\n" + pipeline(mode, watchdog, extra=f", marker: '{marker}'")
                    .replace('sinks: [{id: keep, plugin: collect, input: "*.pose"}]',
                             'sinks: [{plugin: csv_tracks, input: "*.pose"}]'))
    env = {"PYTHONPATH": f"{site}:{REPO}", "PATH": "/usr/bin:/bin"}
    return subprocess.Popen([sys.executable, "-m", "firenav_framework", "run", str(path),
                             "--quiet", "--output", str(tmp_path / "out")], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for(path, proc, timeout=60.0) -> None:
    t0 = time.monotonic()
    while not path.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < timeout, "the plugin never started misbehaving"
        time.sleep(0.05)


@pytest.mark.timeout(120)
def test_sigterm_ends_a_run_whose_plugin_hangs_cleanly(site, tmp_path):
    proc = start_run(site, tmp_path, "hang", watchdog=0)    # no watchdog: only SIGTERM
    wait_for(tmp_path / "marker", proc)
    time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err                       # ended, with the plugin's fault
    assert "PluginInterrupted: handle of 'rogue' did not return within 2 s of the request " \
           "to stop; disabled" in out
    assert "other.pose  ff1" in out                        # the summary was written
    assert (tmp_path / "out" / "summary.json").is_file()
    assert (tmp_path / "out" / "other_pose.csv").read_text().count("\n") >= 3


@pytest.mark.timeout(120)
@pytest.mark.parametrize("mode", ["regex", "swallow"])
def test_a_call_that_cannot_be_interrupted_ends_the_process_instead_of_freezing_it(
        site, tmp_path, mode):
    # the pipeline's watchdog (every plugin) is 0.2 s: the process ends within
    # HARD_EXIT_FACTOR limits (+ 1 s) of the deadline even when the watchdog is starved
    proc = start_run(site, tmp_path, mode, watchdog=0.2)
    out, err = proc.communicate(timeout=90)
    assert proc.returncode == 1, err
    assert "handle of 'rogue' did not return within 0.2 s" in err or \
        "Timeout" in err, err                              # faulthandler or the watchdog
    assert "rogues.py" in err                              # where it was stuck
