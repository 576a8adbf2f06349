"""Reads a teachcam MCAP take with independent ROS 2 readers and checks it against the CSVs.

The messages are decoded by `mcap-ros2-support` from the schemas embedded in the file (not
from teachcam's code); the expected numbers come from the trajectory CSV and, with a robot,
from `teachcam check --joints-out`.

RViz's markers (`/teachcam/markers`, 5 Hz): the tip's sphere at the tip, and, with `--tool`,
the tool's marker spheres where the CSV's pose puts the tool file's markers (rotated here).

Run: python3 -m venv target/ros-venv && target/ros-venv/bin/pip install mcap mcap-ros2-support
     target/ros-venv/bin/python scripts/ros2/read_mcap.py take.mcap TRAJ.csv [JOINTS.csv] \
         [--frame-id world] [--cameras N] [--tool TOOL.json]
Prints one JSON line with what it counted; exits 1 naming the first check that fails.
"""

import argparse
import csv
import json
import math
import sys

from mcap_ros2.reader import read_ros2_messages


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def stamp_s(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def rotate(q, v):
    """v rotated by the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    # v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z)
    ux = (y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0])
    uux = (y * ux[2] - z * ux[1], z * ux[0] - x * ux[2], x * ux[1] - y * ux[0])
    return [v[i] + 2 * w * ux[i] + 2 * uux[i] for i in range(3)]


def check_marker_fields(k):
    """The fields a marker leaves at their defaults, and its lifetime: decoded in place, they
    show that the fields after the points (texture, uv_coordinates, mesh_file) line up."""
    if k.action != 0 or k.frame_locked or k.mesh_use_embedded_materials:
        fail(f"marker {k.id}: action {k.action}, frame_locked, mesh_use_embedded_materials")
    if (k.text, k.mesh_resource, k.texture_resource, k.texture.format, k.mesh_file.filename) != (
        "", "", "", "", ""
    ):
        fail(f"marker {k.id}: a text or resource field that should be empty")
    if len(k.mesh_file.data) or len(k.texture.data) or len(k.uv_coordinates) or len(k.colors):
        fail(f"marker {k.id}: a sequence that should be empty")
    if abs(stamp_s(k.lifetime) - 0.4) > 1e-9 or abs(k.color.a - 1.0) > 1e-6:
        fail(f"marker {k.id}: lifetime {stamp_s(k.lifetime)} s, alpha {k.color.a}")


def check_markers(messages, posed, frame_id, tool):
    """The marker arrays against the posed rows; returns (count, worst metres)."""
    # The frames that carry markers: the first posed, then each first posed 0.2 s after.
    expected, last = [], None
    for row in posed:
        t = float(row["time_s"])
        if last is None or t < last or t - last >= 0.2 * (1 - 1e-9):
            expected.append(row)
            last = t
    if len(messages) != len(expected):
        fail(f"{len(messages)} marker arrays, expected {len(expected)} (5 Hz over the posed frames)")
    worst = 0.0
    for row, m in zip(expected, messages):
        markers = m.ros_msg.markers
        by_id = {k.id: k for k in markers}
        tip = by_id.get(1)
        if tip is None or tip.type != 2:
            fail("no tip sphere (id 1, SPHERE)")
        for k in markers:
            if k.header.frame_id != frame_id:
                fail(f"marker frame_id {k.header.frame_id!r}")
            check_marker_fields(k)
            if abs(stamp_s(k.header.stamp) - float(row["time_s"])) > 1e-6:
                fail(f"frame {row['frame']}: marker stamp {stamp_s(k.header.stamp)}")
        want = [float(row[k]) / 1000.0 for k in ("tip_x_mm", "tip_y_mm", "tip_z_mm")]
        got = tip.pose.position
        worst = max(worst, abs(got.x - want[0]), abs(got.y - want[1]), abs(got.z - want[2]))
        if tool is not None:
            spheres = by_id.get(0)
            if spheres is None or spheres.type != 7:
                fail("no marker spheres (id 0, SPHERE_LIST)")
            if abs(spheres.scale.x - tool["marker_diameter_mm"] / 1000.0) > 1e-9:
                fail(f"sphere diameter {spheres.scale.x} m")
            q = [float(row[k]) for k in ("qw", "qx", "qy", "qz")]
            t = [float(row[k]) for k in ("x_mm", "y_mm", "z_mm")]
            if len(spheres.points) != len(tool["markers"]):
                fail(f"{len(spheres.points)} marker spheres for {len(tool['markers'])} markers")
            for point, marker in zip(spheres.points, tool["markers"]):
                r = rotate(q, marker)
                want = [(r[i] + t[i]) / 1000.0 for i in range(3)]
                worst = max(worst, abs(point.x - want[0]), abs(point.y - want[1]),
                            abs(point.z - want[2]))
    if worst > 1e-6:
        fail(f"marker positions differ from the tracked ones in metres by {worst} m")
    return len(messages), worst


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mcap")
    parser.add_argument("trajectory")
    parser.add_argument("joints", nargs="?")
    parser.add_argument("--frame-id", default="world")
    parser.add_argument("--cameras", type=int, default=0)
    parser.add_argument("--tool", help="the tool file: check the marker spheres too")
    args = parser.parse_args()
    tool_file = None
    if args.tool:
        with open(args.tool) as f:
            tool_file = json.load(f)

    with open(args.trajectory, newline="") as f:
        rows = list(csv.DictReader(f))
    posed = [r for r in rows if r["x_mm"] != ""]

    by_topic = {}
    types = {}
    for m in read_ros2_messages(args.mcap):
        by_topic.setdefault(m.channel.topic, []).append(m)
        types[m.channel.topic] = m.schema.name
    tool = by_topic.get("/teachcam/tool", [])
    if types.get("/teachcam/tool") != "geometry_msgs/msg/PoseWithCovarianceStamped":
        fail(f"/teachcam/tool type {types.get('/teachcam/tool')}")
    if len(tool) != len(posed):
        fail(f"{len(tool)} tool messages for {len(posed)} posed frames")
    worst_m = 0.0
    worst_s = 0.0
    for row, m in zip(posed, tool):
        msg = m.ros_msg
        if msg.header.frame_id != args.frame_id:
            fail(f"frame_id {msg.header.frame_id!r}")
        p = msg.pose.pose.position
        tip = [float(row[k]) / 1000.0 for k in ("tip_x_mm", "tip_y_mm", "tip_z_mm")]
        worst_m = max(worst_m, abs(p.x - tip[0]), abs(p.y - tip[1]), abs(p.z - tip[2]))
        worst_s = max(worst_s, abs(stamp_s(msg.header.stamp) - float(row["time_s"])))
        q = msg.pose.pose.orientation
        if abs(math.sqrt(q.x**2 + q.y**2 + q.z**2 + q.w**2) - 1.0) > 1e-6:
            fail(f"frame {row['frame']}: orientation not unit")
        cov = list(msg.pose.covariance)
        if len(cov) != 36:
            fail("covariance length")
        diagonal = [cov[i * 7] for i in range(6)]
        if not all(math.isfinite(v) and v > 0 for v in diagonal):
            fail(f"frame {row['frame']}: covariance diagonal {diagonal}")
        if not all(math.isfinite(v) for v in cov):
            fail(f"frame {row['frame']}: covariance not finite")
        if row.get("tip_std_mm"):
            # The CSV rounds tip_std_mm: the variance is the square of a value within half a
            # unit of its last digit.
            text = row["tip_std_mm"]
            half = 0.5 * 10.0 ** -(len(text.split(".")[1]) if "." in text else 0)
            low = (max(float(text) - half, 0.0) / 1000.0) ** 2
            high = ((float(text) + half) / 1000.0) ** 2
            if not low * (1 - 1e-9) <= diagonal[0] <= high * (1 + 1e-9):
                fail(f"frame {row['frame']}: x variance {diagonal[0]} outside the CSV's "
                     f"tip_std_mm {text} ({low}..{high} m^2)")
    if worst_m > 1e-6:
        fail(f"positions differ from tip/1000 by {worst_m} m")
    if worst_s > 1e-6:
        fail(f"stamps differ from time_s by {worst_s} s")

    tf = by_topic.get("/tf", [])
    if not tf:
        fail("no /tf message")
    first = tf[0].ros_msg.transforms[0]
    if first.header.frame_id != args.frame_id:
        fail(f"/tf parent {first.header.frame_id!r}")

    status = by_topic.get("/teachcam/status", [])
    if len(status) != len(rows):
        fail(f"{len(status)} status messages for {len(rows)} frames")

    if types.get("/teachcam/markers") != "visualization_msgs/msg/MarkerArray":
        fail(f"/teachcam/markers type {types.get('/teachcam/markers')}")
    marker_arrays, worst_marker_m = check_markers(
        by_topic.get("/teachcam/markers", []), posed, args.frame_id, tool_file
    )

    cameras = 0
    if args.cameras:
        static = by_topic.get("/tf_static", [])
        cameras = sum(len(m.ros_msg.transforms) for m in static)
        if cameras != args.cameras:
            fail(f"/tf_static has {cameras} cameras, expected {args.cameras}")

    worst_rad = None
    points = 0
    if args.joints:
        with open(args.joints, newline="") as f:
            joint_rows = [r for r in csv.DictReader(f) if r["j1_deg"] != ""]
        jt = by_topic.get("/teachcam/joint_trajectory", [])
        if len(jt) != 1:
            fail(f"{len(jt)} joint trajectories")
        msg = jt[0].ros_msg
        if len(msg.joint_names) != 6:
            fail(f"joint names {msg.joint_names}")
        points = len(msg.points)
        if points != len(joint_rows):
            fail(f"{points} points for {len(joint_rows)} frames with joints")
        worst_rad = 0.0
        start = float(joint_rows[0]["time_s"])
        for row, point in zip(joint_rows, msg.points):
            expected = [math.radians(float(row[f"j{i}_deg"])) for i in range(1, 7)]
            worst_rad = max(worst_rad, *(abs(a - b) for a, b in zip(point.positions, expected)))
            t = stamp_s(point.time_from_start)
            if abs(t - (float(row["time_s"]) - start)) > 2e-6:
                fail(f"frame {row['frame']}: time_from_start {t}")
        if worst_rad > 1e-6:
            fail(f"joints differ from --joints-out by {worst_rad} rad")

    print(json.dumps({
        "tool_messages": len(tool),
        "posed_frames": len(posed),
        "status_messages": len(status),
        "tf_messages": len(tf),
        "cameras": cameras,
        "joint_points": points,
        "marker_arrays": marker_arrays,
        "worst_marker_m": worst_marker_m,
        "worst_position_m": worst_m,
        "worst_stamp_s": worst_s,
        "worst_joint_rad": worst_rad,
    }))


if __name__ == "__main__":
    main()
