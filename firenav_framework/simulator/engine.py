"""``simulate(scenario, seed)``: plan, walk, sense; one deterministic run.

Order of work: the real building is made from the plan (:mod:`.world`: furniture, the
plan's errors); the planner turns every leader's plan into legs (tags get stuck as the
first deploying agent passes doors); followers copy their leader's legs ``lag_s``
later; each :class:`~.movement.Walker` places footfalls; the foot kinematics give
the IMU's ideal readings, which the grade's errors corrupt; the body tracks drive the
radio world (breadcrumb drops, RSSI packets), the UWB ranges, the RFID reads and the
barometers' pressures (:mod:`.barometer`).

Every random choice draws from its own generator, seeded from ``seed`` and a stable
name (the agent id and what is drawn), so the same seed gives the same result and
adding an agent does not change the others' IMU noise.
"""
from __future__ import annotations

import dataclasses
import zlib
from pathlib import Path

import numpy as np

from ..building import Anchor, load_building
from ..messages import (BreadcrumbDrop, GroundTruth, Range, RssiReading, TagDeployment,
                        TagDetection)
from .gait import FootKinematics, foot_kinematics
from .imu_errors import IndoorField, corrupt, earth_field_enu, magnetometer
from .imu_grades import error_specs, get_grade
from .imu_ideal import device_matrix, ideal_imu
from .mount import MountMotion, imu_kinematics, mount_motion, rocking_on_all_fours
from .movement import BodyTrack, Walker
from .planner import Planner
from .barometer import barometer_frames
from .breadcrumb_faults import breadcrumb_fates
from .radio import LinkModel, Node, drawn_radio, packet_readings, simulate_dispensers
from .result import AgentTruth, ImuRecord, SimulationResult
from .rfid import rfid_detections
from .scenario import AgentSpec, Scenario, load_scenario
from .uwb import uwb_ranges
from .world import WorldError, build_world

RADIO_HEIGHT = 1.2      # worn radio above the floor [m]


def rng_for(seed: int, *names: str) -> np.random.Generator:
    """A generator for one purpose: stable across runs and independent of the others."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, *(zlib.crc32(n.encode()) for n in names)])


def simulate(scenario: Scenario | str | Path, seed: int = 0, *, duration_s: float | None = None,
             building=None, imu_errors: str | None = None,
             imu_grade: str | None = None) -> SimulationResult:
    """Run ``scenario`` (a Scenario, a file or a bundled name) with ``seed``.

    ``duration_s`` caps the run (else the scenario's ``duration_s``, else until every
    plan has ended plus ``end_still_s``). ``imu_errors`` (one of
    :data:`~.imu_grades.IMU_ERRORS`) replaces every IMU's own ``errors`` setting,
    ``imu_grade`` (a grade name) every IMU's ``grade`` (a consumer-IMU variant of a
    scenario: the same walk and every other sensor's signal unchanged).
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    m = sc.model
    plan = building if building is not None else load_building(sc.building_path)
    # everything below happens in the real building; the pipeline gets the plan
    b = _world(sc, plan, seed)
    planner = Planner(b, sc, rng_for(seed, "planner"))

    # -- movement -------------------------------------------------------------------
    walkers: dict[str, Walker] = {}
    plans: dict[str, tuple] = {}
    for i, agent in enumerate(m.agents):
        if agent.follow is not None:
            continue
        start, legs = planner.plan(agent, sc.steps[agent.id], ("agents", i),
                                   rng_for(seed, "deviate", agent.id))
        plans[agent.id] = (start, legs, agent.start.time_s)
        person = agent.person.drawn(rng_for(seed, "person", agent.id))
        walkers[agent.id] = _walk(b, sc, seed, agent, person, start, legs, agent.start.time_s,
                                  emit=True)
    for agent in m.agents:
        if agent.follow is None:
            continue
        start, legs, t_lead = plans[agent.follow.agent]
        leader = walkers[agent.follow.agent].person
        person = agent.person.drawn(rng_for(seed, "person", agent.id)).model_copy(
            update={"speed_scale": leader.speed_scale})
        t0 = max(agent.start.time_s, t_lead) + agent.follow.lag_s
        walkers[agent.id] = _walk(b, sc, seed, agent, person, start, legs, t0, emit=False)

    t_end = max(w.t for w in walkers.values()) + m.end_still_s
    cap = duration_s if duration_s is not None else m.duration_s
    if cap is not None:
        t_end = min(t_end, float(cap))

    # -- per agent: IMU and truth ----------------------------------------------------
    env = m.environment
    lat = env.latitude_deg if env.latitude_deg is not None else (
        b.georef.lat if b.georef is not None else 50.0)
    imu: dict[str, ImuRecord] = {}
    truth: dict[str, AgentTruth] = {}
    bodies: dict[str, BodyTrack] = {}
    for agent in m.agents:
        w = walkers[agent.id]
        body = w.body_track()
        bodies[agent.id] = body
        tt = np.arange(0.0, t_end + 1e-9, 1.0 / m.truth_rate_hz)
        pos, hd = body.at(tt)
        kin = mount = None
        table = w.stride_table()
        cfg = agent.sensors.imu
        if cfg is not None and cfg.switch_on_s < t_end - 2.0 / cfg.rate_hz:  # else: not on yet
            rec, kin, mount = _imu(b, sc, seed, agent, table, w, t_end, lat, imu_errors,
                                   imu_grade)
            imu[agent.id] = rec
        truth[agent.id] = AgentTruth(
            agent=agent.id, t=tt, position=pos, heading=hd,
            floor=np.asarray(b.floor_of_z(pos[:, 2]), int), motion=body.motion_at(tt),
            foot=kin, mount=mount, strides=table, person=w.person.model_dump(),
            checkpoints=[c for c in w.checkpoints if c.t_end <= t_end])

    messages: dict[str, list] = {"truth": _truth_messages(truth)}
    extra: dict[str, list] = {}

    # -- fixed nodes ----------------------------------------------------------------
    anchors = {a.id: {"kind": a.kind, "position": np.asarray(a.position, float),
                      "floor": a.floor} for a in b.anchors}
    for a in m.anchors:
        anchors[a.id] = {"kind": a.kind, "floor": a.floor, "position": np.array(
            [a.position[0], a.position[1], b.floor(a.floor).z + a.height_m])}

    def worn(agent_id: str, height: float):
        body = bodies[agent_id]

        def track(t: np.ndarray):
            p, h = body.at(t)
            fl = np.asarray(b.floor_of_z(p[:, 2]), int)
            return p + np.array([0.0, 0.0, height]), fl, h
        return track

    # -- tags -------------------------------------------------------------------------
    tags: dict[str, dict] = {}
    for aid, w in walkers.items():
        for dep in w.deployments:
            if dep.t > t_end:
                continue
            feature = next(f for f, (tid, _) in planner.tags.tags.items() if tid == dep.tag_id)
            tags[dep.tag_id] = {"feature": feature, "position": dep.position, "t": dep.t,
                                "agent": aid}
    if any(a.sensors.rfid is not None for a in m.agents):
        messages["tags"] = sorted(
            (TagDeployment(t=v["t"], agent=v["agent"], device=f"{v['agent']}/rfid", tag_id=k)
             for k, v in tags.items()), key=lambda x: x.t)
        det = []
        tag_list = [(k, v["position"], v["t"]) for k, v in tags.items()]
        for agent in m.agents:
            cfg = agent.sensors.rfid
            if cfg is None:
                continue
            ta = np.arange(0.0, t_end, 1.0 / cfg.rate_hz)
            p, _, _ = worn(agent.id, cfg.reader_height_m)(ta)
            for t, tag_id, reads, rssi in rfid_detections(ta, p, tag_list, cfg,
                                                          rng_for(seed, "rfid", agent.id)):
                det.append(TagDetection(t=t, agent=agent.id, device=f"{agent.id}/rfid",
                                        tag_id=tag_id, reader=f"{agent.id}/rfid",
                                        rssi_dbm=rssi, reads=reads))
        messages["rfid"] = sorted(det, key=lambda x: x.t)

    # -- barometers -------------------------------------------------------------------
    if any(a.sensors.barometer is not None for a in m.agents):
        messages["baro"], extra["baro"] = barometer_frames(
            b, m, bodies, t_end, lambda *names: rng_for(seed, *names))

    # -- UWB --------------------------------------------------------------------------
    if any(a.sensors.uwb is not None for a in m.agents):
        model = LinkModel(m.radio, b, m.fires, rng_for(seed, "uwb-walls"))
        ranges, info = [], []
        for i, agent in enumerate(m.agents):
            cfg = agent.sensors.uwb
            if cfg is None:
                continue
            ids = cfg.anchors if cfg.anchors is not None else [
                k for k, v in anchors.items() if v["kind"] == "uwb"]
            if not ids:
                raise sc.problem(("agents", i, "sensors", "uwb"), "no UWB anchor: the "
                                 "building has none; add one under 'anchors:' or list ids")
            for aid in ids:
                if aid not in anchors:
                    raise sc.problem(("agents", i, "sensors", "uwb", "anchors"),
                                     f"no anchor '{aid}'; anchors: {', '.join(anchors)}")
                an = anchors[aid]
                rng = rng_for(seed, "uwb", agent.id, aid)
                tu = np.arange(rng.uniform(0, 1 / cfg.rate_hz), t_end, 1.0 / cfg.rate_hz)
                p, fl, _ = worn(agent.id, cfg.height_m)(tu)
                walls = model.walls_between(p[:, :2], fl, np.repeat(an["position"][None, :2],
                                                                    len(tu), 0))
                keep, meas, tr = uwb_ranges(tu, p, fl, an["position"], an["floor"], cfg, walls,
                                            b.floor(0).height, rng)
                for j in np.flatnonzero(keep):
                    ranges.append(Range(t=float(tu[j]), agent=agent.id, device=f"{agent.id}/uwb",
                                        a=f"{agent.id}/uwb", b=aid,
                                        range_m=round(float(meas[j]), 3), sigma_m=cfg.sigma_m,
                                        method="uwb"))
                    info.append({"t": float(tu[j]), "a": f"{agent.id}/uwb", "b": aid,
                                 "true_range_m": round(float(tr["true_range_m"][j]), 3),
                                 "obstructions": int(tr["obstructions"][j]),
                                 "outlier": bool(tr["outlier"][j])})
        order = np.argsort([r.t for r in ranges], kind="stable")
        messages["uwb"] = [ranges[k] for k in order]
        extra["uwb"] = [info[k] for k in order]

    # -- breadcrumbs and RSSI ----------------------------------------------------------
    dispensers = [a for a in m.agents if a.sensors.dispenser is not None]
    radios = [a for a in m.agents if (a.sensors.radio if a.sensors.radio is not None
                                      else bool(dispensers))]
    breadcrumbs: dict[str, dict] = {}
    radio = drawn_radio(m.radio, rng_for(seed, "radio-draw", b.name))
    if radios or dispensers:
        model = LinkModel(radio, b, m.fires, rng_for(seed, "radio-field"))
        fixed = []
        base = m.radio.base_station
        if base is not None and base in anchors:
            fixed.append(Node(base, position=anchors[base]["position"],
                              floor=anchors[base]["floor"]))
        worn_nodes = {a.id: Node(a.id, agent=a.id, track=worn(a.id, RADIO_HEIGHT))
                      for a in radios + dispensers}
        drops = simulate_dispensers(model, fixed, [(worn_nodes[a.id], a.sensors.dispenser)
                                                   for a in dispensers], t_end,
                                    rng_for(seed, "dispensers"),
                                    floor_z=lambda f: b.floor(f).z)
        fates = breadcrumb_fates(
            drops, {a.id: a.sensors.dispenser.faults for a in dispensers},
            {a.id: worn(a.id, 0.0) for a in m.agents}, m.fires, b, t_end,
            rng_for(seed, "breadcrumb-fates"))
        for d in drops:
            breadcrumbs[d.node_id] = {"position": d.position, "floor": d.floor, "t": d.t,
                                      "agent": d.agent, **fates[d.node_id].record()}
        messages["drops"] = [BreadcrumbDrop(t=d.t, agent=d.agent, device=f"{d.agent}/dispenser",
                                            node_id=d.node_id) for d in drops]
        nodes = fixed + [fates[d.node_id].node(d) for d in drops] + [worn_nodes[a.id]
                                                                      for a in radios]
        readings = packet_readings(model, nodes, t_end, rng_for(seed, "packets"))
        messages["rssi"] = [RssiReading(t=t, agent=rx.agent or (
            tx if tx in worn_nodes else ""), device=rx.id if not rx.agent else f"{rx.agent}/radio",
                                        tx=tx, rx=rx.id, rssi_dbm=r)
                            for t, tx, _, r, rx in readings]

    anchors_out = {k: {**v, "position": v["position"]} for k, v in anchors.items()}
    # the scenario's own anchors (a UWB anchor left at the entrance) belong to the building
    # the pipeline sees, so estimators can place the ranges measured to them
    fixed = [Anchor(id=k, kind=v["kind"], position=v["position"], floor=v["floor"])
             for k, v in anchors.items()]
    world = dataclasses.replace(b, anchors=fixed)
    given = world if b is plan else dataclasses.replace(plan, anchors=fixed)
    return SimulationResult(scenario=sc, seed=int(seed), building=given, world=world,
                            t_end=float(t_end), imu=imu, truth=truth, messages=messages,
                            tags=tags, breadcrumbs=breadcrumbs, anchors=anchors_out, extra=extra,
                            radio=radio.model_dump(exclude={"base_station", "draw"}))


def _world(sc: Scenario, plan, seed: int):
    """The building as it really is (the plan itself when the scenario has no ``world``)."""
    if sc.model.world is None:
        return plan
    base = load_building(sc.world_path) if sc.world_path is not None else None
    try:
        return build_world(plan, sc.model.world, rng_for(seed, "world"), base=base)
    except WorldError as exc:
        raise sc.problem(exc.where, str(exc)) from None


def _walk(b, sc: Scenario, seed: int, agent: AgentSpec, person, start, legs, t0: float,
          emit: bool) -> Walker:
    floor = b.floor(start.floor)
    w = Walker(person, sc.gaits, rng_for(seed, "gait", agent.id), t0=t0, xy=start.xy,
               floor=start.floor, z=floor.z, heading=start.heading, emit_deployments=emit,
               rockers=sc.model.foot_model == "realistic")
    w.run(legs)
    return w


def _imu(b, sc: Scenario, seed: int, agent: AgentSpec, table, walker: Walker, t_end: float,
         lat: float, imu_errors: str | None, imu_grade: str | None = None
         ) -> tuple[ImuRecord, FootKinematics, MountMotion | None]:
    cfg = agent.sensors.imu
    env = sc.model.environment
    errors = imu_errors or cfg.errors
    grade = imu_grade or cfg.grade
    gyro_spec, accel_spec, mag_spec = error_specs(get_grade(grade), errors, gyro=cfg.gyro,
                                                  accel=cfg.accel, mag=cfg.mag)
    fs = cfg.rate_hz
    phase = rng_for(seed, "clock", agent.id).uniform(0, 1.0 / fs)
    t = np.arange(cfg.switch_on_s + phase, t_end, 1.0 / fs)
    if table is None:   # never moves: a foot at rest at its start pose
        kin = FootKinematics.at_rest(t, walker.foot_p, [walker.foot_yaw, walker.foot_pitch, 0.0])
    else:
        if cfg.mount is not None:
            table = rocking_on_all_fours(table, cfg.mount)
        kin = foot_kinematics(table, t)
    mount = None
    if cfg.mount is not None and sc.model.foot_model == "realistic":
        person = walker.person
        mount = mount_motion(kin, fs, cfg.mount, np.array([0.0, 0.0, -person.imu_height]),
                             rng_for(seed, "mount", agent.id), gravity=env.gravity)
    dev = device_matrix(cfg.axes, cfg.mount_deg)
    f, w = ideal_imu(kin, gravity=env.gravity, latitude_deg=lat if env.earth_rate else None,
                     device=dev, mount=mount)
    warm = t - cfg.switch_on_s
    temp = env.temperature.change_k * (1.0 - np.exp(-warm / env.temperature.tau_s))
    acc, sat_a, err_a = corrupt(f, accel_spec, fs, rng_for(seed, "accel", agent.id),
                                temperature_delta=temp)
    gyr, sat_g, err_g = corrupt(w, gyro_spec, fs, rng_for(seed, "gyro", agent.id),
                                temperature_delta=temp, specific_force=f)
    mag = None
    if cfg.magnetometer:
        mrng = rng_for(seed, "mag", agent.id)
        mg = env.magnetic
        earth = earth_field_enu(mg.intensity_ut, mg.inclination_deg, mg.declination_deg)
        if b.georef is not None:
            bear = np.radians(b.georef.bearing)
            rot = np.array([[np.cos(bear), np.sin(bear)], [-np.sin(bear), np.cos(bear)]])
            earth = np.array([*(rot.T @ earth[:2]), earth[2]])
        field = IndoorField.random(mrng, mg.indoor_disturbance_ut)
        pose = imu_kinematics(kin, mount)          # where the IMU is and how it is turned
        b_n = earth + field(pose.position)
        b_b = np.einsum("nji,nj->ni", pose.c_bn, b_n) @ dev.T
        mag = magnetometer(b_b, mag_spec, mrng)
    rec = ImuRecord(agent=agent.id, device=f"{agent.id}/imu", grade=grade, rate_hz=fs,
                    frame=cfg.axes, time=t, accel=acc, gyro=gyr, mag=mag,
                    saturated=sat_a | sat_g,
                    errors={"condition": errors, "gyro": err_g.as_dict(),
                            "accel": err_a.as_dict(),
                            "gyro_spec": gyro_spec.model_dump(),
                            "accel_spec": accel_spec.model_dump()})
    return rec, kin, mount


def _truth_messages(truth: dict[str, AgentTruth]) -> list[GroundTruth]:
    out = []
    for a, tr in truth.items():
        for i in range(len(tr.t)):
            out.append(GroundTruth(t=float(tr.t[i]), agent=a, position=tr.position[i],
                                   heading=float(tr.heading[i]), floor=int(tr.floor[i])))
    out.sort(key=lambda g: g.t)
    return out
