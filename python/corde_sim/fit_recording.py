"""Recordings for corde_fit: tracked points along a cable over time (CSV, rosbag) and the poses of
the gripper that moved it, turned into a grasp's keyframes (docs/calibration.md)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from typing import List, Optional

import numpy as np


class FitError(Exception):
    """Bad input or a failed run; the message names the file, key or parameter."""


# ---------------------------------------------------------------------------------------------
# Recordings
# ---------------------------------------------------------------------------------------------


@dataclass
class Recording:
    """Tracked points over time, optionally their arc lengths and the gripper's poses.

    times (F,), points (F, M, 3) in m; arc_lengths (M,) in m or None (estimated by projection);
    gripper: None or (times (K,), positions (K, 3), quaternions (K, 4) as [qx, qy, qz, qw]).
    wrenches: None or the gripper's measured wrench, (times (W,), values (W, 3) forces or (W, 6)
    forces and torques): what a force-torque sensor reads, the force (N) the cable exerts on the
    gripper and its torque (N m) about the grasped segment's midpoint, in wrench_frame: "world",
    or "holder" (the grasp's holder frame, the node's grasp/<name>).
    """

    times: np.ndarray
    points: np.ndarray
    arc_lengths: Optional[np.ndarray] = None
    gripper: Optional[tuple] = None
    wrenches: Optional[tuple] = None
    wrench_frame: str = "world"

    def check(self, source: str = "recording") -> None:
        t, p = self.times, self.points
        if t.ndim != 1 or len(t) < 2:
            raise FitError(f"{source}: needs at least 2 frames, got {len(t)}")
        if p.shape != (len(t), p.shape[1], 3) or p.shape[1] < 1:
            raise FitError(f"{source}: points must be frames x points x 3, got {p.shape}")
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(p)):
            raise FitError(f"{source}: non-finite time or coordinate")
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0)) + 1
            raise FitError(f"{source}: times must increase strictly (frame {k}: {t[k]} s)")
        if t[0] < 0:
            raise FitError(f"{source}: times must be >= 0 (scene time), got {t[0]}")
        if self.arc_lengths is not None:
            s = np.asarray(self.arc_lengths, float)
            if s.shape != (p.shape[1],):
                raise FitError(f"{source}: {len(s)} arc lengths for {p.shape[1]} points")
            if np.any(s < 0) or not np.all(np.isfinite(s)):
                raise FitError(f"{source}: arc lengths must be finite and >= 0")
        if self.wrenches is not None:
            wt, wv = self.wrenches
            if wv.ndim != 2 or wv.shape[1] not in (3, 6) or len(wt) != len(wv) or len(wt) < 1:
                raise FitError(f"{source}: wrenches must be times x 3 (force) or x 6 (force, "
                               f"torque), got {wv.shape}")
            if not np.all(np.isfinite(wt)) or not np.all(np.isfinite(wv)):
                raise FitError(f"{source}: non-finite wrench time or value")
            if np.any(np.diff(wt) <= 0) or wt[0] < 0:
                raise FitError(f"{source}: wrench times must be >= 0 and increase strictly")


# A CSV recording's wrench columns, after the points' (docs/calibration.md).
WRENCH_COLUMNS = ["fx", "fy", "fz", "tx", "ty", "tz"]


def write_csv_recording(path: str, rec: Recording) -> None:
    """Writes the CSV format read by read_csv_recording (docs/calibration.md)."""
    m = rec.points.shape[1]
    with open(path, "w", newline="") as f:
        f.write("# corde_fit recording: time (s), then x,y,z (m) of each tracked point\n")
        if rec.arc_lengths is not None:
            f.write("# arc_length," + ",".join(repr(float(s)) for s in rec.arc_lengths) + "\n")
        w = csv.writer(f)
        wcols = []
        if rec.wrenches is not None:
            if rec.wrench_frame != "world" or not np.array_equal(rec.wrenches[0], rec.times):
                raise FitError(f"{path}: a CSV holds wrenches in the world frame at the frames' "
                               f"times")
            wcols = WRENCH_COLUMNS[: rec.wrenches[1].shape[1]]
        w.writerow(["time"] + [f"{c}{i}" for i in range(m) for c in "xyz"] + wcols)
        for k, (t, pts) in enumerate(zip(rec.times, rec.points)):
            row = [repr(float(t))] + [repr(float(v)) for v in pts.reshape(-1)]
            if wcols:
                row += [repr(float(v)) for v in rec.wrenches[1][k]]
            w.writerow(row)


def read_csv_recording(path: str) -> Recording:
    """Reads a recording CSV: a header `time,x0,y0,z0,x1,...` (optionally ending in the gripper's
    measured wrench, `fx,fy,fz` or `fx,fy,fz,tx,ty,tz`, world frame), one row per frame; `#`
    lines are comments, except `# arc_length,s0,s1,...` which gives the points' arc lengths (m)."""
    arc = None
    rows = []
    header = None
    try:
        f = open(path, newline="")
    except OSError as e:
        raise FitError(f"{path}: {e.strerror}") from None
    with f:
        for lineno, line in enumerate(f, 1):
            line = line.strip().lstrip("\ufeff")
            if not line:
                continue
            if line.startswith("#"):
                body = line[1:].strip()
                if body.startswith("arc_length"):
                    try:
                        arc = np.array([float(v) for v in body.split(",")[1:]])
                    except ValueError:
                        raise FitError(f"{path} line {lineno}: arc_length values must be numbers")
                continue
            cells = [c.strip() for c in line.split(",")]
            if header is None:
                header = cells
                nw = next((k for k in (6, 3) if header[-k:] == WRENCH_COLUMNS[:k]), 0)
                if "fx" in header and not nw:
                    raise FitError(f"{path} line {lineno}: the wrench columns must close the "
                                   f"header as fx,fy,fz or fx,fy,fz,tx,ty,tz, got '{line}'")
                if (header[0] != "time" or (len(header) - 1 - nw) % 3 != 0
                        or len(header) - nw < 4):
                    raise FitError(f"{path} line {lineno}: header must be time,x0,y0,z0,... "
                                   f"(3 columns per point), got '{line}'")
                continue
            if len(cells) != len(header):
                raise FitError(f"{path} line {lineno}: {len(cells)} values, the header has "
                               f"{len(header)}")
            try:
                rows.append([float(c) for c in cells])
            except ValueError:
                raise FitError(f"{path} line {lineno}: not a number in '{line}'") from None
    if header is None:
        raise FitError(f"{path}: no header line (time,x0,y0,z0,...)")
    data = np.array(rows).reshape(len(rows), len(header))
    nw = next((k for k in (6, 3) if header[-k:] == WRENCH_COLUMNS[:k]), 0)
    rec = Recording(times=data[:, 0], points=data[:, 1:len(header) - nw].reshape(len(rows), -1, 3),
                    arc_lengths=arc)
    if nw:
        rec.wrenches = (data[:, 0].copy(), data[:, len(header) - nw:].copy())
    rec.check(path)
    return rec


class ToolChain:
    """Forward kinematics of a URDF from its root link to one link (the gripper's tool frame):
    fixed, revolute, continuous and prismatic joints, origins as xyz + rpy (fixed axes), as
    robot_state_publisher computes them. The root link is taken to be the world frame."""

    def __init__(self, urdf_path: str, tool_link: str):
        import xml.etree.ElementTree as ET

        try:
            root = ET.parse(urdf_path).getroot()
        except (OSError, ET.ParseError) as e:
            raise FitError(f"{urdf_path}: cannot read the URDF: {e}") from None
        joints = {}
        for j in root.findall("joint"):
            child = j.find("child").get("link")
            o = j.find("origin")
            xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
            rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
            a = j.find("axis")
            axis = [float(v) for v in (a.get("xyz") if a is not None else "1 0 0").split()]
            joints[child] = (j.get("name"), j.get("type"), j.find("parent").get("link"),
                             np.array(xyz), np.array(rpy), np.array(axis) / np.linalg.norm(axis))
        links = {lk.get("name") for lk in root.findall("link")}
        if tool_link not in links:
            raise FitError(f"{urdf_path}: no link '{tool_link}' (links: "
                           f"{', '.join(sorted(links))})")
        self.chain = []  # root to tool
        link = tool_link
        while link in joints:
            self.chain.insert(0, joints[link])
            link = joints[link][2]
        self.moving = [j[0] for j in self.chain if j[1] in ("revolute", "continuous", "prismatic")]
        for j in self.chain:
            if j[1] not in ("fixed", "revolute", "continuous", "prismatic"):
                raise FitError(f"{urdf_path}: joint '{j[0]}' is {j[1]}; the tool's chain may "
                               f"have fixed, revolute, continuous and prismatic joints")

    def pose(self, values: dict):
        """The tool frame's (position (3,), quaternion [qx, qy, qz, qw]) for joint values."""
        from scipy.spatial.transform import Rotation as R

        p, r = np.zeros(3), R.identity()
        for name, kind, _, xyz, rpy, axis in self.chain:
            p = p + r.apply(xyz)
            r = r * R.from_euler("xyz", rpy)
            q = float(values.get(name, 0.0))
            if kind in ("revolute", "continuous"):
                r = r * R.from_rotvec(axis * q)
            elif kind == "prismatic":
                p = p + r.apply(axis * q)
        return p, r.as_quat()


def read_bag_recording(path: str, points_topic: str = "/cable/points",
                       gripper_topic: Optional[str] = None,
                       tool: Optional[ToolChain] = None, wrench_topic: Optional[str] = None,
                       grasp: Optional[str] = None, world_frame: str = "world") -> Recording:
    """Reads a rosbag: tracked points as geometry_msgs/PoseArray (positions in order along the
    cable) or sensor_msgs/PointCloud2 (fields x, y, z, in order), the gripper as
    geometry_msgs/PoseStamped, or as sensor_msgs/JointState turned into the tool frame's pose by
    `tool` (forward kinematics). Times are the messages' header stamps minus the first points
    message's stamp (scene time 0). wrench_topic: geometry_msgs/WrenchStamped, the force and
    torque the cable exerts on the gripper, in world_frame (or an empty frame_id) or in the
    grasp's holder frame (a frame_id ending in grasp/<grasp>, as the node's reaction topic)."""
    try:
        import rosbag  # python3-rosbag (Debian)
    except ImportError:
        raise FitError("reading a rosbag needs python3-rosbag (apt-get install python3-rosbag)")
    try:
        bag = rosbag.Bag(path)
    except Exception as e:  # rosbag raises its own types (ROSBagException, IOError)
        raise FitError(f"{path}: cannot open as a rosbag: {e}") from None
    times, frames, gt, gp, gq = [], [], [], [], []
    wt, wv, wframes = [], [], set()
    topics = [points_topic] + ([gripper_topic] if gripper_topic else [])
    topics += [wrench_topic] if wrench_topic else []
    with bag:
        info = bag.get_type_and_topic_info().topics
        for t in topics:
            if t not in info:
                raise FitError(f"{path}: no topic '{t}' (topics: {', '.join(sorted(info))})")
        for topic, msg, stamp in bag.read_messages(topics=topics):
            st = msg.header.stamp.to_sec() if msg.header.stamp.to_sec() > 0 else stamp.to_sec()
            if topic == points_topic:
                times.append(st)
                frames.append(_points_of_message(msg, path, topic))
            elif topic == wrench_topic:
                if msg._type != "geometry_msgs/WrenchStamped":
                    raise FitError(f"{path}: '{topic}' has {msg._type}; the gripper's wrench must "
                                   f"be geometry_msgs/WrenchStamped")
                fr, tq = msg.wrench.force, msg.wrench.torque
                wt.append(st)
                wv.append([fr.x, fr.y, fr.z, tq.x, tq.y, tq.z])
                wframes.add(msg.header.frame_id.lstrip("/"))
            elif msg._type == "sensor_msgs/JointState":
                if tool is None:
                    raise FitError(f"{path}: '{topic}' has joint states: give the robot's URDF "
                                   f"and its tool link (--urdf, --tool-link)")
                values = dict(zip(msg.name, msg.position))
                missing = [j for j in tool.moving if j not in values]
                if missing:
                    raise FitError(f"{path}: '{topic}' at {st:.6f} s: no value for joint "
                                   f"'{missing[0]}' of the tool's chain")
                p, q = tool.pose(values)
                gt.append(st)
                gp.append(list(p))
                gq.append(list(q))
            elif msg._type == "geometry_msgs/PoseStamped":
                p, q = msg.pose.position, msg.pose.orientation
                gt.append(st)
                gp.append([p.x, p.y, p.z])
                gq.append([q.x, q.y, q.z, q.w])
            else:
                raise FitError(f"{path}: '{topic}' has {msg._type}; the gripper must be "
                               f"geometry_msgs/PoseStamped or sensor_msgs/JointState")
    if not frames:
        raise FitError(f"{path}: no messages on '{points_topic}'")
    m = {len(f) for f in frames}
    if len(m) != 1:
        raise FitError(f"{path}: '{points_topic}': the number of tracked points changes "
                       f"({sorted(m)}); every frame must have the same points in the same order")
    t0 = times[0]
    order = np.argsort(times, kind="stable")
    rec = Recording(times=np.array(times)[order] - t0, points=np.array(frames)[order])
    if gripper_topic:
        if not gt:
            raise FitError(f"{path}: no messages on '{gripper_topic}'")
        o = np.argsort(gt, kind="stable")
        rec.gripper = (np.array(gt)[o] - t0, np.array(gp)[o], np.array(gq)[o])
    if wrench_topic:
        if not wt:
            raise FitError(f"{path}: no messages on '{wrench_topic}'")
        if len(wframes) != 1:
            raise FitError(f"{path}: '{wrench_topic}': the frame_id changes ({sorted(wframes)})")
        frame = wframes.pop()
        if frame in ("", world_frame.lstrip("/")):
            rec.wrench_frame = "world"
        elif grasp and (frame == f"grasp/{grasp}" or frame.endswith(f"/grasp/{grasp}")
                        or frame.endswith(f"grasp/{grasp}")):
            rec.wrench_frame = "holder"
        else:
            raise FitError(f"{path}: '{wrench_topic}' is in frame '{frame}': give wrenches in the "
                           f"world frame ('{world_frame}', --world-frame) or the grasp's holder "
                           f"frame grasp/{grasp or 'NAME'} (with --grasp NAME)")
        o = np.argsort(wt, kind="stable")
        wtimes = np.array(wt)[o] - t0
        keep = wtimes >= 0  # before the first points message: not scene time
        rec.wrenches = (wtimes[keep], np.array(wv)[o][keep])
    rec.check(f"{path}:{points_topic}")
    return rec


def _points_of_message(msg, path, topic):
    t = msg._type
    if t == "geometry_msgs/PoseArray":
        return [[p.position.x, p.position.y, p.position.z] for p in msg.poses]
    if t == "sensor_msgs/PointCloud2":
        from sensor_msgs import point_cloud2
        return [list(p) for p in point_cloud2.read_points(msg, field_names=("x", "y", "z"))]
    raise FitError(f"{path}: '{topic}' has {t}; tracked points must be geometry_msgs/PoseArray "
                   f"or sensor_msgs/PointCloud2")


def write_bag_recording(path: str, rec: Recording, points_topic: str = "/cable/points",
                        gripper_topic: str = "/gripper/pose", frame_id: str = "world",
                        start: float = 1.0, joints: Optional[tuple] = None,
                        joint_topic: str = "/joint_states", wrench_topic: str = "/gripper/wrench",
                        wrench_frame_id: Optional[str] = None) -> None:
    """Writes a recording as a rosbag in the format read_bag_recording reads (PoseArray points,
    PoseStamped gripper, WrenchStamped wrenches on wrench_topic in wrench_frame_id, default
    frame_id), stamped from `start` s (a bag cannot hold time 0). joints: (times (K,), names,
    values (K, J)) written as sensor_msgs/JointState on joint_topic."""
    _write_bag_events(path, rec, points_topic, gripper_topic, frame_id, start, joints, joint_topic)
    if rec.wrenches is not None:
        import rosbag
        import rospy
        from geometry_msgs.msg import WrenchStamped

        with rosbag.Bag(path, "a") as bag:
            for t, w in zip(*rec.wrenches):
                stamp = rospy.Time.from_sec(start + t)
                msg = WrenchStamped()
                msg.header.stamp, msg.header.frame_id = stamp, wrench_frame_id or frame_id
                w = list(map(float, w)) + [0.0] * (6 - len(w))
                msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = w[:3]
                msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = w[3:]
                bag.write(wrench_topic, msg, stamp)


def _write_bag_events(path, rec, points_topic, gripper_topic, frame_id, start, joints,
                      joint_topic):
    import rosbag
    import rospy
    from geometry_msgs.msg import Pose, PoseArray, PoseStamped
    from sensor_msgs.msg import JointState

    with rosbag.Bag(path, "w") as bag:
        events = [(t, 0, i) for i, t in enumerate(rec.times)]
        if rec.gripper is not None:
            events += [(t, 1, i) for i, t in enumerate(rec.gripper[0])]
        if joints is not None:
            events += [(t, 2, i) for i, t in enumerate(joints[0])]
        for t, kind, i in sorted(events):
            if kind == 2:
                stamp = rospy.Time.from_sec(start + t)
                msg = JointState()
                msg.header.stamp = stamp
                msg.name = list(joints[1])
                msg.position = [float(v) for v in joints[2][i]]
                bag.write(joint_topic, msg, stamp)
                continue
            stamp = rospy.Time.from_sec(start + t)
            if kind == 0:
                msg = PoseArray()
                msg.header.stamp, msg.header.frame_id = stamp, frame_id
                for x in rec.points[i]:
                    p = Pose()
                    p.position.x, p.position.y, p.position.z = map(float, x)
                    p.orientation.w = 1.0
                    msg.poses.append(p)
                bag.write(points_topic, msg, stamp)
            else:
                msg = PoseStamped()
                msg.header.stamp, msg.header.frame_id = stamp, frame_id
                x, q = rec.gripper[1][i], rec.gripper[2][i]
                msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = map(float, x)
                (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
                 msg.pose.orientation.w) = map(float, q)
                bag.write(gripper_topic, msg, stamp)


def read_recording(path: str, points_topic: str = "/cable/points",
                   gripper_topic: Optional[str] = None,
                   tool: Optional[ToolChain] = None, wrench_topic: Optional[str] = None,
                   grasp: Optional[str] = None, world_frame: str = "world") -> Recording:
    if path.endswith(".bag"):
        return read_bag_recording(path, points_topic, gripper_topic, tool, wrench_topic, grasp,
                                  world_frame)
    if wrench_topic:
        raise FitError(f"{path}: a CSV recording has its wrenches in columns fx,fy,fz[,tx,ty,tz], "
                       f"not on a topic")
    if gripper_topic:
        raise FitError(f"{path}: a CSV recording has no gripper poses; the scene's grasp "
                       f"keyframes give the motion (use a rosbag for recorded poses)")
    return read_csv_recording(path)


# ---------------------------------------------------------------------------------------------
# Gripper poses -> grasp keyframes
# ---------------------------------------------------------------------------------------------


def grasp_segment(doc: dict, grasp: str) -> tuple:
    """(rod name or index, segment index) held by the named grasp of a scene document."""
    grasps = doc.get("grasps") or []
    for g in grasps:
        if isinstance(g, dict) and g.get("name") == grasp:
            break
    else:
        names = [g.get("name") for g in grasps if isinstance(g, dict)]
        raise FitError(f"grasps: no grasp named '{grasp}' (grasps: {', '.join(map(str, names))})")
    rods = doc["rods"]
    rod = g.get("rod", rods[0].get("name", "rod0") if len(rods) == 1 else None)
    if rod is None:
        raise FitError(f"grasps.{grasp}.rod: required with several rods")
    r = next((x for x in rods if x.get("name", None) == rod), rods[0])
    n = r.get("elements", 50)
    if not isinstance(n, int):
        raise FitError(f"rods.{rod}.elements: must be a number for a fit with recorded gripper "
                       f"poses, got {n}")
    place = g.get("place", "end")
    if place == "start":
        seg = 0
    elif place == "end":
        seg = n - 1
    elif place == "node":
        seg = min(int(g["value"]), n - 1)
    else:
        raise FitError(f"grasps.{grasp}.place: {place}: give the grasp by start, end or node "
                       f"for recorded gripper poses")
    return rod, seg


def gripper_keyframes(gripper: tuple, holder0_pos: np.ndarray, holder0_quat: np.ndarray,
                      rate: float = 50.0) -> List[dict]:
    """Keyframes (world poses) of a grasp holder rigidly attached to the recorded gripper: the
    holder keeps the pose relative to the gripper it has at the first gripper pose, H(t) =
    T(t) T(0)^-1 H(0). Poses are taken at most `rate` per second, after time 0."""
    from scipy.spatial.transform import Rotation as R

    t, p, q = gripper
    r0 = R.from_quat(q[0])
    rel_p = r0.inv().apply(holder0_pos - p[0])
    rel_r = r0.inv() * R.from_quat(holder0_quat)
    keys, last = [], 0.0
    for k in range(len(t)):
        if t[k] <= 1e-9 or (t[k] - last < (1.0 - 1e-6) / rate and k != len(t) - 1):
            continue
        rk = R.from_quat(q[k])
        pos = p[k] + rk.apply(rel_p)
        quat = (rk * rel_r).as_quat()
        keys.append({"time": float(t[k]), "position": [float(v) for v in pos],
                     "orientation": [float(v) for v in quat / np.linalg.norm(quat)]})
        last = t[k]
    return keys


def write_keyframe_csv(path: str, keys: List[dict]) -> None:
    with open(path, "w") as f:
        f.write("# grasp holder poses from the recorded gripper (corde_fit)\n")
        f.write("time,x,y,z,qx,qy,qz,qw\n")
        for k in keys:
            f.write(",".join(f"{v:.12g}" for v in [k["time"]] + k["position"] + k["orientation"])
                    + "\n")
