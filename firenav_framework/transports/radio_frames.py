"""The other sensors of a scenario or recording as their devices send them (``firenav play``).

Every message that is not a foot IMU's is turned into the frames of the link its codec
uses, in the team layout of ``pipelines/incident-live.yaml``:

* **UWB** ranges (``Range``, method ``uwb``) as ``UWB_TWR_REPORT`` CAN frames
  (``uwb_can``, ``dbc/uwb_twr.dbc``): ``TagId`` is the firefighter's position N in the
  roster (the IMUs' order), ``AnchorId`` the anchor's index in ``anchors`` (the plan's
  anchor ids in order; an anchor not there is numbered on first use), ``Seq`` a
  counter per tag; no powers (the simulator has none: raw 255, "not available").
* **RFID** reads and deployments (``TagDetection``, ``TagDeployment``) as ``TAG`` /
  ``DEPLOY`` lines (``rfid_lines``) on the line link, the reader named as in the message.
* **Breadcrumb radio** readings and drops (``RssiReading``, ``BreadcrumbDrop``) as
  ``RSSI`` / ``DROP`` lines (``breadcrumb_lines``), the roster's firefighters as their
  worn radios ``<agent>/radio``.
* **Frames** a scenario or recording already holds (the simulator's barometer lines,
  a recording's CAN frames) go out as they are, on the link of their transport
  (``serial``/``udp`` -> the line link).

A radio message carries no device clock: the live sensors stamp it with its receive
time, so live and offline agree up to the constant that also maps the IMUs' device
clocks onto the receive clock, plus each frame's own delivery delay, only when played
at ``speed`` 1 (:class:`~.player.DevicePlayer`).
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from ..codecs import Codec, EncodedFrame, get_codec
from ..codecs.breadcrumb_lines import radio_event
from ..codecs.rfid_lines import RfidEvent
from ..codecs.twr_report import TwrReport
from ..messages import (BreadcrumbDrop, Message, Range, RawFrame, RssiReading, TagDeployment,
                        TagDetection)

__all__ = ["RadioEncoder", "LINE_LINK", "RADIO_CODECS", "message_kind", "plan_anchors"]

#: The name of the text-line link (a serial port or a UDP address) in the player.
LINE_LINK = "lines"
#: The codec of each kind of radio message, and the link it goes on.
RADIO_CODECS = {"uwb": ("uwb_can", "can"), "rfid": ("rfid_lines", LINE_LINK),
                "radio": ("breadcrumb_lines", LINE_LINK)}
_FRAME_LINKS = {"can": "can", "mavlink": "mavlink", "serial": LINE_LINK, "udp": LINE_LINK}
_MAX_NUMBER = 255   # TagId and AnchorId are one byte


def message_kind(msg: Message) -> str | None:
    """``uwb``, ``rfid``, ``radio`` or ``frames`` for a message the encoder sends, else None."""
    if isinstance(msg, Range):
        return "uwb" if msg.method in ("uwb", "") else None
    if isinstance(msg, (TagDetection, TagDeployment)):
        return "rfid"
    if isinstance(msg, (RssiReading, BreadcrumbDrop)):
        return "radio"
    if isinstance(msg, RawFrame):
        return "frames"
    return None


@dataclass
class RadioEncoder:
    """Encodes the radio messages of one play (see the module docstring).

    ``team`` returns the roster's firefighters by position, the list itself (it grows as
    the IMUs are assigned; a UWB tag of a firefighter not in it yet appends them, as
    their IMU would); ``anchors`` the plan's anchor ids; ``announce`` is told each new
    tag and anchor number (a text line); ``sent`` counts the messages encoded per kind.
    """

    team: Callable[[], list[str]]
    anchors: list[str] = field(default_factory=list)
    announce: Callable[[str], None] = lambda text: None
    sent: Counter = field(default_factory=Counter)
    _codecs: dict[str, Codec] = field(default_factory=dict)
    _seq: Counter = field(default_factory=Counter)
    _told: set = field(default_factory=set)

    def codec(self, kind: str) -> Codec:
        """The encoder of a message kind (made on first use)."""
        c = self._codecs.get(kind)
        if c is None:
            c = self._codecs[kind] = get_codec(RADIO_CODECS[kind][0])()
        return c

    def encode(self, msg: Message) -> tuple[str, list[EncodedFrame]] | None:
        """``(link, frames)`` of one message; None for a message it does not send."""
        kind = message_kind(msg)
        if kind == "frames":
            link = _FRAME_LINKS.get(msg.transport)
            if link is None:
                return None
            self.sent[kind] += 1
            return link, [EncodedFrame(msg.t, msg.channel, bytes(msg.data))]
        if kind is None:
            return None
        self.sent[kind] += 1
        if kind == "uwb":
            record: object = self._report(msg)
        elif kind == "rfid":
            record = (RfidEvent(msg.t, "DEPLOY", msg.device, msg.tag_id)
                      if isinstance(msg, TagDeployment) else
                      RfidEvent(msg.t, "TAG", msg.reader or msg.device, msg.tag_id,
                                msg.rssi_dbm, msg.reads))
        else:
            record = radio_event(msg, self.team())
        return RADIO_CODECS[kind][1], self.codec(kind).encode([record])

    def _report(self, r: Range) -> TwrReport:
        agent = r.agent or r.a.split("/", 1)[0]
        tag = self._number("tag", agent, self.team())
        anchor = self._number("anchor", r.b, self.anchors)
        seq = self._seq[tag]
        self._seq[tag] = (seq + 1) & 0xFF
        return TwrReport(r.t, str(tag), str(anchor), r.range_m, None, None, seq)

    def _number(self, what: str, name: str, names: list[str]) -> int:
        """A tag's (1-based position) or an anchor's (0-based index) wire number."""
        if name not in names:
            names.append(name)
        n = names.index(name) + (what == "tag")
        if n > _MAX_NUMBER:
            raise ValueError(f"UWB {what} {name}: number {n} does not fit the report's byte")
        if (what, name) not in self._told:
            self._told.add((what, name))
            self.announce(f"UWB {what} {name} -> {'TagId' if what == 'tag' else 'AnchorId'} {n}")
        return n


def plan_anchors(building: object) -> Sequence[str]:
    """The anchor ids of a plan, in its order (none without a plan)."""
    return [a.id for a in getattr(building, "anchors", None) or ()]
