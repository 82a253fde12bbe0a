"""Pipelines the hardening tests run, as text."""
from __future__ import annotations

from pathlib import Path

from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import RunResult, run_pipeline


def ins_on_recording(path: Path | str, extra: str = "", timeline: str = "") -> str:
    """A recording (FLU IMU data, as the simulator writes) -> foot_imu -> zupt_ins."""
    return f"""
name: hardening
{timeline}
sources:
  - {{id: rec, plugin: recording, path: "{path}"}}
sensors:
  - {{id: imu, plugin: foot_imu, input: rec.imu}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu}}
{extra}"""


def run_text(text: str, tmp_path: Path, registry=None, **kw) -> RunResult:
    spec = load_pipeline_text(text, base_dir=tmp_path, registry=registry)
    return run_pipeline(spec, output_dir=tmp_path / "out", **kw)


def poses(result: RunResult, stream: str = "ins.pose") -> dict[str, int]:
    return {a: len(tr) for a, tr in result.tracks.get(stream, {}).items()}
