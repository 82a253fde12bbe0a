"""The human-readable end-of-run summary (and its JSON twin)."""
from __future__ import annotations

import math

from .evaluation import error_stats, horizontal_errors
from .runner import RunResult
from .timefmt import clock_text


def summary_dict(result: RunResult) -> dict:
    tracks = {s: {a: {"poses": len(tr), "length_m": round(tr.length_m, 3)}
                  for a, tr in agents.items()} for s, agents in result.tracks.items()}
    errors = {}
    for stream, agents in result.tracks.items():
        for agent, tr in agents.items():
            truth = result.truth.get(agent)
            if truth is not None and truth.frame == tr.frame:
                errors.setdefault(stream, {})[agent] = error_stats(
                    horizontal_errors(tr, truth)[1]).as_dict()
    other_frames = sorted({t.frame for t in result.truth.values() if t.frame != "building"})
    unplaced = sorted(s for s, agents in result.tracks.items()
                      if any(tr.frame != "building" for tr in agents.values()))
    return {
        "pipeline": result.pipeline,
        "data_s": round(result.duration_s, 3),
        "wall_s": round(result.wall_s, 3),
        **result.stats.as_dict(),
        "faults": [vars(f) for f in result.faults],
        "tracks": tracks,
        "track_error": errors,
        "truth_in_other_frames": other_frames,
        "streams_not_in_building_frame": unplaced,
    }


def format_summary(result: RunResult) -> str:
    d = summary_dict(result)
    speed = d["data_s"] / d["wall_s"] if d["wall_s"] > 0 else math.inf
    lines = [f"Run summary: {d['pipeline']}: {d['data_s']:.1f} s of data in "
             f"{d['wall_s']:.2f} s ({speed:.0f}x real time)", "", "Messages per stream:"]
    width = max((len(s) for s in d["messages"]), default=10)
    lines += [f"  {s:<{width}}  {n:>9}" for s, n in d["messages"].items()] or ["  (none)"]
    lines += ["", "Skipped / bad / repaired input:"]
    counted = [(c, k, n) for c, kv in d["counts"].items() for k, n in kv.items() if k != "faults"]
    lines += [f"  {c}: {k} {n}" for c, k, n in counted] or ["  none"]
    lines += ["", "Plugin faults:"]
    lines += [f"  {f['component']} (agent '{f['agent']}', {clock_text(f['t'])}): {f['error']}; "
              f"{f['action']}" for f in d["faults"]] or ["  none"]
    lines += ["", "Tracks:"]
    lines += [f"  {s}  {a}: {v['poses']} poses, {v['length_m']:.1f} m"
              for s, agents in d["tracks"].items() for a, v in agents.items()] or ["  none"]
    if d["truth_in_other_frames"]:
        lines += ["", f"Ground truth is in the {', '.join(d['truth_in_other_frames'])} frame, "
                  "not the building frame: compare with `firenav evaluate`, which aligns "
                  "the frames first."]
    if d["streams_not_in_building_frame"] and result.truth:
        lines += ["", "Not compared with ground truth (in their own odometry frame): "
                  + ", ".join(d["streams_not_in_building_frame"])]
    if d["track_error"]:
        lines += ["", "Horizontal track error against ground truth:"]
        for s, agents in d["track_error"].items():
            for a, e in agents.items():
                lines.append(f"  {s}  {a}: RMSE {e['rmse_m']:.2f} m, mean {e['mean_m']:.2f} m, "
                             f"p95 {e['p95_m']:.2f} m, max {e['max_m']:.2f} m")
    return "\n".join(lines)
