"""The conformance checks catch what they are for: each broken variant of a working plugin
(the extension templates) fails exactly the check about its defect, with a message that
names it; the working ones pass."""
from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from firenav_framework import (Angle, Constraint, Message, Odometry, Params, Range, RawFrame,
                               Sensor, Source, param)
from firenav_framework.codecs import FrameError
from firenav_framework.testing import (CHECKS, ConformanceError, check_codec, check_plugin,
                                       parameter_problems, plugin_case, run_checks)
from firenav_framework.testing import checks as checks_module

from .templates import load


@pytest.fixture(scope="module")
def templates(tmp_path_factory):
    folder = tmp_path_factory.mktemp("templates")
    return {k: load(k, folder) for k in ("sensor", "estimator", "constraint", "source", "codec")}


def ranges(n: int = 12, agents=("ff1", "ff2")) -> list[tuple[str, Message]]:
    return [("uwb.raw", Range(t=0.5 * k, agent=a, device=f"{a}/uwb", a=f"{a}/uwb", b="anchor",
                              range_m=3.0 + 0.1 * k, sigma_m=0.1))
            for k in range(n) for a in agents]


def failures(cls, **kw) -> dict[str, str]:
    """Check name -> message of every failed check."""
    results = run_checks(plugin_case(cls, **kw))
    return {k: str(v) for k, v in results.items() if isinstance(v, BaseException)}


def test_the_working_sensor_passes_every_check_that_applies(templates):
    results = run_checks(plugin_case(templates["sensor"], sample_input=ranges()))
    assert {k: v for k, v in results.items() if v != "passed"} == {
        "capability": "n/a: not a constraint", "live_stop": "n/a: not a live source"}
    assert list(results) == list(CHECKS)


def test_a_sensor_without_handle_is_rejected_at_once():
    class NoHandle(Sensor):
        """Forgets to implement handle."""
        name = "no_handle"
        inputs = (Range,)

    with pytest.raises(ConformanceError) as err:
        check_plugin(NoHandle, sample_input=ranges())
    assert err.value.results == {"class": err.value.results["class"]}   # nothing else ran
    assert "NoHandle does not implement handle (required of a sensor)" in str(err.value)


def test_a_constraint_must_implement_a_capability():
    class Bare(Constraint):
        """Implements no capability."""
        name = "bare"

    assert "must subclass a capability base" in failures(Bare, sample_input=[])["class"]


def test_class_problems_are_listed_together(templates):
    class Sloppy(templates["sensor"]):
        inputs = ()

        def handle(self, msg):      # the runner calls handle(stream, msg)
            pass

    Sloppy.__doc__ = None
    text = failures(Sloppy, sample_input=[])["class"]
    for problem in ("needs a docstring", "a sensor needs inputs",
                    "handle() cannot be called as the runner calls it"):
        assert problem in text


def test_parameter_docs_cover_nested_groups_units_and_degrees():
    class Detector(Params):
        window: float = param(0.1, unit="s", description="window")
        threshold: float = param(0.3)

    class P(Params):
        detector: Detector = param(Detector(), description="the detector")
        groups: dict[str, Detector] = param({}, description="per device")
        yaw_offset: Angle = param(0.0, description="mounting yaw")
        turn_deg: float = param(5.0, unit="deg", description="a turn")
        timeout: float = param(2.0, description="give up after this long")
        gap_s: float = param(1.0, description="a gap")
        max_range: float = param(5.0, unit="m", description="fine")
        distance_ratio: float = param(0.1, description="a ratio: no unit needed")
        count: int = param(3, description="an integer count: no unit needed")
        documented: float = param(1.0, unit="m")
        """described by its docstring"""

    assert P.model_fields["documented"].description == "described by its docstring"
    missing = "no description (a docstring right below the parameter, or param(description=...))"
    assert parameter_problems(P) == [
        f"detector.threshold: {missing}",
        f"groups.threshold: {missing}",
        "yaw_offset: an Angle needs unit='rad', has None",
        "turn_deg: degrees (parameters are SI: declare it Angle or AngularRate, in radians; "
        "YAML may still say '5 deg')",
        "timeout: a physical quantity without a unit (param(unit=...))",
        "gap_s: a physical quantity without a unit (param(unit=...))",
    ]


def test_publishing_off_the_declared_ports_and_changing_input_are_caught(templates):
    class Leaky(templates["sensor"]):
        """Publishes off its ports."""
        def handle(self, stream, msg):
            super().handle(stream, msg)
            self.ctx.publish("ranges", msg)                               # undeclared port
            self.ctx.publish("range", Odometry(t=msg.t, t_start=msg.t, delta=np.zeros(3),
                                               dheading=0.0, cov=np.eye(4),
                                               position=np.zeros(3), heading=0.0))
            self.ctx.publish("diagnostics", checks_module.Diagnostic(
                t=msg.t, component="someone", level="info", code="x", text="x"))

    text = failures(Leaky, sample_input=ranges())["ports"]
    assert "published Range on undeclared port 'ranges' (declared: range, diagnostics)" in text
    assert "published Odometry on 'range', declared Range" in text
    assert "naming component 'someone', not its own id 'under_test'" in text

    class Meddler(templates["estimator"]):
        """Changes the odometry it receives."""
        def handle(self, stream, msg):
            msg.delta[0] += 1.0                                          # shared message!
            super().handle(stream, msg)

    walk = [("ins.odometry", Odometry(t=float(k), agent="ff1", t_start=k - 1.0,
                                      delta=np.array([1.0, 0.0, 0.0]), dheading=0.0,
                                      cov=np.eye(4) * 0.01, position=np.array([k, 0.0, 0.0]),
                                      heading=0.0)) for k in range(1, 6)]
    # message arrays are read-only: the attempt itself fails, in the meddler's own hands
    assert "assignment destination is read-only" in failures(
        Meddler, sample_input=walk)["ports"]


def test_declared_ports_and_ticks_must_be_consistent(templates):
    class Odd(templates["sensor"]):
        """Declares odd ports and ticks."""
        @classmethod
        def output_ports(cls, params):
            return {"range": Range, "bad.port": int}

        @classmethod
        def tick_period(cls, params):
            return -1.0

    text = failures(Odd, sample_input=[])["declared_ports"]
    for problem in ("port name 'bad.port' is not a plain name", "maps to <class 'int'>",
                    "lacks 'diagnostics': Diagnostic", "tick_period() must be None or a "
                    "positive number of seconds, got -1.0"):
        assert problem in text


@pytest.mark.parametrize("defect, expected", [
    ("raises", "a NaN value in the Range at t=2.00 s: ValueError escaped: bad range"),
    ("silent", "a NaN value in the Range at t=2.00 s: the output changed but nothing was "
               "counted"),
    ("leaks", "an infinite value in the Range at t=2.00 s: non-finite values published in "
              "range.range_m"),
    ("unordered", "the Range at t=2.00 s delivered after a later one (out of time order): "
                  "the output changed but nothing was counted"),
])
def test_bad_input_defects_are_caught(templates, defect, expected):
    base = templates["sensor"]

    class Defective(base):
        """Mishandles bad ranges."""
        def handle(self, stream, msg):
            finite = math.isfinite(msg.range_m)
            if defect == "raises" and not finite:
                raise ValueError("bad range")
            if defect == "silent" and not finite:
                return
            if defect in ("leaks", "unordered"):
                self.ctx.publish("range", msg)
                return
            super().handle(stream, msg)

    assert expected in failures(Defective, sample_input=ranges())["bad_input"]


class FirstSighting(Sensor):
    """Publishes each range (per firefighter) and, once per run, the first sighting of
    each anchor (a building fact that outlives any firefighter's reset)."""
    name = "first_sighting"
    inputs = (Range,)
    outputs = {"range": Range, "anchors": Range}

    def __init__(self, params, ctx):
        super().__init__(params, ctx)
        self._anchors: set[str] = set()

    def handle(self, stream, msg):
        self.ctx.publish("range", msg)
        if msg.b not in self._anchors:
            self._anchors.add(msg.b)
            self.ctx.publish("anchors", msg)


def test_building_facts_kept_through_reset_pass_only_when_declared_as_world_outputs():
    sample = ranges(agents=("ff1",))
    text = failures(FirstSighting, sample_input=sample)["reset_refeed"]
    assert "reset must forget everything of that firefighter" in text

    class Declared(FirstSighting):
        """The same, declaring its anchor port a building fact."""
        world_outputs = ("anchors",)

    assert "reset_refeed" not in failures(Declared, sample_input=sample)

    class Misnamed(FirstSighting):
        """Declares a port it does not have."""
        world_outputs = ("anchor",)

    assert "world_outputs names 'anchor', which is not an output port" in failures(
        Misnamed, sample_input=sample)["ports"]


def test_a_reset_that_forgets_nothing_is_caught(templates):
    class Stubborn(templates["estimator"]):
        """Forgets nothing on reset."""
        def reset(self, agent):
            pass

    walk = [("ins.odometry", Odometry(t=float(k), agent="ff1", t_start=k - 1.0,
                                      delta=np.array([1.0, 0.0, 0.0]), dheading=0.0,
                                      cov=np.eye(4) * 0.01, position=np.array([k, 0.0, 0.0]),
                                      heading=0.0)) for k in range(1, 6)]
    text = failures(Stubborn, sample_input=walk)["reset_refeed"]
    assert "after reset('ff1') and 5 of its messages again (14 s later)" in text
    assert "first difference at message 0: PoseEstimate on 'pose'" in text
    assert failures(templates["estimator"], sample_input=walk) == {}


def test_nondeterminism_is_caught(templates):
    class Noisy(templates["sensor"]):
        """Adds unseeded noise."""
        def handle(self, stream, msg):
            self.ctx.publish("range", Range(t=msg.t, agent=msg.agent, a=msg.a, b=msg.b,
                                            range_m=msg.range_m + np.random.normal(),
                                            sigma_m=msg.sigma_m))

    assert "the first difference is message 0" in failures(
        Noisy, sample_input=ranges())["deterministic"]


def test_a_capability_answer_of_the_wrong_type_is_caught(templates):
    class Sloppy(templates["constraint"]):
        """Answers with a list."""
        def log_likelihood(self, step):
            return list(super().log_likelihood(step))

    text = failures(Sloppy)["capability"]
    assert "log_likelihood() answered list, declared ndarray | NoneType" in text


def test_a_source_that_does_not_count_damaged_data_is_caught(templates, tmp_path):
    class Careless(templates["source"]):
        """Hides what it counted."""
        def __init__(self, params, ctx):
            super().__init__(params, ctx)
            ctx.count = ctx.report = lambda *args, **kw: None

    good, bad = tmp_path / "good.csv", tmp_path / "bad.csv"
    good.write_text("1.0,ff1,0,0,0\n")
    bad.write_text("1.0,ff1,0,0,0\nbroken\n")
    assert failures(templates["source"], params={"path": str(good)},
                    faulty_params=[{"path": str(bad)}]) == {}
    text = failures(Careless, params={"path": str(good)}, faulty_params=[{"path": str(bad)}])
    assert "the damaged data was neither counted nor reported" in text["bad_input"]


def test_a_live_source_deaf_to_stop_is_caught(monkeypatch):
    class Deaf(Source):
        """Waits for data forever."""
        name = "deaf"
        live = True
        outputs = {"raw": RawFrame}

        release = threading.Event()

        def messages(self):
            self.release.wait(30.0)
            yield from ()

    monkeypatch.setattr(checks_module, "STOP_WITHIN_S", 0.3)
    results = run_checks(plugin_case(Deaf), ["live_stop"])
    Deaf.release.set()
    assert "messages() still running 0.3 s after stop()" in str(results["live_stop"])


def test_check_plugin_lists_every_failure_and_can_leave_checks_out(templates):
    class Twice(templates["sensor"]):
        """Two defects at once."""
        def handle(self, stream, msg):
            self.ctx.publish("ranges", msg)

        def reset(self, agent):
            raise RuntimeError("no")

    with pytest.raises(ConformanceError) as err:
        check_plugin(Twice, sample_input=ranges())
    text = str(err.value)
    assert text.startswith("Twice fails 3 of 9 conformance checks:")
    assert "[ports]" in text and "[bad_input]" in text and "[reset_refeed] RuntimeError: no" in text
    rec = check_plugin(Twice, sample_input=ranges(), checks=["class", "deterministic"])
    assert len(rec.on("ranges")) == len(ranges())
    with pytest.raises(ValueError, match="unknown checks"):
        check_plugin(Twice, checks=["nonsense"])


def test_a_building_without_its_sample_is_refused(templates):
    with pytest.raises(ValueError, match="a building goes with the sample_input"):
        check_plugin(templates["sensor"], building=object())


def test_codec_defects_are_caught(templates):
    base = templates["codec"]
    records = [base.record(1.0, "link/tag7", "a1", 7.25)]

    class Fragile(base):
        """Breaks on truncated lines."""
        def decode(self, frame):
            if frame.data.startswith(b"MYRNG") and not frame.data.endswith(b"\n") and \
                    b"*" not in frame.data:
                raise IndexError("truncated")
            return super().decode(frame)

    class Lossy(base):
        """Encodes what it did not decode."""
        def encode(self, records, *, address=""):
            return super().encode([base.record(r.t, r.device, r.anchor, r.range_m + 0.001)
                                   for r in records], address=address)

    with pytest.raises(ConformanceError, match="truncated frame on channel 'tag7': "
                                               "IndexError escaped: truncated"):
        check_codec(Fragile, records=records, address="tag7")
    with pytest.raises(ConformanceError, match="encode to other frames"):
        check_codec(Lossy, records=records, address="tag7")
    assert check_codec(base, frames=[RawFrame(t=1.0, device="link", transport="serial",
                                              channel="", data=b"MYRNG,a1,100*00")]) == {
        "class": "passed", "round_trip": "n/a: no sample records", "bad_frames": "passed",
        "deterministic": "passed"}
    assert FrameError  # the codec template raises it for a bad checksum (see bad_frames)
