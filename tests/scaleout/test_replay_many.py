"""`firenav replay` of a folder of incidents on local workers: each incident's own
outputs, one table across them, and a broken incident costs the others nothing."""
from __future__ import annotations

import base64
import csv
import json

import can

from firenav_framework.cli import main

PIPELINE = """
name: field-test
sources:
  - {id: can, plugin: can_bus, interface: virtual, channel: unused, device: can0}
sinks:
  - {plugin: mcap_recorder, input: ["can.raw"], file: frames.mcap}
"""


def _write_incident(folder, n: int, first_id: int) -> list[bytes]:
    (folder / "can").mkdir(parents=True)
    payloads = []
    with can.Logger(str(folder / "can" / "can0.log")) as log:
        for k in range(n):
            data = (first_id + k).to_bytes(4, "little")
            payloads.append(data)
            log(can.Message(timestamp=1000.0 + 0.01 * k, arbitration_id=0x100 + k % 3,
                            data=data, is_extended_id=False, channel="can0"))
    return payloads


def _mcap_payloads(path) -> list[bytes]:
    """CAN payloads of the RawFrames in an MCAP recording (JSON, data in base64)."""
    from mcap.reader import make_reader
    with open(path, "rb") as fh:
        return [base64.b64decode(json.loads(m.data)["data"])
                for _, _, m in make_reader(fh).iter_messages()]


def test_folder_of_incidents_on_workers(tmp_path, capsys):
    pipe = tmp_path / "field.yaml"
    pipe.write_text(PIPELINE)
    year = tmp_path / "exercises"
    sent = {"2026-03-drill": _write_incident(year / "2026-03-drill", 50, 0),
            "2026-09-fire": _write_incident(year / "2026-09-fire", 80, 1000)}
    (year / "2026-11-no-logs").mkdir()          # an incident whose recording is missing
    out = tmp_path / "out"
    code = main(["replay", str(year), "--pipeline", str(pipe), "--output", str(out),
                 "--workers", "2", "--quiet"])
    assert code == 1                              # one incident failed, the others ran
    rows = {r["incident"]: r for r in csv.DictReader((out / "incidents.csv").open())}
    assert sorted(rows) == ["2026-03-drill", "2026-09-fire", "2026-11-no-logs"]
    for name, payloads in sent.items():
        assert rows[name]["ok"] == "True" and rows[name]["error"] == ""
        assert int(rows[name]["messages"]) == len(payloads)
        assert float(rows[name]["data_s"]) == round(0.01 * (len(payloads) - 1), 3)
        summary = json.loads((out / name / "summary.json").read_text())
        assert summary["messages"] == {"can.raw": len(payloads)}
        assert (out / name / "summary.txt").read_text().startswith("Run summary: field-test")
        assert _mcap_payloads(out / name / "frames.mcap") == payloads   # its own frames
    broken = rows["2026-11-no-logs"]
    assert broken["ok"] == "False" and "no recording for source(s) can" in broken["error"]
    printed = capsys.readouterr().out
    assert "incident 2026-11-no-logs FAILED" in printed and "3 incidents, 1 failed" in printed


def test_one_recording_folder_is_still_one_replay(tmp_path, capsys):
    pipe = tmp_path / "field.yaml"
    pipe.write_text(PIPELINE)
    _write_incident(tmp_path / "raw", 30, 0)
    assert main(["replay", str(tmp_path / "raw"), "--pipeline", str(pipe), "--output",
                 str(tmp_path / "out"), "--quiet"]) == 0
    assert "can.raw         30" in capsys.readouterr().out
    assert (tmp_path / "out" / "frames.mcap").exists()
    assert not (tmp_path / "out" / "incidents.csv").exists()
