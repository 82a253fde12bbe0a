"""Installed packages: built-in names protected, bad imports contained with a time limit."""
from __future__ import annotations

import importlib.metadata as md

import pytest

from firenav_framework.registry import load_registry
from firenav_framework.safe_import import PluginImportError, import_object

from tests.hardening.vendor import firenav, make_dist

SHADOW = """
from firenav_plugins.estimators.zupt_ins import ZuptInsEstimator
from firenav_plugins.sensors.foot_imu import FootImuSensor

class AcmeZupt(ZuptInsEstimator):
    '''ACME's own ZUPT INS (publishes nothing: easy to tell apart).'''
    def handle(self, stream, msg):
        self.ctx.count("acme_handled")

class AcmeFootImu(FootImuSensor):
    '''ACME's foot IMU.'''
"""

PIPELINE = """
sources: [{id: sim, plugin: simulator, scenario: demo, duration: 8}]
sensors: [{id: imu, plugin: foot_imu, input: sim.imu}]
estimators: [{id: ins, plugin: ZUPT, input: imu.imu}]
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """One "site-packages" with a package shadowing two built-ins and three that break at
    import: by raising SystemExit, by raising KeyboardInterrupt, by hanging."""
    site = tmp_path_factory.mktemp("site")
    make_dist(site, "acme-firenav", {"acme_shadow": SHADOW}, {"firenav.plugins": {
        "estimator.zupt_ins": "acme_shadow:AcmeZupt",
        "sensor.foot_imu": "acme_shadow:AcmeFootImu"}})
    make_dist(site, "exit-firenav", {"exit_hooks": "import sys\nsys.exit(3)\n"},
              {"firenav": {"exit": "exit_hooks"}})
    make_dist(site, "ctrlc-firenav", {"ctrlc_hooks": "raise KeyboardInterrupt\n"},
              {"firenav": {"ctrlc": "ctrlc_hooks"}})
    make_dist(site, "hang-firenav", {"hang_hooks": "import time\ntime.sleep(600)\n"},
              {"firenav": {"hang": "hang_hooks"}})
    return site


def write_pipeline(tmp_path, zupt: str):
    path = tmp_path / "p.yaml"
    path.write_text(PIPELINE.replace("ZUPT", zupt))
    return path


@pytest.mark.timeout(120)
def test_packages_that_exit_interrupt_or_hang_at_import_cost_only_themselves(site):
    out = firenav(site, "plugins", "list", env={"FIRENAV_IMPORT_TIMEOUT": "4"})
    assert out.returncode == 0, out.stderr
    assert "zupt_ins" in out.stdout and "particle_filter" in out.stdout  # built-ins listed
    problems = out.stdout.split("problems while loading plugins:")[1]
    assert "exit-firenav: entry point 'exit = exit_hooks' failed to load: SystemExit: 3" in problems
    assert "ctrlc-firenav: entry point 'ctrlc = ctrlc_hooks' failed to load: KeyboardInterrupt" \
        in problems
    assert "hang-firenav: entry point 'hang = hang_hooks' failed to load: did not finish " \
           "within 4 s" in problems


@pytest.mark.timeout(120)
def test_the_import_limit_never_costs_a_builtin_plugin(site, tmp_path):
    """A limit far below any real import (10 ms) skips the vendors' packages, hanging or
    not, but the pipeline's built-in simulator, foot IMU and INS still load: a busy
    machine must not lose firenav's own plugins."""
    out = firenav(site, "validate", str(write_pipeline(tmp_path, "zupt_ins")),
                  env={"FIRENAV_IMPORT_TIMEOUT": "0.01"})
    assert out.returncode == 0, out.stderr
    assert "hang_hooks: did not finish within 0.01 s" in out.stderr
    assert "firenav_framework.sources.simulator" not in out.stderr


@pytest.mark.timeout(120)
def test_a_package_cannot_silently_replace_a_builtin_and_pinning_chooses_it(site, tmp_path):
    env = {"FIRENAV_IMPORT_TIMEOUT": "4"}  # the vendor's tiny package imports well within it
    out = firenav(site, "validate", str(write_pipeline(tmp_path, "zupt_ins")), env=env)
    assert out.returncode == 0, out.stderr
    assert "p.yaml:4:" in out.stderr and "'zupt_ins' is also offered by acme-firenav; " \
        "firenav's is used (write 'zupt_ins@<package>' to choose another)" in out.stderr
    assert "'foot_imu' is also offered by acme-firenav" in out.stderr
    assert "zupt_ins             in: imu.imu" in out.stdout           # the built-in
    # pinned: the run uses ACME's class (it counts, and publishes no poses)
    pinned = write_pipeline(tmp_path, "zupt_ins@acme-firenav")
    out = firenav(site, "validate", str(pinned), env=env)
    assert out.returncode == 0 and "zupt_ins@acme-firenav" in out.stdout, out.stderr
    out = firenav(site, "run", str(pinned), "--quiet", "--output", str(tmp_path / "o"), env=env)
    assert out.returncode == 0, out.stderr
    assert "ins: acme_handled" in out.stdout and "ins.pose" not in out.stdout
    out = firenav(site, "validate", str(write_pipeline(tmp_path, "zupt_ins@nobody")), env=env)
    assert out.returncode == 2
    assert "no package 'nobody' offers estimator plugin 'zupt_ins'; offered by firenav, " \
           "acme-firenav" in out.stderr


def test_the_shadowing_package_is_not_even_imported_unless_pinned(tmp_path, monkeypatch):
    (tmp_path / "never_imported.py").write_text("raise RuntimeError('imported!')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    builtin = next(ep for ep in md.entry_points(group="firenav.plugins")
                   if ep.name == "estimator.zupt_ins")
    shadow = md.EntryPoint(name="estimator.zupt_ins", value="never_imported:X",
                           group="firenav.plugins")
    reg = load_registry([builtin, shadow])
    assert reg.get("estimator", "zupt_ins").package == "firenav"
    assert reg.offered_by("estimator", "zupt_ins") == ["never_imported"]
    assert not any("imported!" in e for e in reg.errors)
    assert reg.get("estimator", "zupt_ins", package="never_imported") is None
    assert any("RuntimeError: imported!" in e for e in reg.errors)


@pytest.mark.timeout(30)
def test_a_hanging_import_times_out_and_is_not_retried(tmp_path, monkeypatch):
    (tmp_path / "slow_mod.py").write_text("import time\ntime.sleep(60)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(PluginImportError, match="did not finish within 0.3 s"):
        import_object("slow_mod:X", timeout=0.3)
    with pytest.raises(PluginImportError, match="hung at import earlier"):
        import_object("slow_mod:X", timeout=0.3)
