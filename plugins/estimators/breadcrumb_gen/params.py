"""Parameters of ``breadcrumb_gen``, in groups: the base station, the start, the odometry
edges, the breadcrumbs, the radio edges, the graph window, the heading states, the
learned path-loss model, the consistency of the published covariance and integrity."""
from __future__ import annotations

from typing import Any

from firenav_framework import Angle, AngularRate, Params, StartPose, Vec3, param
from firenav_framework.integrity import IntegrityParams

from ..start_pose import start_pose_type


class Base(Params):
    """The base station: the anchor of the graph."""

    id: str = param("base")
    """node id of the base station"""
    position: Vec3 | None = param(None, unit="m")
    """antenna position (x, y, z), building frame; null: the building's anchor of that id"""


class OdometryEdges(Params):
    """Odometry steps as edges between consecutive firefighter states."""

    rotation: dict[str, Angle] = param({}, unit="rad")
    """per agent: rotation from the odometry frame into the building frame (default 0: odometry
    already in the building frame)"""
    noise_per_m: float = param(0.15, ge=0)
    """extra horizontal std per axis per metre of step, for INS errors the per-step covariance
    leaves out"""
    max_speed: float = param(5.0, unit="m/s", gt=0)
    """a step faster than this is impossible and dropped (§IV-F)"""


class Breadcrumbs(Params):
    """Dropped breadcrumbs and kicked ones (§V-C)."""

    drop_sigma: float = param(0.3, unit="m", gt=0)
    """a dropped breadcrumb lies this close to the dropping foot, per horizontal axis"""
    kick_sigma: float = param(1.5, unit="m", gt=0)
    """displacement of a kicked breadcrumb per horizontal axis (§V-C: 1-2 m)"""
    antenna_height: float = param(0.05, unit="m", ge=0)
    """breadcrumb antenna above the floor"""


class Radio(Params):
    """RSSI ranges and encounters as edges, with their outlier rules (§IV-F)."""

    use_ranges: bool = param(True)
    """use RSSI ranges (false: PDR with drops and encounters only)"""
    use_encounters: bool = param(True)
    """use encounter events"""
    agent_antenna_height: float = param(1.2, unit="m", ge=0)
    """worn radio above the foot"""
    max_range: float = param(1.5, unit="m", gt=0)
    """longer RSSI ranges are not used (§V-B: ranges within 1.5 m are relatively accurate; walls
    and the body bias longer ones)"""
    near_range: float = param(1.5, unit="m", gt=0)
    """shorter ranges enter as a zero relative position of that spread"""
    near_sigma: float = param(1.5, unit="m", ge=0)
    """least horizontal spread per axis of a near range or an encounter: fast fading lets a few
    short readings through from metres away"""
    period: float = param(2.0, unit="s", ge=0)
    """at most one range per firefighter and node in this time (shadowing is correlated over
    metres)"""
    static_samples: int = param(10, ge=1)
    """readings averaged (median) into the single range edge between two fixed nodes"""
    gate: float = param(4.0, gt=0)
    """innovation [sigmas] above which a range or encounter contradicts the graph: it is down-
    weighted (its variance scaled by (z / gate)^4, so the further off the less it pulls),
    counted, diagnosed, and widens the firefighter's published covariance (§IV-F drops it)"""
    weaken: float = param(2.0, gt=0)
    """innovation [sigmas] above which a range's variance is inflated (§IV-F)"""
    time_match: float = param(1.0, unit="s", gt=0)
    """a radio event is tied to the firefighter state nearest in time, at most this far"""
    mutual_correlation_s: float = param(30.0, unit="s", ge=0)
    """links (ranges, encounters) between the same two firefighters within this time share one
    error (they walk and drift together): each enters with its variance times the number of such
    links in that time, and none checks the graph's absolute position (consistency); 0:
    independent"""
    shadow_length: float = param(1.0, unit="m", ge=0)
    """a range to a fixed node (base station, breadcrumb) from within this distance walked
    (odometry) of the last one used is not used: its shadowing is the same, so a firefighter
    waiting by a breadcrumb gives one range, however long; 0: every range"""


class RadioLearning(Params):
    """The path-loss model learned online from links of known length (radio_model.py)."""

    enabled: bool = param(True)
    """correct the sensor's ranges and encounters with the learned model (false: the sensor's model
    as given)"""
    steps: int = param(8, ge=1)
    """a breadcrumb and the firefighter who dropped it (the base station and a firefighter after
    the start) are a link of known length for this many steps"""
    sigma_offset: float = param(0.15, unit="decade", gt=0)
    """prior std of the log-range offset c (4 dB of RSSI at 1 m are 0.13 at exponent 3)"""
    sigma_slope: float = param(0.3, gt=0)
    """prior std of the log-range slope e, the ratio of the building's exponent to the sensor's"""
    sigma_log: float = param(0.2, unit="decade", gt=0)
    """spread of one link's log range (shadowing and fading over 10 x the exponent)"""
    min_samples: int = param(20, ge=1)
    """links observed before the correction is applied"""
    period: float = param(0.5, unit="s", gt=0)
    """at most one observation per link in this time (fading is correlated over a step)"""


class Consistency(Params):
    """How the published covariance is kept honest against the radio and the odometry
    (integrity)."""

    enabled: bool = param(True)
    """judge radio links against the graph as below (false: the paper's rule, a link beyond
    radio.gate is dropped and the graph's marginal is published as it is)"""
    memory: int = param(10, ge=1)
    """radio links over which the normalised innovation (chi-square per degree of freedom) is
    averaged; the published covariance is scaled by that average when above 1"""
    widen_decay: float = param(0.5, gt=0, le=1)
    """after a contradiction the published covariance carries the contradiction's size squared
    until a link within radio.weaken confirms the graph; each link between weaken and gate
    multiplies it by this"""
    doubt_per_m: float = param(0.1, ge=0)
    """growth of a doubt kept beside the graph from the distance walked alone: its std per
    horizontal axis grows by this many metres per metre walked; a near range or an encounter
    with a fixed node narrows it (fused with the link's variance plus the node's doubt, never
    below the node's own), a breadcrumb inherits its dropper's at the drop, links between
    firefighters leave it. Its variance is added to the published covariance, so integrity
    does not rest on the graph's odometry model (the INS step covariance, noise_per_m, the
    heading states) being right; 0: off"""


class Graph(Params):
    """The marginalisation window (§IV-E) and the incremental solver."""

    window: int = param(20, ge=2, le=10_000)
    """past states per firefighter kept in the graph; older ones are marginalised (eq. 17)"""
    window_max: int = param(200, ge=2, le=10_000)
    """past states kept at most while the oldest one's heading is unsettled (heading states; never
    fewer than window)"""
    forget_per_update: int = param(4, ge=2, le=10_000)
    """states marginalised at most per update (a closure that settles a long backlog at once
    spreads its marginalisation over the next updates)"""
    settle_heading_sigma: Angle = param(0.1, unit="rad", gt=0)
    """a state is marginalised only once its heading is known this well (heading states)"""
    relinearize_sigma: float = param(0.1, gt=0)
    """re-linearise a range when its linearisation error exceeds this many sigmas"""
    max_active_dims: int = param(600, ge=30, le=20_000)
    """dense active set of the incremental solver before refactorising"""
    rebuild_lag: int = param(0, ge=0, le=1_000)
    """updates from the start of a refactorisation on a worker thread to its hand-over (0: on the
    pipeline thread); the poses meanwhile are the previous factorisation's (counted as
    poses_while_refactorising)"""
    handover_wait: float | None = param(None, unit="s", ge=0)
    """longest wait of an update for a refactorisation due at its hand-over (null: wait until done,
    so replays give identical tracks; a number bounds the update's latency, and a late factor is
    handed over at a later update, counted as graph_late_handovers, which makes tracks depend on
    the machine's timing)"""
    background_dims: int = param(3000, ge=0, le=1_000_000)
    """systems of at least this many dimensions are refactorised on the worker thread; smaller ones
    at once"""

    def network_options(self) -> dict[str, Any]:
        """The :class:`~.network.GeneralizedElectricalNetwork` keyword arguments of these
        settings (the hot nodes re-activated after a refactorisation: a twelfth of the
        active set's bound, in nodes of 3 dimensions, at least 8)."""
        return {"relinearize_sigma": self.relinearize_sigma,
                "max_active_dims": self.max_active_dims,
                "hot_nodes": max(8, self.max_active_dims // 12),
                "rebuild_lag": self.rebuild_lag, "background_dims": self.background_dims,
                "handover_wait": self.handover_wait}


class HeadingStates(Params):
    """Each state's INS heading correction: offset, drift rate and turn scale error."""

    enabled: bool = param(True)
    """estimate them in the graph (false: the paper's position-only GEN)"""
    rate_sigma: AngularRate = param(0.03, unit="rad/s", gt=0)
    """residual gyro bias about z at the start (an uncalibrated consumer IMU without a still start:
    about 1.7 deg/s)"""
    rate_walk: float = param(3e-4, unit="rad/s/sqrt(s)", ge=0)
    """random walk of that bias (warm-up drift, bias instability)"""
    turn_scale_sigma: float = param(0.02, gt=0)
    """gyro scale-factor error: heading error per radian the INS turned"""
    turn_scale_walk: float = param(1e-3, ge=0)
    """random walk of the scale-factor error per step"""


#: Firefighters start relative to the base station, 0.5 m per axis uncertain, with the
#: known start heading good to 2 degrees.
DEFAULT_START = StartPose(mode="unknown", sigma_position=0.5, sigma_heading=0.035)
BreadcrumbGenStart = start_pose_type(DEFAULT_START, modes=("unknown", "pose"),
                                     needs_heading=False)


class BreadcrumbGenParams(Params):
    base: Base = param(Base())
    """the base station"""
    start: BreadcrumbGenStart = param(DEFAULT_START)
    """where each firefighter's first state is: mode 'unknown' = the odometry's own position before
    its first step; 'pose' = the start position (per agent in agents; the heading comes from the
    odometry). sigma_position is relative to the base; sigma_heading is the start heading's
    (heading states)"""
    odometry: OdometryEdges = param(OdometryEdges())
    """odometry edges"""
    breadcrumbs: Breadcrumbs = param(Breadcrumbs())
    """drops and kicks"""
    radio: Radio = param(Radio())
    """ranges and encounters"""
    graph: Graph = param(Graph())
    """marginalisation window and solver"""
    heading: HeadingStates = param(HeadingStates())
    """heading states (beyond the paper)"""
    learn: RadioLearning = param(RadioLearning())
    """path-loss model learned online (beyond the paper)"""
    consistency: Consistency = param(Consistency())
    """covariance kept honest against the radio's innovations"""
    integrity: IntegrityParams = param(IntegrityParams())
    """protection radius and when a pose is trusted"""
