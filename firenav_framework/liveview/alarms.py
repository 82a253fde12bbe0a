"""Latched alarms: raised by a condition, kept until a person acknowledges them.

The states are those of the alarm-management standard ANSI/ISA-18.2: an alarm is raised *unacknowledged and active* when its
condition (:mod:`.status`) comes on. When the condition goes away the alarm *returns
to normal* but stays latched and shown, unacknowledged, so a man-down the commander
has not seen is never lost because the device went quiet or the firefighter moved
again. Acknowledging an active alarm keeps it shown (muted) until the condition goes;
acknowledging a returned one closes it. A condition coming back while its alarm is
still latched re-raises that alarm instead of adding a second.

Every transition is an :class:`AlarmEvent`; the ``live_view`` sink turns each into an
incident-log diagnostic (:func:`alarm_diagnostic`), recorded by ``diagnostics_log``
and ``mcap_recorder`` with the wall-clock time.

Codes: ``alarm_<condition>`` (``alarm_man_down``, ``alarm_device_silent``,
``alarm_untrusted``, ``alarm_map_contradiction``) for raise / re-raise / return to
normal (``active`` True while the alarm is latched), ``alarm_acknowledged`` for an
acknowledgement (``active`` True while the acknowledged alarm is still shown) and
``alarm_closed`` when an acknowledged alarm's condition goes.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from ..messages import Diagnostic
from ..timefmt import clock_text, wall_text
from .status import CONDITIONS, Change

__all__ = ["ALARM_TITLES", "Alarm", "AlarmEvent", "AlarmBook", "alarm_diagnostic",
           "ALARM_CODES"]

#: What the commander reads for each condition.
ALARM_TITLES = {"man_down": "MAN DOWN", "device_silent": "DEVICE SILENT",
                "untrusted": "POSITION UNTRUSTED", "map_contradiction": "MAP CONTRADICTION"}
assert set(ALARM_TITLES) == set(CONDITIONS)

#: Every diagnostic code an alarm event can carry.
ALARM_CODES = frozenset([f"alarm_{c}" for c in CONDITIONS] + ["alarm_acknowledged",
                                                              "alarm_closed"])

EventKind = Literal["raised", "raised_again", "returned", "acknowledged", "closed"]


@dataclass
class Alarm:
    """One latched alarm of one firefighter.

    ``raised_t`` [s] pipeline time of the raise (on a live link that is the wall
    clock); ``floor`` and ``position`` (x, y) [m] where the firefighter was last
    seen at the raise (None when unknown). ``active``: the condition holds.
    """

    id: int
    agent: str
    condition: str
    raised_t: float
    floor: int | None = None
    position: tuple[float, float] | None = None
    active: bool = True
    returned_t: float | None = None
    acknowledged_wall: float | None = None
    acknowledged_by: str = ""
    raises: int = 1

    @property
    def acknowledged(self) -> bool:
        return self.acknowledged_wall is not None

    @property
    def state(self) -> str:
        """``unacknowledged`` / ``acknowledged`` (condition active) / ``returned``
        (unacknowledged, condition gone) / ``closed``."""
        if self.acknowledged:
            return "acknowledged" if self.active else "closed"
        return "unacknowledged" if self.active else "returned"

    @property
    def title(self) -> str:
        return ALARM_TITLES[self.condition]

    def as_json(self) -> dict:
        """What the page shows (times as numbers; the page writes the local clock)."""
        return {"id": self.id, "agent": self.agent, "condition": self.condition,
                "title": self.title, "state": self.state, "raised_t": self.raised_t,
                "floor": self.floor,
                "position": list(self.position) if self.position else None,
                "returned_t": self.returned_t, "acknowledged_wall": self.acknowledged_wall,
                "acknowledged_by": self.acknowledged_by, "raises": self.raises}


@dataclass(frozen=True)
class AlarmEvent:
    """A transition of ``alarm`` at pipeline time ``t`` [s]; for an acknowledgement
    ``wall`` [UNIX s] when the person clicked and ``client`` their address."""

    kind: EventKind
    alarm: Alarm
    t: float
    wall: float | None = None
    client: str = ""


@dataclass
class AlarmBook:
    """Every alarm of a run: the latched ones shown, the closed ones kept for the log."""

    alarms: dict[int, Alarm] = field(default_factory=dict)
    _next_id: int = 1

    def _latched(self, agent: str, condition: str) -> Alarm | None:
        for a in self.alarms.values():
            if a.agent == agent and a.condition == condition and a.state != "closed":
                return a
        return None

    def update(self, changes: list[Change], t: float,
               where: dict[str, tuple[int | None, tuple[float, float] | None]]
               ) -> list[AlarmEvent]:
        """Apply condition changes at pipeline time ``t`` [s]; ``where`` gives each
        agent's last (floor, (x, y)). Returns the events."""
        events = []
        for agent, condition, on in changes:
            alarm = self._latched(agent, condition)
            floor, pos = where.get(agent, (None, None))
            if on:
                if alarm is None:
                    alarm = Alarm(self._next_id, agent, condition, t, floor, pos)
                    self._next_id += 1
                    self.alarms[alarm.id] = alarm
                    events.append(AlarmEvent("raised", alarm, t))
                elif not alarm.active:  # back while still latched: the same alarm again
                    alarm.active, alarm.returned_t = True, None
                    alarm.raises += 1
                    alarm.floor, alarm.position = floor, pos
                    events.append(AlarmEvent("raised_again", alarm, t))
            elif alarm is not None and alarm.active:
                alarm.active, alarm.returned_t = False, t
                events.append(AlarmEvent("closed" if alarm.acknowledged else "returned",
                                         alarm, t))
        return events

    def acknowledge(self, alarm_id: int, t: float, wall: float, by: str = "",
                    client: str = "") -> AlarmEvent | str:
        """Acknowledge alarm ``alarm_id`` (``by``: who, as typed in the view); the event,
        or why not (a text for the person who clicked)."""
        alarm = self.alarms.get(alarm_id)
        if alarm is None:
            return f"there is no alarm {alarm_id}"
        if alarm.acknowledged:
            return f"alarm {alarm_id} was acknowledged already"
        alarm.acknowledged_wall, alarm.acknowledged_by = wall, by
        return AlarmEvent("acknowledged", alarm, t, wall, client)

    def shown(self) -> list[Alarm]:
        """The latched alarms: unacknowledged first, the newest first within each."""
        live = [a for a in self.alarms.values() if a.state != "closed"]
        return sorted(live, key=lambda a: (a.acknowledged, -a.raised_t, -a.id))


def _where(alarm: Alarm) -> str:
    parts = []
    if alarm.floor is not None:
        parts.append(f"floor {alarm.floor}")
    if alarm.position is not None:
        parts.append(f"({alarm.position[0]:.1f}, {alarm.position[1]:.1f}) m")
    return f" at {', '.join(parts)}" if parts else ""


def alarm_diagnostic(ev: AlarmEvent, component: str) -> Diagnostic:
    """The incident-log diagnostic of an alarm event (times as the local clock)."""
    a = ev.alarm
    since = clock_text(a.raised_t)
    head = f"{a.agent} {a.title}"
    if ev.kind in ("raised", "raised_again"):
        again = f" (again, {a.raises} times)" if ev.kind == "raised_again" else ""
        text = (f"ALARM {head}{again} since {since}{_where(a)}; latched until acknowledged "
                f"[alarm {a.id}]")
        return Diagnostic(t=ev.t, agent=a.agent, component=component, level="error",
                          code=f"alarm_{a.condition}", text=text, active=True)
    if ev.kind == "returned":
        text = (f"{head} (since {since}): condition gone at {clock_text(ev.t)}; the alarm "
                f"stays until acknowledged [alarm {a.id}]")
        return Diagnostic(t=ev.t, agent=a.agent, component=component, level="warning",
                          code=f"alarm_{a.condition}", text=text, active=True)
    if ev.kind == "acknowledged":
        who = f" by {a.acknowledged_by!r}" if a.acknowledged_by else ""
        client = f" from {ev.client}" if ev.client else ""
        rest = ("; condition still present, shown until it goes" if a.active
                else "; condition had gone: alarm closed")
        clicked = wall_text(ev.wall, date=True) if ev.wall is not None else clock_text(ev.t)
        text = (f"{head} (since {since}) acknowledged at {clicked}"
                f"{who}{client}{rest} [alarm {a.id}]")
        return Diagnostic(t=ev.t, agent=a.agent, component=component, level="info",
                          code="alarm_acknowledged", text=text, active=a.active)
    text = (f"{head} (since {since}, acknowledged): condition gone at {clock_text(ev.t)}; "
            f"alarm closed [alarm {a.id}]")
    return Diagnostic(t=ev.t, agent=a.agent, component=component, level="info",
                      code="alarm_closed", text=text, active=False)
