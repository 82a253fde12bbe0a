"""Scenario files: what building, who moves how, what they carry (YAML, validated).

A scenario is a YAML mapping (full reference with examples: ``docs/scenarios.md``)::

    name: flat_search
    building: flat_125            # a bundled plan name, or a plan file relative to this file
    duration_s: 600               # optional cap
    agents:
      - id: ff1
        start: {entrance: front}
        sensors:
          imu: {grade: xsens_mti3, rate_hz: 100}
        plan:
          - wait: 10
          - search: {hand: right, gait: search}
      - id: ff2
        follow: {agent: ff1, lag_s: 1.5}
        sensors: {imu: {grade: xsens_mti3}}

Plan steps are one-key mappings (``wait``, ``kneel``, ``walk``, ``crawl``, ``search``,
``compartmental_search``, ``stairs``, ``turn``, ``checkpoint``, ``repeat``); see
:data:`STEP_MODELS`.
Every problem is reported as ``file:line:col: where: message`` through
:class:`~firenav_framework.yaml_locations.ConfigError`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import (BaseModel, ConfigDict, Field, ValidationError, field_validator,
                      model_validator)

from ..field_docs import DescribedModel

from ..yaml_locations import ConfigError, LocatedDocument, Problem, load, loads
from .gaits import Gait, Person
from .imu_grades import AccelSpec, GyroSpec, ImuErrors, MagSpec, get_grade
from .mount import MountConfig

SCENARIO_DIR = Path(__file__).with_name("scenarios")

XY = tuple[float, float]


class _Model(DescribedModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# -- environment and radio ------------------------------------------------------------

class Magnetic(_Model):
    """Earth field and the building's disturbance of it (steel, wiring)."""

    intensity_ut: float = Field(50.0, gt=0, le=70)
    inclination_deg: float = Field(65.0, ge=-90, le=90)
    declination_deg: float = Field(2.0, ge=-180, le=180)
    indoor_disturbance_ut: float = Field(10.0, ge=0)
    """rms per axis [uT]"""


class Temperature(_Model):
    """IMU temperature change after power-up (drives the grades' thermal drift).

    Default: a foot IMU on a boot warms by 10 K with a 10-minute time constant (body
    and walking heat, its own electronics); near a fire raise ``change_k``. The INS
    can calibrate the bias at the start, not its later drift.
    """

    change_k: float = Field(10.0, ge=-50, le=150)
    """final change [K]"""
    tau_s: float = Field(600.0, gt=0)
    """time constant of the change [s]"""


class Pressure(_Model):
    """The air the barometers are in (simulator/barometer.py): weather, drawn per seed
    and drifting, and the building's own pressure against the outside."""

    sea_level_pa: tuple[float, float] = Field((99_000.0, 103_000.0))
    """sea-level pressure at the start, drawn in this range [Pa]"""
    trend_pa_per_h: float = Field(50.0, ge=0)
    """1-sigma of the weather's linear trend, drawn per seed [Pa/h] (a front: 100-300 Pa/h)"""
    weather_rw_pa_per_sqrt_s: float = Field(0.05, ge=0)
    """weather random walk [Pa/sqrt(s)]"""
    site_elevation_m: float | None = Field(None)
    """height of building z = 0 above sea level [m] (default: the plan's georef altitude, else 0)"""
    outside_c: tuple[float, float] = Field((-5.0, 25.0))
    """outside air temperature, drawn in this range [C]"""
    inside_c: float = Field(20.0, ge=-20, le=80)
    """inside air temperature [C]"""
    neutral_plane: tuple[float, float] = Field((0.3, 0.7))
    """height of the stack effect's neutral plane as a share of the building's height, drawn in
    this range"""
    floor_sigma_pa: float = Field(2.0, ge=0)
    """1-sigma of a per-floor offset (ventilation zones), drawn per floor [Pa]"""
    ventilation_rw_pa_per_sqrt_s: float = Field(0.05, ge=0)
    """random walk of the inside pressure [Pa/sqrt(s)]"""
    door_rate_per_min: float = Field(1.0, ge=0)
    """door openings per minute (Poisson), each a step of the inside pressure"""
    door_step_pa: float = Field(3.0, ge=0)
    """1-sigma of a door opening's step [Pa]"""
    door_open_s: float = Field(30.0, gt=0)
    """mean time a door stays open [s]"""
    fire_pa: float = Field(10.0, ge=0)
    """overpressure within a metre of a burning fire zone [Pa]"""
    reference: bool = Field(True)
    """a reference barometer (device base/baro, the worn ones' model) outside the first entrance, 1
    m up"""
    reference_rate_hz: float = Field(1.0, gt=0, le=50)
    """its reading rate"""


class Environment(_Model):
    gravity: float = Field(9.81, gt=9.7, lt=9.9)
    """local gravity [m/s^2]"""
    earth_rate: bool = Field(True)
    """include the Earth rotation in the gyros"""
    latitude_deg: float | None = Field(None, ge=-90, le=90)
    """default: the building's georef latitude, else 50"""
    magnetic: Magnetic = Magnetic()
    temperature: Temperature = Temperature()
    pressure: Pressure = Pressure()


class Fire(_Model):
    """A fire zone: heat and smoke attenuate and disturb radio links through it."""

    floor: int = 0
    position: XY
    radius_m: float = Field(3.0, gt=0)
    loss_db_per_m: float = Field(3.0, ge=0)
    """extra path loss inside the zone"""
    fading_db: float = Field(4.0, ge=0)
    """extra fading std of links through it"""
    start_s: float = Field(0.0, ge=0)


class Radio(_Model):
    """2.4 GHz breadcrumb radio links (log-distance path loss, breadcrumb paper Sec. V)."""

    rssi_1m_dbm: float = Field(-40.0)
    """RSSI at 1 m (paper Fig. 7: > -40 dBm at encounters within about 1 m)"""
    exponent: float = Field(2.8, gt=1, lt=6)
    """path-loss exponent"""
    wall_db: float = Field(4.0, ge=0)
    """loss per wall crossed"""
    floor_db: float = Field(15.0, ge=0)
    """loss per floor crossed"""
    shadowing_db: float = Field(4.0, ge=0)
    """log-normal shadowing std"""
    shadowing_m: float = Field(3.0, gt=0)
    """shadowing decorrelation distance"""
    fading_db: float = Field(2.5, ge=0)
    """per-packet fading std"""
    body_db: float = Field(6.0, ge=0)
    """extra loss when the wearer's body is between antenna and peer"""
    sensitivity_dbm: float = Field(-95.0)
    """packets weaker than this are lost"""
    packet_rate_hz: float = Field(1.0, gt=0, le=50)
    """packets per node per second"""
    base_station: str | None = Field("base")
    """building anchor id of the base station (root of the breadcrumb chain), or null"""
    draw: bool = Field(False)
    """draw the RSSI at 1 m, exponent, wall and floor loss, shadowing and fading per building and
    seed (ranges: simulator/radio.py RADIO_RANGES) instead of the values above, so that no
    estimator can be tuned to the simulator's"""


class AnchorSpec(_Model):
    """An extra fixed radio node (e.g. a UWB anchor left at the entrance)."""

    id: str
    position: XY
    floor: int = 0
    height_m: float = Field(1.0, ge=0, le=10)
    kind: Literal["uwb", "base_station"] = "uwb"


# -- the true world --------------------------------------------------------------------

class WallPiece(_Model):
    """``remove_wall``: the plan draws a wall (here, ``length_m`` of it centred on the
    point nearest to ``at``) that the real building does not have."""

    at: XY
    length_m: float = Field(1.0, gt=0.1, le=20)


class NewWall(_Model):
    """``add_wall``: a wall (partition) the plan does not show, ``from`` -> ``to``."""

    start: XY = Field(alias="from")
    end: XY = Field(alias="to")


class DoorShift(_Model):
    """``move_door``: the door is ``by_m`` [m] along its wall from where the plan has it."""

    door: str
    by_m: float = Field(ge=-20, le=20)


class RoomSplit(_Model):
    """``split_room``: a partition across the room with a door in it. ``across: x``: the
    partition runs in y at ``at`` of the room's x extent (0..1); ``y`` likewise."""

    room: str
    across: Literal["x", "y"] = "x"
    at: float = Field(0.5, gt=0.1, lt=0.9)
    door_at: float = Field(0.5, ge=0.1, le=0.9)
    """door along the partition (0..1)"""
    door_width: float = Field(0.9, ge=0.6, le=2.0)


class Change(_Model):
    """One way the real building differs from its plan, on ``floor``: exactly one of
    ``remove_wall``, ``add_wall``, ``brick_up`` (a door id), ``move_door``, ``split_room``."""

    floor: int = 0
    remove_wall: WallPiece | None = None
    add_wall: NewWall | None = None
    brick_up: str | None = None
    move_door: DoorShift | None = None
    split_room: RoomSplit | None = None

    @model_validator(mode="after")
    def _one(self) -> "Change":
        if len([k for k in CHANGE_KINDS if getattr(self, k) is not None]) != 1:
            raise ValueError(f"give exactly one of {', '.join(CHANGE_KINDS)}")
        return self

    def kind(self) -> tuple[str, Any]:
        """(kind, its value)."""
        k = next(k for k in CHANGE_KINDS if getattr(self, k) is not None)
        return k, getattr(self, k)


CHANGE_KINDS = ("remove_wall", "add_wall", "brick_up", "move_door", "split_room")


class Box(_Model):
    """A piece of furniture placed by hand: ``box`` [x0, y0, x1, y1] on ``floor``."""

    floor: int = 0
    box: tuple[float, float, float, float]


class Furniture(_Model):
    """Furniture drawn per seed: ``per_room`` pieces (lowest, highest) against the walls
    of every room, ``corridor`` pieces of clutter along corridors and halls, none within
    ``keep_clear_m`` of a door or stair; a piece that would cut a floor in two is left out."""

    per_room: tuple[int, int] = (1, 3)
    corridor: tuple[int, int] = (0, 1)
    keep_clear_m: float = Field(1.0, ge=0.5, le=3.0)


class World(_Model):
    """How the real building differs from the plan the pipeline is given (``building``).

    ``building``: another plan to start from (default: the given plan); then
    ``changes``, ``obstacles`` and ``furniture`` (see :mod:`.world`).
    """

    building: str | None = None
    furniture: Furniture | None = None
    obstacles: list[Box] = Field(default_factory=list)
    changes: list[Change] = Field(default_factory=list)


# -- sensors ----------------------------------------------------------------------------

class ImuConfig(_Model):
    """The foot IMU: a named grade, its errors, rate, mounting and optional overrides.

    ``errors``: ``as_worn`` (the unit on a boot in the field, uncalibrated: the default),
    ``calibrated`` (as worn after a still-start gyro calibration), ``datasheet`` (the
    datasheet numbers only) or ``ideal`` (error-free); see
    :func:`~.imu_grades.error_specs`. ``gyro``/``accel``/``mag`` override single fields
    on top of that.
    """

    grade: str = "industrial"
    errors: ImuErrors = "as_worn"
    switch_on_s: float = Field(0.0, ge=0)
    """when the unit is switched on [s]: it records from then (a firefighter who goes in later
    switches it on at the door: no still start to calibrate on)"""
    rate_hz: float = Field(100.0, ge=50, le=1000)
    axes: str = Field("FLU")
    """device axes on the foot, e.g. FLU or FRD (z down)"""
    mount_deg: tuple[float, float, float] = Field((0.0, 0.0, 0.0))
    """roll, pitch, yaw of the device on the boot [deg]"""
    mount: MountConfig | None = Field(MountConfig())
    """compliance of the attachment (null: rigidly on the foot)"""
    magnetometer: bool = False
    gyro: dict[str, float] = Field(default_factory=dict)
    """GyroSpec overrides"""
    accel: dict[str, float] = Field(default_factory=dict)
    """AccelSpec overrides"""
    mag: dict[str, float] = Field(default_factory=dict)
    """MagSpec overrides"""

    @field_validator("grade")
    @classmethod
    def _grade(cls, v: str) -> str:
        get_grade(v)
        return v

    @field_validator("axes")
    @classmethod
    def _axes(cls, v: str) -> str:
        from .imu_ideal import axes_matrix
        axes_matrix(v)
        return v.upper()

    @field_validator("gyro")
    @classmethod
    def _gyro(cls, v: dict) -> dict:
        GyroSpec(**v)
        return v

    @field_validator("accel")
    @classmethod
    def _accel(cls, v: dict) -> dict:
        AccelSpec(**v)
        return v

    @field_validator("mag")
    @classmethod
    def _mag(cls, v: dict) -> dict:
        MagSpec(**v)
        return v


class UwbConfig(_Model):
    """A UWB tag ranging to fixed anchors (DW1000 class, ORCA paper Sec. 3.1)."""

    anchors: list[str] | None = Field(None)
    """anchor ids (default: every uwb anchor)"""
    rate_hz: float = Field(2.0, gt=0, le=50)
    sigma_m: float = Field(0.10, gt=0)
    """line-of-sight range noise"""
    nlos_bias_m: float = Field(0.30, ge=0)
    """mean extra delay per wall (positive)"""
    nlos_sigma_m: float = Field(0.25, ge=0)
    """extra noise per wall"""
    outlier_prob: float = Field(0.01, ge=0, le=0.5)
    dropout_prob: float = Field(0.02, ge=0, le=1)
    dropout_per_wall: float = Field(0.08, ge=0, le=1)
    max_range_m: float = Field(40.0, gt=0)
    height_m: float = Field(1.4, ge=0, le=3)
    """tag height on the body"""


class RfidConfig(_Model):
    """An RFID reader (and, with ``deploy``, a tag dispenser) on the firefighter."""

    deploy: bool = Field(False)
    """stick a tag on each new door / stair end passed"""
    pause_s: float = Field(3.0, ge=0, le=30)
    """stop to stick a tag"""
    range_m: float = Field(1.5, gt=0, le=10)
    """read range"""
    rate_hz: float = Field(5.0, gt=0, le=100)
    """read attempts per second"""
    window_s: float = Field(1.0, gt=0)
    """reads aggregated into one detection"""
    reader_height_m: float = Field(1.2, ge=0, le=3)
    """reader on the body"""
    tag_height_m: float = Field(2.0, ge=0, le=4)
    """tags at the top of the jamb"""


class DispenserConfig(_Model):
    """A breadcrumb dispenser (breadcrumb paper Sec. III): drops a node when the link
    from the wearer to the last node of the chain gets weak."""

    capacity: int = Field(6, ge=1, le=100)
    drop_below_dbm: float = Field(-80.0)
    """drop when the averaged RSSI to the chain falls below this"""
    average_packets: int = Field(3, ge=1, le=50)
    min_spacing_m: float = Field(3.0, ge=0)
    faults: BreadcrumbFaults | None = Field(None)
    """kicked, burned, lost breadcrumbs (default: none)"""


class BreadcrumbFaults(_Model):
    """What happens to breadcrumbs once dropped (each drawn per breadcrumb and seed)."""

    dud: float = Field(0.0, ge=0, le=1)
    """share that never transmit (broken in the drop)"""
    kick: float = Field(0.0, ge=0, le=1)
    """chance that a firefighter passing within 0.7 m kicks it along the way they walk"""
    kick_m: tuple[float, float] = Field((0.5, 3.0))
    """how far a kick sends it [m]"""
    lost_per_min: float = Field(0.0, ge=0, le=1)
    """chance per minute that it stops (battery, water, crushed)"""
    burn: bool = Field(True)
    """one inside a fire zone dies 60-180 s after the fire reaches it"""


class BarometerConfig(_Model):
    """A worn MEMS barometer: a named part (:data:`~.barometer.BAROMETER_MODELS`, its
    datasheet figures) with optional overrides, its rate and where it is worn."""

    model: str = Field("ms5611")
    """named part (simulator/barometer.py)"""
    rate_hz: float = Field(10.0, gt=0)
    """readings per second"""
    height_m: float = Field(1.3, ge=0, le=2.5)
    """above the floor when standing (shoulder strap, SCBA); 40 % of it crawling, 60 % kneeling"""
    switch_on_s: float = Field(0.0, ge=0)
    """when it starts reading [s]"""
    noise_pa: float | None = Field(None, ge=0)
    """override: white noise [Pa]"""
    resolution_pa: float | None = Field(None, ge=0)
    """override: output step [Pa]"""
    offset_pa: float | None = Field(None, ge=0)
    """override: offset range [Pa]"""
    drift_pa_per_sqrt_s: float | None = Field(None, ge=0)
    """override: drift"""
    latency_s: float | None = Field(None, ge=0, le=2)
    """override: latency [s]"""

    @field_validator("model")
    @classmethod
    def _model(cls, v: str) -> str:
        from .barometer import BAROMETER_MODELS
        if v not in BAROMETER_MODELS:
            raise ValueError(f"unknown barometer model {v!r}; known: {', '.join(BAROMETER_MODELS)}")
        return v

    @model_validator(mode="after")
    def _rate(self) -> "BarometerConfig":
        spec = self.spec()
        if self.rate_hz > spec.max_rate_hz:
            raise ValueError(f"rate_hz {self.rate_hz:g} is above the {self.model}'s "
                             f"{spec.max_rate_hz:g} Hz")
        return self

    def spec(self):
        """The part's :class:`~.barometer.BaroSpec` with the overrides applied."""
        import dataclasses

        from .barometer import BAROMETER_MODELS
        over = {k: getattr(self, k) for k in ("noise_pa", "resolution_pa", "offset_pa",
                                              "drift_pa_per_sqrt_s", "latency_s")
                if getattr(self, k) is not None}
        return dataclasses.replace(BAROMETER_MODELS[self.model], **over)


class Sensors(_Model):
    imu: ImuConfig | None = ImuConfig()
    barometer: BarometerConfig | None = Field(None)
    """a worn barometer (default: none)"""
    uwb: UwbConfig | None = None
    rfid: RfidConfig | None = None
    dispenser: DispenserConfig | None = None
    radio: bool | None = Field(None)
    """carries a radio node (default: when the scenario has breadcrumbs)"""


# -- plans ------------------------------------------------------------------------------

class Stops(_Model):
    """Short random stops along a route (feeling furniture, listening); with
    ``kneel_prob`` a stop is made on the knees."""

    every_m: float = Field(6.0, gt=0.5)
    duration_s: tuple[float, float] = (1.0, 4.0)
    kneel_prob: float = Field(0.0, ge=0, le=1)


class Deviations(_Model):
    """How a real searcher departs from the clean hand-on-wall loop (drawn per seed)."""

    skip_rooms: float = Field(0.0, ge=0, le=1)
    """share of the rooms (not corridors, not the one the search starts in) left out: their doors
    are passed by"""
    coverage: float = Field(1.0, gt=0, le=1)
    """share of the loop searched before the search ends (a search cut short)"""
    leave_wall: float = Field(0.0, ge=0, le=1)
    """chance, every 4 m, of leaving the wall: 3-8 m of the loop replaced by a straight line across
    the room when that is at least 25 % shorter"""
    backtrack_every_m: float | None = Field(None, gt=2)
    """about this often, go back the way one came and on again"""
    backtrack_m: tuple[float, float] = (1.0, 4.0)
    sweep_every_m: float | None = Field(None, gt=1)
    """about this often, stop and sweep the floor ahead with the foot"""
    sweep_s: tuple[float, float] = (3.0, 8.0)
    crawl_share: float = Field(0.0, ge=0, le=1)
    """share of the path crawled, in pieces of 3-8 m"""
    run_in_corridors: bool = Field(False)
    """corridor stretches over 5 m are run (gait run)"""


class Target(_Model):
    """Where to go: exactly one of position, door, room, entrance, anchor."""

    position: XY | None = None
    door: str | None = None
    room: str | None = None
    entrance: str | None = None
    anchor: str | None = None
    floor: int | None = None


class Walk(_Model):
    """Go somewhere: ``to`` a target (routed around walls, through doors, up/down stairs)
    or along explicit ``via`` points (straight lines, which must not cross walls)."""

    to: Target | XY | None = None
    via: list[XY] | None = None
    gait: str = "walk"
    backwards: bool = False
    stops: Stops | None = None


class Crawl(Walk):
    gait: str = "crawl"


class Search(_Model):
    """Directional (hand-on-wall) search from where the agent stands."""

    hand: Literal["right", "left"] = "right"
    rooms: list[str] | None = Field(None)
    """limit to these rooms (default: floor)"""
    closed_doors: list[str] = Field(default_factory=list)
    """doors treated as walls"""
    offset_m: float = Field(0.5, ge=0.25, le=1.5)
    """body to wall distance"""
    gait: str = "search"
    laps: float = Field(1.0, gt=0, le=20)
    length_m: float | None = Field(None, gt=0)
    """stop after this distance"""
    stops: Stops | None = None
    kneel_at_doors_s: float = Field(0.0, ge=0, le=60)
    """kneel this long in each doorway before going through (flashover drill, Sec. II)"""
    deviate: Deviations | None = Field(None)
    """how the searcher departs from the clean loop (default: not at all)"""


class CompartmentalSearch(_Model):
    """Search the current room hand-on-wall, then each room behind its doors in turn,
    coming back the same way (search-pattern paper, Sec. II)."""

    hand: Literal["right", "left"] = "right"
    rooms: list[str] | None = Field(None)
    """rooms to search (default: all reachable)"""
    offset_m: float = Field(0.5, ge=0.25, le=1.5)
    gait: str = "search"
    stops: Stops | None = None


class Stairs(_Model):
    to_floor: int
    backwards: bool = Field(False)
    """descend backwards (firefighter practice)"""


class Turn(_Model):
    heading_deg: float | None = None
    by_deg: float | None = None


class Checkpoint(_Model):
    """Stop on a marked point for ``stop_s``; its true position is recorded (sparse
    ground truth, like the surveyed stop points of the ORCA paper, Sec. 3.2)."""

    name: str = Field(min_length=1)
    stop_s: float = Field(3.0, ge=0, le=600)


class Repeat(_Model):
    times: int = Field(2, ge=1, le=100)
    plan: list[Any]


STEP_MODELS: dict[str, type[BaseModel] | type] = {
    "wait": float, "kneel": float, "walk": Walk, "crawl": Crawl, "search": Search,
    "compartmental_search": CompartmentalSearch, "stairs": Stairs, "turn": Turn,
    "checkpoint": Checkpoint, "repeat": Repeat,
}


@dataclass(frozen=True)
class Step:
    """One validated plan step: its kind, its model (or seconds) and its YAML path."""

    kind: str
    spec: Any
    where: tuple
    plan: tuple["Step", ...] = ()   # for repeat


class Start(_Model):
    entrance: str | None = None
    position: XY | None = None
    floor: int = 0
    heading_deg: float | None = None
    time_s: float = Field(5.0, ge=0)
    """the plan starts here; before it the firefighter stands still (IMU alignment)"""


class Follow(_Model):
    """Move as the second of a team: same route as ``agent``, ``lag_s`` behind."""

    agent: str
    lag_s: float = Field(1.5, ge=0, le=60)


class AgentSpec(_Model):
    id: str = Field(min_length=1)
    team: str = ""
    start: Start = Start()
    person: Person = Person()
    sensors: Sensors = Sensors()
    plan: list[Any] | None = None
    follow: Follow | None = None


class ScenarioModel(_Model):
    name: str = ""
    description: str = ""
    family: str = Field("")
    """the group `firenav simulate --list` shows it in (paper, field, twin, demo)"""
    building: str = Field()
    """the plan the pipeline is given"""
    world: World | None = Field(None)
    """how the real building differs from it (default: not at all)"""
    duration_s: float | None = Field(None, gt=0)
    truth_rate_hz: float = Field(20.0, gt=0, le=200)
    end_still_s: float = Field(3.0, ge=0)
    """still time after the last plan ends"""
    foot_model: Literal["realistic", "ideal"] = Field("realistic")
    """realistic: the foot rolls over heel and ball and the IMU sits on a compliant boot; ideal:
    the foot lifts off and lands flat and the IMU is rigid on it (every IMU's mount is ignored)"""
    gaits: dict[str, dict[str, Any]] = Field(default_factory=dict)
    environment: Environment = Environment()
    radio: Radio = Radio()
    fires: list[Fire] = Field(default_factory=list)
    anchors: list[AnchorSpec] = Field(default_factory=list)
    agents: list[AgentSpec] = Field(min_length=1)


@dataclass
class Scenario:
    """A validated scenario with its file, resolved building path and plan steps."""

    model: ScenarioModel
    file: str
    base_dir: Path
    building_path: Path
    world_path: Path | None
    steps: dict[str, tuple[Step, ...]]
    gaits: dict[str, Gait]
    document: LocatedDocument

    @property
    def name(self) -> str:
        return self.model.name or Path(self.file).stem

    def problem(self, where: tuple, message: str) -> ConfigError:
        """A ConfigError pointing at ``where`` in the scenario file."""
        return ConfigError([self.document.problem(where, message)])


def _locate_loc(doc: LocatedDocument, base: tuple, loc: tuple) -> tuple:
    """Walk a pydantic ``loc`` down the document, skipping parts that are not keys."""
    path = tuple(base)
    node: Any = doc.data
    for part in base:
        node = node[part] if isinstance(node, (dict, list)) else None
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
            path += (part,)
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
            path += (part,)
        elif isinstance(node, dict) and isinstance(part, str):
            path += (part,)  # a missing key: point at the mapping, name the key
            break
    return path


def _pyd_problems(doc: LocatedDocument, base: tuple, exc: ValidationError) -> list[Problem]:
    from ..pipeline import pydantic_message
    out = []
    for err in exc.errors():
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-")))
        out.append(doc.problem(_locate_loc(doc, base, loc), pydantic_message(err)))
    return out


def _steps(doc: LocatedDocument, items: Any, base: tuple, problems: list[Problem]
           ) -> tuple[Step, ...]:
    if not isinstance(items, list):
        problems.append(doc.problem(base, "a plan is a list of steps"))
        return ()
    out = []
    for i, item in enumerate(items):
        where = base + (i,)
        if not isinstance(item, dict) or len(item) != 1:
            problems.append(doc.problem(where, "each plan step is a one-key mapping such as "
                                        f"'- wait: 10'; known steps: {', '.join(STEP_MODELS)}"))
            continue
        kind, value = next(iter(item.items()))
        model = STEP_MODELS.get(kind)
        if model is None:
            from ..pipeline import _did_you_mean
            problems.append(doc.problem(where + (kind,), f"unknown plan step '{kind}'"
                                        f"{_did_you_mean(str(kind), list(STEP_MODELS))}; "
                                        f"known: {', '.join(STEP_MODELS)}"))
            continue
        if model is float:
            if isinstance(value, dict) and set(value) == {"duration_s"}:
                value = value["duration_s"]
            if not isinstance(value, (int, float)) or isinstance(value, bool) or value < 0:
                problems.append(doc.problem(where + (kind,), f"'{kind}' takes a duration in "
                                            "seconds, e.g. '- wait: 10'"))
                continue
            out.append(Step(kind, float(value), where))
            continue
        if kind == "checkpoint" and isinstance(value, str):
            value = {"name": value}
        try:
            spec = model.model_validate(value if value is not None else {})
        except ValidationError as exc:
            problems.extend(_pyd_problems(doc, where + (kind,), exc))
            continue
        nested: tuple[Step, ...] = ()
        if kind == "repeat":
            nested = _steps(doc, spec.plan, where + (kind, "plan"), problems)
        if isinstance(spec, (Walk, Crawl)):
            if (spec.to is None) == (spec.via is None):
                problems.append(doc.problem(where + (kind,), "give either 'to' (a target) or "
                                            "'via' (a list of [x, y] points)"))
                continue
            if isinstance(spec.to, Target):
                given = [k for k in ("position", "door", "room", "entrance", "anchor")
                         if getattr(spec.to, k) is not None]
                if len(given) != 1:
                    problems.append(doc.problem(where + (kind, "to"), "a target needs exactly "
                                                "one of position, door, room, entrance, anchor"))
                    continue
        if isinstance(spec, Turn) and (spec.heading_deg is None) == (spec.by_deg is None):
            problems.append(doc.problem(where + (kind,), "give either heading_deg or by_deg"))
            continue
        out.append(Step(kind, spec, where, nested))
    return tuple(out)


def _gait_names(steps: tuple[Step, ...]) -> list[tuple[str, tuple]]:
    out = []
    for s in steps:
        g = getattr(s.spec, "gait", None)
        if g is not None:
            out.append((g, s.where + (s.kind, "gait")))
        out.extend(_gait_names(s.plan))
    return out


def _validate(doc: LocatedDocument, base_dir: Path) -> Scenario:
    from ..building import bundled_plans
    from .gaits import GAITS
    if not isinstance(doc.data, dict):
        raise ConfigError([doc.problem((), "a scenario must be a mapping with at least "
                                       "'building' and 'agents'")])
    try:
        model = ScenarioModel.model_validate(doc.data)
    except ValidationError as exc:
        raise ConfigError(_pyd_problems(doc, (), exc)) from None
    problems: list[Problem] = []

    def plan_path(name: str, where: tuple) -> Path:
        if name in bundled_plans():
            from ..building import bundled_plan
            return bundled_plan(name)
        path = Path(name).expanduser()
        if not path.is_absolute():
            path = base_dir / path
        if not path.is_file():
            problems.append(doc.problem(where, f"'{name}' is neither a bundled plan "
                                        f"({', '.join(bundled_plans())}) nor a file (looked "
                                        f"for {path})"))
        else:
            from ..building.loader import plan_problem
            if (why := plan_problem(path)) is not None:
                problems.append(doc.problem(where, why))
        return path
    building_path = plan_path(model.building, ("building",))
    world_path = None
    if model.world is not None and model.world.building is not None:
        world_path = plan_path(model.world.building, ("world", "building"))
    gaits: dict[str, Gait] = {}
    for name, over in model.gaits.items():
        try:
            gaits[name] = Gait.model_validate({**GAITS.get(name, Gait()).model_dump(), **over})
        except ValidationError as exc:
            problems.extend(_pyd_problems(doc, ("gaits", name), exc))
    known_gaits = {**GAITS, **gaits}
    ids = [a.id for a in model.agents]
    steps: dict[str, tuple[Step, ...]] = {}
    for i, agent in enumerate(model.agents):
        where = ("agents", i)
        if ids.count(agent.id) > 1:
            problems.append(doc.problem(where + ("id",), f"agent id '{agent.id}' is used twice"))
        if (agent.plan is None) == (agent.follow is None):
            problems.append(doc.problem(where, "an agent needs either a 'plan' or 'follow'"))
            continue
        if agent.follow is not None:
            if agent.follow.agent not in ids or agent.follow.agent == agent.id:
                problems.append(doc.problem(where + ("follow", "agent"), f"no other agent "
                                            f"'{agent.follow.agent}' to follow; agents: "
                                            f"{', '.join(ids)}"))
            elif model.agents[ids.index(agent.follow.agent)].follow is not None:
                problems.append(doc.problem(where + ("follow", "agent"), "follow a leader who "
                                            "has a plan (chains of followers are not supported)"))
            continue
        steps[agent.id] = _steps(doc, agent.plan, where + ("plan",), problems)
        for gname, gwhere in _gait_names(steps[agent.id]):
            if gname not in known_gaits:
                problems.append(doc.problem(gwhere, f"unknown gait '{gname}'; known: "
                                            f"{', '.join(sorted(known_gaits))} (or define it "
                                            "under 'gaits:')"))
    if problems:
        raise ConfigError(problems)
    return Scenario(model=model, file=doc.file, base_dir=base_dir,
                    building_path=Path(building_path), world_path=world_path, steps=steps,
                    gaits=gaits, document=doc)


def bundled_scenarios() -> list[str]:
    """Names of the scenarios shipped with firenav (``scenarios/*.yaml``)."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def scenario_path(name_or_path: str | Path) -> Path:
    """A scenario file: an existing path, or the bundled scenario of that name."""
    p = Path(name_or_path).expanduser()
    if p.is_file():
        return p
    bundled = SCENARIO_DIR / f"{name_or_path}.yaml"
    if bundled.is_file():
        return bundled
    raise ConfigError([Problem(str(name_or_path), None, None, "", "no such scenario file "
                               f"and no bundled scenario of that name; bundled: "
                               f"{', '.join(bundled_scenarios())}")])


def load_scenario(path_or_name: str | Path) -> Scenario:
    """Read and validate a scenario (a file path or a bundled scenario name)."""
    path = scenario_path(path_or_name)
    doc = load(path)
    return _validate(doc, path.resolve().parent)


def load_scenario_text(text: str, *, file: str = "<string>", base_dir: Path | None = None
                       ) -> Scenario:
    """Validate a scenario given as YAML text (tests, embedding)."""
    return _validate(loads(text, file), base_dir or Path.cwd())
