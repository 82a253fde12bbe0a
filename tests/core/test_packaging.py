"""Packaging: what a user installs has every data file, and a vendor package plugs in.

These tests build real packages with pip (no network: setuptools from this environment),
so they show what `pip install` would give a user or a vendor.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO

PIP = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]


def _pip(*args: str, cwd: Path | None = None) -> None:
    proc = subprocess.run([*PIP, *args], cwd=cwd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_the_wheel_ships_every_data_file(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy(REPO / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
    for pkg in ("firenav_framework", "plugins"):
        shutil.copytree(REPO / pkg, src / pkg, ignore=ignore)
    _pip("wheel", "--no-deps", "--no-build-isolation", "-w", str(tmp_path / "dist"), str(src))
    (wheel,) = (tmp_path / "dist").glob("*.whl")
    shipped = set(zipfile.ZipFile(wheel).namelist())
    expected = set()
    for pkg, installed_as in (("firenav_framework", "firenav_framework"),
                              ("plugins", "firenav_plugins")):
        for f in (src / pkg).rglob("*"):
            if f.is_file():
                expected.add(installed_as + "/" + f.relative_to(src / pkg).as_posix())
    missing = sorted(expected - shipped)
    assert not missing, f"not in the wheel: {missing}"
    assert not any(n.startswith("plugins/") for n in shipped), "generic 'plugins' name installed"


@pytest.fixture(scope="module")
def vendor_site(tmp_path_factory) -> Path:
    """The ACME vendor package and a broken one, pip-installed into an isolated folder."""
    root = tmp_path_factory.mktemp("vendor")
    site = root / "site"
    for name in ("vendor_package", "broken_vendor_package"):
        shutil.copytree(REPO / "tests" / name, root / name)
        _pip("install", "--no-deps", "--no-build-isolation", "--target", str(site),
             str(root / name))
    return site


def firenav(site: Path, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run([sys.executable, "-m", "firenav_framework", *args], env=env,
                          cwd=cwd, capture_output=True, text=True)


def test_an_installed_vendor_plugin_is_listed_and_the_broken_one_reported(vendor_site):
    out = firenav(vendor_site, "plugins", "list")
    assert out.returncode == 0, out.stderr
    row = next(ln for ln in out.stdout.splitlines() if ln.strip().startswith("acme_imu"))
    assert "acme-firenav 1.2.0" in row and "ACME AX-1 foot IMU" in row
    assert "broken-firenav: entry point 'broken = broken_firenav.plugin' failed to load: " \
           "ModuleNotFoundError" in out.stdout
    assert "csv_tracks" in out.stdout          # the other plugins still load
    show = firenav(vendor_site, "plugins", "show", "acme_imu")
    assert "gyro_bias_dps" in show.stdout and "deg/s" in show.stdout


def test_a_pipeline_runs_with_the_vendor_sensor(vendor_site, tmp_path):
    """Still ACME device, recorded in g and deg/s on FRD axes: converted by the vendor's
    sensor, the INS must report a foot at rest."""
    from firenav_framework.messages import ImuBlock
    from firenav_framework.formats.imu_csv import write_imu_csv

    n, rate = 3000, 100.0
    t = np.arange(n) / rate
    rng = np.random.default_rng(0)
    accel_g = np.tile([0.0, 0.0, -1.0], (n, 1)) + rng.normal(0, 0.002, (n, 3))  # z down
    gyro_dps = np.tile([0.3, -0.2, 0.1], (n, 1)) + rng.normal(0, 0.05, (n, 3))
    write_imu_csv(tmp_path / "still.csv", [ImuBlock.from_arrays(t, accel_g, gyro_dps,
                                                                frame="FRD")])
    (tmp_path / "p.yaml").write_text("""
name: acme
sources: [{id: rec, plugin: recording}]
sensors: [{id: acme, plugin: acme_imu, input: rec.imu, gyro_bias_dps: [0.3, -0.2, 0.1]}]
estimators: [{id: ins, plugin: zupt_ins, input: acme.imu}]
sinks: [{plugin: csv_tracks, input: ins.pose}]
""")
    out = firenav(vendor_site, "run", "p.yaml", "--input", "still.csv", "--output", "out",
                  "--quiet", cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "acme: samples 3000" in out.stdout
    rows = (tmp_path / "out" / "ins_pose.csv").read_text().splitlines()[1:]
    assert rows, "no poses"
    xy = np.array([[float(v) for v in r.split(",")[2:4]] for r in rows])
    assert np.all(np.hypot(xy[:, 0], xy[:, 1]) < 0.05)
