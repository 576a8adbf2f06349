"""Subscribes to teachcam's ROS 2 topics with Cyclone DDS (PyPI `cyclonedds`) and checks them.

An independent DDS implementation (the one ROS 2's default RMW uses) reads the wire: the types
are declared here from ROS 2's `.msg` definitions with ROS 2's DDS type names
(`geometry_msgs::msg::dds_::PoseWithCovarianceStamped_`), the topics with ROS 2's `rt/` prefix,
the QoS as ROS 2's default profile (reliable, volatile, keep last 10). Cyclone is configured by
the caller's CYCLONEDDS_URI (the tests: loopback only, multicast off, a loopback peer).

Run: target/ros-venv/bin/pip install cyclonedds
     CYCLONEDDS_URI=... target/ros-venv/bin/python scripts/ros2/read_dds.py --seconds 30 \
         [--idle 3] [--domain 0] [--frame-id world] [--min-rate 20]
Prints one JSON line with what it received; exits 1 naming the first check that fails.
"""

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.internal import InvalidSample
from cyclonedds.idl.types import array, float32, float64, int32, sequence, uint8, uint32
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class PoseWithCovarianceStamped(
    IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"
):
    header: Header
    pose: PoseWithCovariance


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header
    status: sequence[DiagnosticStatus]


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32
    nanosec: uint32


@dataclass
class ColorRGBA(IdlStruct, typename="std_msgs::msg::dds_::ColorRGBA_"):
    r: float32
    g: float32
    b: float32
    a: float32


@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header
    format: str
    data: sequence[uint8]


@dataclass
class UVCoordinate(IdlStruct, typename="visualization_msgs::msg::dds_::UVCoordinate_"):
    u: float32
    v: float32


@dataclass
class MeshFile(IdlStruct, typename="visualization_msgs::msg::dds_::MeshFile_"):
    filename: str
    data: sequence[uint8]


# visualization_msgs/msg/Marker as Humble and Jazzy define it (Foxy and Galactic lack the
# texture, uv_coordinates and mesh_file fields).
@dataclass
class Marker(IdlStruct, typename="visualization_msgs::msg::dds_::Marker_"):
    header: Header
    ns: str
    id: int32
    type: int32
    action: int32
    pose: Pose
    scale: Vector3
    color: ColorRGBA
    lifetime: Duration
    frame_locked: bool
    points: sequence[Point]
    colors: sequence[ColorRGBA]
    texture_resource: str
    texture: CompressedImage
    uv_coordinates: sequence[UVCoordinate]
    text: str
    mesh_resource: str
    mesh_file: MeshFile
    mesh_use_embedded_materials: bool


@dataclass
class MarkerArray(IdlStruct, typename="visualization_msgs::msg::dds_::MarkerArray_"):
    markers: sequence[Marker]


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def stamp_s(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, required=True, help="read at most this long")
    parser.add_argument(
        "--idle", type=float, default=3.0, help="stop once nothing came for this long after data"
    )
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--frame-id", default="world")
    parser.add_argument("--min-rate", type=float, default=20.0)
    args = parser.parse_args()

    # ROS 2's default profile (rmw_qos_profile_default).
    qos = Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )
    # tf2's static listener: transient local, so the cameras written once at start arrive.
    static_qos = Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
    )
    participant = DomainParticipant(args.domain)
    readers = {
        "tool": DataReader(
            participant,
            Topic(participant, "rt/teachcam/tool", PoseWithCovarianceStamped, qos=qos),
            qos=qos,
        ),
        "tf": DataReader(participant, Topic(participant, "rt/tf", TFMessage, qos=qos), qos=qos),
        "status": DataReader(
            participant,
            Topic(participant, "rt/teachcam/status", DiagnosticArray, qos=qos),
            qos=qos,
        ),
        "markers": DataReader(
            participant,
            Topic(participant, "rt/teachcam/markers", MarkerArray, qos=qos),
            qos=qos,
        ),
        "tf_static": DataReader(
            participant,
            Topic(participant, "rt/tf_static", TFMessage, qos=static_qos),
            qos=static_qos,
        ),
    }
    received = {name: [] for name in readers}
    arrival = []
    end = time.monotonic() + args.seconds
    last = None
    while time.monotonic() < end:
        if last is not None and time.monotonic() - last > args.idle:
            break
        got = False
        for name, reader in readers.items():
            for sample in reader.take(N=100):
                if isinstance(sample, InvalidSample):
                    # An instance's state (the writer gone at the end), no data.
                    continue
                received[name].append(sample)
                if name == "tool":
                    arrival.append((time.time(), sample))
                got = True
                last = time.monotonic()
        if not got:
            time.sleep(0.002)

    tools = received["tool"]
    if len(tools) < 2:
        fail(f"{len(tools)} messages on rt/teachcam/tool")
    # The rate over the span the poses arrived in (the publisher starts after the reader).
    span = arrival[-1][0] - arrival[0][0]
    rate = (len(tools) - 1) / span if span > 0 else 0.0
    if rate < args.min_rate:
        fail(f"{rate:.1f} poses/s on rt/teachcam/tool, expected at least {args.min_rate}")
    for m in tools:
        if m.header.frame_id != args.frame_id:
            fail(f"frame_id {m.header.frame_id!r}, expected {args.frame_id!r}")
        p = m.pose.pose.position
        q = m.pose.pose.orientation
        values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w, *m.pose.covariance]
        if not all(math.isfinite(v) for v in values):
            fail("a pose or covariance that is not finite")
        diagonal = [m.pose.covariance[7 * i] for i in range(6)]
        if min(diagonal) <= 0:
            fail(f"covariance diagonal {diagonal} not positive")
        if abs(math.sqrt(q.x**2 + q.y**2 + q.z**2 + q.w**2) - 1) > 1e-6:
            fail("orientation not a unit quaternion")
    xs = [(m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z) for m in tools]
    extent = [max(v[i] for v in xs) - min(v[i] for v in xs) for i in range(3)]
    largest = max(max(abs(c) for c in v) for v in xs)
    stamps = [stamp_s(m.header.stamp) for m in tools]
    steps = [b - a for a, b in zip(stamps, stamps[1:])]
    # Latency: arrival on this machine's wall clock less the stamp (the exposure).
    latency = sorted(t - stamp_s(m.header.stamp) for t, m in arrival)
    tf_children = sorted({t.child_frame_id for m in received["tf"] for t in m.transforms})
    tf_parents = sorted({t.header.frame_id for m in received["tf"] for t in m.transforms})
    static_children = sorted(
        {t.child_frame_id for m in received["tf_static"] for t in m.transforms}
    )
    levels = sorted({s.level for m in received["status"] for s in m.status})
    # RViz's markers: per array its stamp, the tip's sphere and the tool's marker spheres.
    marker_arrays = []
    for m in received["markers"]:
        by_id = {k.id: k for k in m.markers}
        tip, spheres = by_id.get(1), by_id.get(0)
        if tip is None or tip.type != 2 or spheres is None or spheres.type != 7:
            fail("a marker array without the tip (id 1, SPHERE) and markers (id 0, SPHERE_LIST)")
        if any(k.header.frame_id != args.frame_id for k in m.markers):
            fail("a marker in another frame")
        # The fields after the points decoded in place (texture, uv_coordinates, mesh_file).
        for k in m.markers:
            if (k.text, k.mesh_resource, k.mesh_file.filename, k.mesh_use_embedded_materials) != (
                "", "", "", False
            ) or abs(stamp_s(k.lifetime) - 0.4) > 1e-9:
                fail(f"marker {k.id}: fields after its points do not decode as written")
        marker_arrays.append(
            {
                "stamp": stamp_s(tip.header.stamp),
                "tip": [tip.pose.position.x, tip.pose.position.y, tip.pose.position.z],
                "diameter_m": spheres.scale.x,
                "spheres": [[p.x, p.y, p.z] for p in spheres.points],
            }
        )
    print(
        json.dumps(
            {
                "tool": len(tools),
                "tf": len(received["tf"]),
                "status": len(received["status"]),
                "rate_hz": rate,
                "extent_m": extent,
                "largest_m": largest,
                "frame_id": tools[0].header.frame_id,
                "stamp_first": stamps[0],
                "stamps_increasing": all(s > 0 for s in steps),
                "stamp_step_median_s": sorted(steps)[len(steps) // 2],
                "latency_ms_p50": 1e3 * latency[len(latency) // 2],
                "latency_ms_max": 1e3 * latency[-1],
                "tf_children": tf_children,
                "tf_parents": tf_parents,
                "tf_static_children": static_children,
                "status_levels": levels,
                "markers": marker_arrays,
                "covariance_first": [tools[0].pose.covariance[7 * i] for i in range(6)],
                "positions_m": xs,
            }
        )
    )


if __name__ == "__main__":
    main()
