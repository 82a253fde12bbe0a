"""Is the covariance breadcrumb_gen publishes honest? Consistency on simulator seeds.

For each seed the bundled ``pipelines/breadcrumb-gen.yaml`` runs once; at every published
pose the horizontal error e against the truth gives ``chi2 = e^T C^-1 e`` with C the
pose's horizontal covariance (2 degrees of freedom: 5 % of a consistent estimate lies
beyond 5.99, 1 % beyond 9.21), and the heading error is compared with its sigma. Beside
it, per seed, the PDR track's horizontal length over the true length (the INS's
step-length scale error, which the graph does not model) and the GEN's mean error.

Run: ``.venv/bin/python benchmarks/bench_breadcrumb_consistency.py [--seeds 0-9]
[--set estimators.gen.graph.window=40 ...]``
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from firenav_framework.evaluation.metrics import path_length
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

PIPELINE = Path(__file__).resolve().parents[1] / "pipelines" / "breadcrumb-gen.yaml"
CHI2_95, CHI2_99 = 5.991, 9.210          # chi-square quantiles, 2 degrees of freedom


def seed_list(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def at(t: np.ndarray, track_t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (N, k) of a track interpolated at times ``t``."""
    return np.stack([np.interp(t, track_t, values[:, i]) for i in range(values.shape[1])], 1)


def run_seed(seed: int, overrides: list[str]) -> dict:
    spec = load_pipeline(PIPELINE, [f"sources.sim.seed={seed}", *overrides])
    with tempfile.TemporaryDirectory() as tmp:
        res = run_pipeline(spec, output_dir=Path(tmp))
    out = {}
    for agent, gen in sorted(res.tracks["gen.pose"].items()):
        truth = res.truth[agent]
        inside = (gen.t >= truth.t[0]) & (gen.t <= truth.t[-1])
        t = gen.t[inside]
        err = gen.position[inside, :2] - at(t, truth.t, truth.position[:, :2])
        cov = gen.cov[inside][:, :2, :2]
        chi2 = np.einsum("ni,nij,nj->n", err, np.linalg.inv(cov), err)
        true_heading = np.interp(t, truth.t, np.unwrap(truth.heading))
        dh = np.angle(np.exp(1j * (gen.heading[inside] - true_heading)))
        z_heading = np.abs(dh) / np.sqrt(gen.cov[inside][:, 3, 3])
        pdr = res.tracks["pdr.pose"][agent]
        true_length = path_length(at(pdr.t, truth.t, truth.position[:, :2]))
        out[agent] = {"chi2": chi2, "z_heading": z_heading, "dh": dh,
                      "horizontal": np.linalg.norm(err, axis=1),
                      "length_ratio": path_length(pdr.position[:, :2]) / true_length}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-9", help="A-B or A,B,... (default 0-9)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a value of the pipeline (repeatable)")
    args = ap.parse_args()
    print("seed agent  beyond 95 % / 99 % (pos.)  heading > 3 sigma  median |dheading|"
          "  mean error  PDR length / true")
    chi2, zh = [], []
    for seed in seed_list(args.seeds):
        for agent, r in run_seed(seed, args.set).items():
            chi2.append(r["chi2"])
            zh.append(r["z_heading"])
            print(f"{seed:4d} {agent:5s}  {np.mean(r['chi2'] > CHI2_95):10.2f} / "
                  f"{np.mean(r['chi2'] > CHI2_99):4.2f}  {np.mean(r['z_heading'] > 3):16.2f}"
                  f"  {np.degrees(np.median(np.abs(r['dh']))):14.1f} deg"
                  f"  {r['horizontal'].mean():8.2f} m  {r['length_ratio']:12.4f}", flush=True)
    c, z = np.concatenate(chi2), np.concatenate(zh)
    print(f"all: beyond the 95 % ellipse {np.mean(c > CHI2_95):.3f} (consistent: 0.05), "
          f"beyond 99 % {np.mean(c > CHI2_99):.3f} (0.01); heading beyond 2 sigma "
          f"{np.mean(z > 2):.3f} (0.046), beyond 3 sigma {np.mean(z > 3):.3f} (0.003)")


if __name__ == "__main__":
    main()
