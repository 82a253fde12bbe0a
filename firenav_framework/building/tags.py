"""The RFID tag database of the RFID/MEMS paper (rfid-mems-ekf, "RFID and Database").

The first team sticks an RFID tag on the **top centre of the door jamb** each time it
passes a door, and at the beginning and the end of each stairway. The database lists
every such candidate site of the building with its 3-D position and its **crossing
direction** (the door's axis, or the stair's climb direction at that end), which gives
the heading update of the paper's Eq. (3) up to the 180 degree ambiguity. When a new tag
is placed, "a distance cost function exploits [the dead-reckoning] position to identify
the most probable door location in the database"; that site's coordinates are then
associated with the tag id for every later reader.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Building

__all__ = ["TagSite", "TagDatabase", "candidate_tag_sites", "DOOR_TAG_HEIGHT", "STAIR_TAG_HEIGHT"]

#: Height [m] above the floor of a tag on the top centre of a door jamb (a 2.0 m door).
DOOR_TAG_HEIGHT = 2.0
#: Height [m] above the stair end's level of a tag at the start/end of a stairway
#: (hand height on the wall or railing; the paper does not give one).
STAIR_TAG_HEIGHT = 1.0


@dataclass(frozen=True, eq=False)
class TagSite:
    """A place a tag can be stuck: ``position`` (3,) ENU [m], ``axis`` (2,) unit crossing
    direction, ``kind`` "door" or "stair", ``ref`` the door or stair id (``end`` is
    "bottom"/"top" for stairs)."""

    id: str
    floor: int
    position: np.ndarray
    kind: str
    axis: np.ndarray
    ref: str
    end: str | None = None

    @property
    def heading(self) -> float:
        """Crossing heading [rad] along ``axis`` (the opposite crossing is this + pi)."""
        return float(np.arctan2(self.axis[1], self.axis[0]))


def candidate_tag_sites(building: Building) -> list[TagSite]:
    """Every door (openings have no jamb to tag) and both ends of every stair."""
    sites = []
    for floor in building.floors:
        for d in floor.doors:
            sites.append(TagSite(d.id, floor.index, np.array([*d.center, floor.z + DOOR_TAG_HEIGHT]),
                                 "door", d.axis.copy(), d.id))
    for s in building.stairs:
        sites.append(TagSite(f"{s.id}/bottom", s.floor_from,
                             np.array([*s.bottom, s.z_from + STAIR_TAG_HEIGHT]), "stair",
                             s.direction, s.id, "bottom"))
        sites.append(TagSite(f"{s.id}/top", s.floor_to, np.array([*s.top, s.z_to + STAIR_TAG_HEIGHT]),
                             "stair", s.top_direction, s.id, "top"))
    return sites


class TagDatabase:
    """Tag id -> site associations over a building's candidate sites.

    :meth:`associate` places a new tag at the free site of least distance cost from the
    estimated position; :meth:`lookup` gives a known tag's site to the readers.
    """

    def __init__(self, building: Building, sites: list[TagSite] | None = None):
        self.building = building
        self.sites = candidate_tag_sites(building) if sites is None else list(sites)
        self._pos = np.array([s.position for s in self.sites]).reshape(-1, 3)
        self._floor = np.array([s.floor for s in self.sites], dtype=np.int64)
        self._by_id = {s.id: i for i, s in enumerate(self.sites)}
        self._tags: dict[str, int] = {}
        self._taken = np.zeros(len(self.sites), dtype=bool)

    def __len__(self) -> int:
        return len(self._tags)

    @property
    def free(self) -> np.ndarray:
        """(len(sites),) bool: the sites no tag is associated with yet."""
        return ~self._taken

    def lookup(self, tag_id: str) -> TagSite | None:
        """The site a tag was associated with, or None for an unknown tag."""
        i = self._tags.get(tag_id)
        return None if i is None else self.sites[i]

    def assign(self, tag_id: str, site_id: str) -> TagSite:
        """Associate a tag with a known site (a surveyed tag, or ground truth in a simulation)."""
        if site_id not in self._by_id:
            raise KeyError(f"no tag site {site_id!r} in building {self.building.name!r}")
        i = self._by_id[site_id]
        self._bind(tag_id, i)
        return self.sites[i]

    def forget(self, tag_id: str) -> None:
        """Drop a tag's association (its site is free again); unknown ids are ignored."""
        i = self._tags.pop(tag_id, None)
        if i is not None:
            self._taken[i] = False

    def _bind(self, tag_id: str, i: int) -> None:
        old = self._tags.get(tag_id)
        if old is not None:
            self._taken[old] = False
        self._tags[tag_id] = i
        self._taken[i] = True

    def costs(self, position: np.ndarray, floor: int | None = None,
              sigma: float | np.ndarray | None = None) -> np.ndarray:
        """Distance cost of every site for a tag placed at ``position`` (2,) or (3,) [m].

        The cost is the squared horizontal Mahalanobis distance, ``sigma`` being the
        position uncertainty: a standard deviation [m] (isotropic) or a 2x2 covariance
        [m^2]; default 1 m. Sites on another floor than ``floor`` (given, or found from
        the z of a 3-D position) cost infinity.
        """
        p = np.asarray(position, dtype=float).ravel()
        if p.shape not in ((2,), (3,)) or not np.all(np.isfinite(p)):
            raise ValueError(f"tag position must be a finite (2,) or (3,) point [m], got {position!r}")
        if floor is None and p.shape == (3,):
            floor = int(self.building.floor_of_z(p[2]))
        cov = _covariance(sigma)
        d = self._pos[:, :2] - p[:2]
        cost = np.einsum("ni,ij,nj->n", d, np.linalg.inv(cov), d)
        if floor is not None:
            cost[self._floor != floor] = np.inf
        return cost

    def associate(self, tag_id: str, position: np.ndarray, floor: int | None = None,
                  sigma: float | np.ndarray | None = None, gate: float | None = None) -> TagSite | None:
        """Associate a newly placed tag with the most probable free site and return it.

        A tag already in the database keeps its site (repeated deployments are
        idempotent). Sites holding another tag are skipped. If no free site is left on
        the floor, the other floors' sites are considered. With ``gate`` (in standard
        deviations) a site farther than that is not taken and None is returned.
        """
        known = self.lookup(tag_id)
        if known is not None:
            return known
        cost = self.costs(position, floor, sigma)
        free = np.where(self._taken, np.inf, cost)
        if not np.isfinite(free).any():
            free = np.where(self._taken, np.inf, self.costs(position, None, sigma))
        if not np.isfinite(free).any():
            raise LookupError(f"no free tag site left in building {self.building.name!r} "
                              f"for tag {tag_id!r} ({len(self.sites)} sites, all tagged)")
        i = int(np.argmin(free))
        if gate is not None and free[i] > gate ** 2:
            return None
        self._bind(tag_id, i)
        return self.sites[i]


def _covariance(sigma: float | np.ndarray | None) -> np.ndarray:
    if sigma is None:
        return np.eye(2)
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 0:
        if not (s > 0 and np.isfinite(s)):
            raise ValueError(f"sigma must be a positive distance [m], got {sigma!r}")
        return np.eye(2) * float(s) ** 2
    if s.shape != (2, 2) or not np.all(np.isfinite(s)) or np.any(np.linalg.eigvalsh((s + s.T) / 2) <= 0):
        raise ValueError(f"sigma must be a std [m] or a positive-definite 2x2 covariance [m^2], "
                         f"got {sigma!r}")
    return s
