"""2.4 GHz links between breadcrumbs, the base station and firefighters' radios.

Received power (dBm) of a packet from ``a`` heard at ``b``::

    RSSI = P(1 m) - 10 n log10(d) - L_wall * walls - L_floor * floors - L_fire(path)
           - L_body + X_shadow(a, b) + X_fade

* log-distance path loss with exponent ``n`` and the RSSI at 1 m (breadcrumb paper,
  Fig. 7: above -40 dBm when a user passes within about a metre);
* per-wall and per-floor attenuation, walls counted on the floor plan along the line;
* fire zones: heat and smoke add loss per metre of the line inside the zone and
  extra fading (paper Fig. 8: with fire the RSSI falls and ranging degrades, worse at
  longer distance);
* body shadowing (paper ref. [12]): the radio sits on the back (breathing apparatus),
  so a peer ahead of the wearer is received through the body;
* log-normal shadowing that is smooth in space (decorrelation ``shadowing_m``) and
  fixed for a pair of fixed nodes, plus independent per-packet fading;
* packets below the sensitivity are lost (and a margin of 3 dB above it is flaky);
  reported RSSI is an integer dBm like real radios.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import wrap_angles
from .scenario import Fire, Radio

BODY_CONE = np.radians(70.0)   # peer within this angle of the wearer's facing: body loss


@dataclass
class Node:
    """A radio node: fixed (base station, breadcrumb) or worn by a firefighter.

    Fixed nodes have ``position`` (3,) and ``floor``; worn ones ``agent`` and a track
    function giving (positions (N, 3), floors (N,), headings (N,)) at times (a kicked
    breadcrumb has one too). ``t_on`` / ``t_off``: when it starts and stops transmitting
    and receiving (a breadcrumb's drop time; a dud, burned or lost one's end).
    """

    id: str
    position: np.ndarray | None = None
    floor: int = 0
    agent: str = ""
    t_on: float = 0.0
    track: object = None
    t_off: float = np.inf

    @property
    def mobile(self) -> bool:
        return self.track is not None

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.track is not None:
            return self.track(t)
        n = len(t)
        return (np.repeat(self.position[None], n, 0), np.full(n, self.floor),
                np.full(n, np.nan))


#: Ranges of the path-loss parameters a ``draw: true`` radio takes per building and seed
#: (uniform): indoor 2.4 GHz measurements put the exponent at 1.6-3.5 (corridors low,
#: furnished offices high), a wall at 2-12 dB (plasterboard to brick and concrete), a
#: floor slab at 10-30 dB, the shadowing spread at 3-9 dB; devices differ by a few dB at
#: 1 m.
RADIO_RANGES = {"exponent": (2.0, 3.6), "wall_db": (2.0, 9.0), "floor_db": (10.0, 25.0),
                "shadowing_db": (3.0, 8.0), "fading_db": (1.5, 4.0), "rssi_1m_dbm": (-4.0, 4.0)}


def drawn_radio(cfg: Radio, rng: np.random.Generator) -> Radio:
    """``cfg`` with its path loss drawn from :data:`RADIO_RANGES` (the RSSI at 1 m as an
    offset from the given value); ``cfg`` itself when it does not ask (``draw``)."""
    if not cfg.draw:
        return cfg
    upd = {k: float(rng.uniform(*r)) for k, r in RADIO_RANGES.items()}
    upd["rssi_1m_dbm"] += cfg.rssi_1m_dbm
    return cfg.model_copy(update=upd)


class ShadowField:
    """Smooth random shadowing around one node: random Fourier features in the plane."""

    def __init__(self, rng: np.random.Generator, sigma_db: float, corr_m: float, waves: int = 16):
        ang = rng.uniform(0, 2 * np.pi, waves)
        k = rng.rayleigh(1.0 / corr_m, waves)
        self.k = np.column_stack([np.cos(ang), np.sin(ang)]) * k[:, None]
        self.phase = rng.uniform(0, 2 * np.pi, waves)
        self.amp = sigma_db * np.sqrt(2.0 / waves)

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        return self.amp * np.cos(xy @ self.k.T + self.phase).sum(axis=1)


def _chord_in_circle(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    """Length (N,) of segments a->b (N, 2) inside the circle (centre c, radius r)."""
    d = b - a
    f = a - c
    A = np.einsum("ij,ij->i", d, d)
    B = 2 * np.einsum("ij,ij->i", f, d)
    C = np.einsum("ij,ij->i", f, f) - r * r
    disc = B * B - 4 * A * C
    ok = (disc > 0) & (A > 1e-12)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    A_ = np.where(A > 1e-12, A, 1.0)
    t0 = np.clip((-B - sq) / (2 * A_), 0, 1)
    t1 = np.clip((-B + sq) / (2 * A_), 0, 1)
    return np.where(ok, (t1 - t0) * np.sqrt(A), 0.0)


class LinkModel:
    """Mean RSSI and its random parts for any pair of nodes at any times."""

    def __init__(self, cfg: Radio, building, fires: list[Fire], rng: np.random.Generator):
        self.cfg = cfg
        self.b = building
        self.fires = fires
        self.rng = rng
        self._shadow: dict[str, ShadowField] = {}

    def shadow(self, node_id: str) -> ShadowField:
        if node_id not in self._shadow:
            seed = self.rng.integers(0, 2 ** 32)
            self._shadow[node_id] = ShadowField(np.random.default_rng(seed),
                                                self.cfg.shadowing_db / np.sqrt(2),
                                                self.cfg.shadowing_m)
        return self._shadow[node_id]

    def walls_between(self, pa: np.ndarray, fa: np.ndarray, pb: np.ndarray) -> np.ndarray:
        """Walls crossed (N,) by the lines pa->pb (N, 2), counted on floor ``fa``
        (furniture edges do not count)."""
        out = np.zeros(len(pa), int)
        for f in np.unique(fa):
            m = fa == f
            floor = self.b.floor(int(f))
            move, seg = floor.wall_index.all_hits(pa[m], pb[m])
            move = move[~floor.wall_is_obstacle[seg]]     # walls, not furniture
            out[np.flatnonzero(m)] = np.bincount(move, minlength=int(m.sum()))
        return out

    def mean_rssi(self, t: np.ndarray, pa: np.ndarray, fa: np.ndarray, pb: np.ndarray,
                  fb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mean RSSI [dBm], walls crossed, extra fading std [dB]) for links a->b."""
        c = self.cfg
        d = np.maximum(np.linalg.norm(pa - pb, axis=1), 0.1)
        walls = self.walls_between(pa[:, :2], fa, pb[:, :2])
        floors = np.abs(fa - fb)
        rssi = c.rssi_1m_dbm - 10 * c.exponent * np.log10(d) - c.wall_db * walls \
            - c.floor_db * floors
        extra = np.zeros(len(t))
        for fire in self.fires:
            active = (t >= fire.start_s) & (fa == fire.floor) & (fb == fire.floor)
            if not active.any():
                continue
            inside = _chord_in_circle(pa[:, :2], pb[:, :2], np.asarray(fire.position, float),
                                      fire.radius_m)
            hit = active & (inside > 0)
            rssi = rssi - np.where(active, fire.loss_db_per_m * inside, 0.0)
            extra = np.where(hit, np.hypot(extra, fire.fading_db), extra)
        return rssi, walls, extra

    def body_loss(self, heading: np.ndarray, p_self: np.ndarray, p_peer: np.ndarray) -> np.ndarray:
        """Loss [dB] when the peer is ahead of a wearer facing ``heading`` (NaN: no body)."""
        if self.cfg.body_db == 0:
            return np.zeros(len(heading))
        d = p_peer[:, :2] - p_self[:, :2]
        ang = np.arctan2(d[:, 1], d[:, 0]) - heading
        ahead = np.abs(wrap_angles(ang)) < BODY_CONE
        return np.where(np.isfinite(heading) & ahead, self.cfg.body_db, 0.0)

    def sample(self, t: np.ndarray, a: Node, b: Node, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray]:
        """(RSSI [dBm] float, received mask) of packets a->b at times ``t``."""
        pa, fa, ha = a.at(t)
        pb, fb, hb = b.at(t)
        mean, _, extra = self.mean_rssi(t, pa, fa.astype(int), pb, fb.astype(int))
        shadow = (self.shadow(a.id)(pb[:, :2]) + self.shadow(b.id)(pa[:, :2]))
        body = self.body_loss(ha, pa, pb) + self.body_loss(hb, pb, pa)
        fade = rng.normal(0.0, 1.0, len(t)) * np.hypot(self.cfg.fading_db, extra)
        rssi = mean + shadow - body + fade
        margin = rssi - self.cfg.sensitivity_dbm
        p_ok = 1.0 / (1.0 + np.exp(-(margin - 1.5) / 0.75))
        received = rng.uniform(size=len(t)) < p_ok
        return np.round(rssi), received


@dataclass
class Drop:
    """A breadcrumb dropped by ``agent`` at ``t`` at ``position`` (3,) on ``floor``."""

    node_id: str
    agent: str
    t: float
    position: np.ndarray
    floor: int


def simulate_dispensers(model: LinkModel, fixed: list[Node], dispensers: list[tuple[Node, object]],
                        t_end: float, rng: np.random.Generator, *, floor_z) -> list[Drop]:
    """Decide when and where the dispensers drop breadcrumbs.

    Each wearer hears the chain (base station and every breadcrumb dropped so far)
    once per packet period; it keeps the strongest RSSI of each period, averages the
    last ``average_packets`` periods and drops a new node when that average falls
    below ``drop_below_dbm`` (breadcrumb paper, Sec. III: "deployed whenever a
    communication connection to the breadcrumb chain gets weak"), at least
    ``min_spacing_m`` after its previous drop and while it has nodes left.

    A node's packets to every wearer are drawn once, for the whole run, when the node
    appears; the sequential part only takes running maxima.
    """
    period = 1.0 / model.cfg.packet_rate_hz
    times = np.arange(period, t_end, period)
    drops: list[Drop] = []
    if not times.size or not dispensers:
        return drops
    floor_rssi = model.cfg.sensitivity_dbm - 5.0
    best = {n.id: np.full(len(times), -np.inf) for n, _ in dispensers}

    def hear(node: Node) -> None:
        for wearer, _ in dispensers:
            r, ok = model.sample(times, node, wearer, rng)
            heard = np.where(ok & (times >= node.t_on), r, -np.inf)
            np.maximum(best[wearer.id], heard, out=best[wearer.id])

    for node in fixed:
        hear(node)
    tracks = {n.id: n.at(times) for n, _ in dispensers}
    state = {n.id: {"left": cfg.capacity, "last": None, "since": 0} for n, cfg in dispensers}
    count = 0
    for k, t in enumerate(times):
        for node, cfg in dispensers:
            st = state[node.id]
            st["since"] += 1
            if st["left"] <= 0 or st["since"] < cfg.average_packets:
                continue
            window = best[node.id][k - cfg.average_packets + 1:k + 1]
            avg = float(np.mean(np.maximum(window, floor_rssi)))
            pos = tracks[node.id][0][k]
            moved = (np.inf if st["last"] is None
                     else float(np.linalg.norm(pos[:2] - st["last"][:2])))
            if avg < cfg.drop_below_dbm and moved >= cfg.min_spacing_m:
                count += 1
                f = int(tracks[node.id][1][k])
                jitter = rng.normal(0.0, 0.15, 2)
                p = np.array([pos[0] + jitter[0], pos[1] + jitter[1], floor_z(f) + 0.05])
                d = Drop(f"bc{count}", node.agent, float(t), p, f)
                drops.append(d)
                hear(Node(d.node_id, position=p, floor=f, t_on=float(t)))
                st["left"] -= 1
                st["last"] = p
                st["since"] = 0
    return drops


def packet_readings(model: LinkModel, nodes: list[Node], t_end: float,
                    rng: np.random.Generator) -> list[tuple]:
    """Every received packet among ``nodes``: (t, tx id, rx id, rssi, rx node).

    Each node broadcasts every packet period with its own phase; every other node
    that exists then and receives it logs the RSSI.
    """
    period = 1.0 / model.cfg.packet_rate_hz
    out = []
    phase = {n.id: rng.uniform(0, period) for n in nodes}
    for a in nodes:
        ta = np.arange(max(a.t_on, 0.0) + phase[a.id], min(t_end, a.t_off), period)
        for b in nodes:
            if b is a:
                continue
            t = ta[(ta >= b.t_on) & (ta < b.t_off)]
            if not t.size:
                continue
            rssi, ok = model.sample(t, a, b, rng)
            for ti, ri in zip(t[ok], rssi[ok]):
                out.append((float(ti) + 1e-4, a.id, b.id, float(ri), b))
    out.sort(key=lambda r: r[0])
    return out
