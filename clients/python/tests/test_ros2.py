"""`splatphys-zenoh --ros2` heard as a ROS 2 node running rmw_zenoh (Jazzy) would hear it, with an
independent implementation of ROS 2's types: `rosbags` decodes every payload as its stated type
(the CDR header included), the type hashes in the keys and in the liveliness tokens equal
`typestore.hash_rihs01`, the attachment has rmw_zenoh's 33-byte layout, the point cloud and the
transforms carry the same numbers as the shared-memory frame and objects of the same stamp, and
`PoseStamped`/`TwistStamped` written by rosbags move the server's objects.

This process plays the `rmw_zenohd` router (a Zenoh peer listening on a free port); no ROS 2 is
installed. Needs `pip install rosbags eclipse-zenoh` and the binaries (see test_zenoh.py).
"""

import os
import threading
import time

import numpy as np
import pytest

import splatphys_client as sc
from test_zenoh import BIN, BRIDGE, HAVE_ZENOH, free_port, stop

try:
    from rosbags.typesys import Stores, get_typestore

    TS = get_typestore(Stores.ROS2_JAZZY)
except ImportError:
    TS = None

pytestmark = pytest.mark.skipif(
    BIN is None or not BRIDGE.exists() or not HAVE_ZENOH or TS is None,
    reason="needs the splatphys and splatphys-zenoh binaries, `pip install eclipse-zenoh rosbags`",
)

NS = "splatphys"


def ros_name(dds_name: str) -> str:
    """`sensor_msgs::msg::dds_::PointCloud2_` -> `sensor_msgs/msg/PointCloud2`."""
    pkg, sub, _, name = dds_name.split("::")
    return f"{pkg}/{sub}/{name.rstrip('_')}"


class Router:
    """A Zenoh peer standing in for rmw_zenohd: it records every sample under domain 0 and
    every ROS liveliness token."""

    def __init__(self):
        import zenoh

        self.port = free_port()
        conf = zenoh.Config()
        conf.insert_json5("mode", '"router"')
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5("listen/endpoints", f'["tcp/127.0.0.1:{self.port}"]')
        self.session = zenoh.open(conf)
        self.lock = threading.Lock()
        self.samples = {}  # key -> [(payload, attachment)]
        self.tokens = set()
        self.subs = [
            self.session.declare_subscriber("0/**", self._on_sample),
            self.session.liveliness().declare_subscriber("@ros2_lv/**", self._on_token, history=True),
        ]

    def _on_sample(self, s):
        att = s.attachment.to_bytes() if s.attachment is not None else None
        with self.lock:
            self.samples.setdefault(str(s.key_expr), []).append((s.payload.to_bytes(), att))

    def _on_token(self, s):
        import zenoh

        with self.lock:
            if s.kind == zenoh.SampleKind.PUT:
                self.tokens.add(str(s.key_expr))
            else:
                self.tokens.discard(str(s.key_expr))

    def wait_for(self, what, timeout_s=20.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self.lock:
                got = what()
            if got:
                return got
            time.sleep(0.02)
        raise AssertionError(f"timed out; keys: {sorted(self.samples)}; tokens: {sorted(self.tokens)}")

    def topic_samples(self, topic: str):
        """Samples of `/<topic>` under any type: (ros type, hash, [(payload, attachment)])."""
        prefix = f"0/{topic.strip('/')}/"
        for key, samples in self.samples.items():
            rest = key[len(prefix):] if key.startswith(prefix) else ""
            if rest.count("/") == 1 and samples:
                dds, h = rest.split("/")
                return ros_name(dds), h, list(samples)
        return None

    def close(self):
        for s in self.subs:
            s.undeclare()
        self.session.close()


@pytest.fixture
def ros(request):
    """A fake server (3 cubes of 400 Gaussians), the router and a `--ros2 --allow-commands`
    bridge joined to it; yields (router, shared-memory client, bridge process)."""
    iox = f"spxros_{request.node.name[:20]}_{os.getpid()}_"
    os.environ[sc.client.IOX2_PREFIX_ENV] = iox
    env = {**os.environ, sc.client.IOX2_PREFIX_ENV: iox}
    import subprocess

    server = subprocess.Popen(
        [str(BIN), "serve", "--fake", "--realtime", "--prefix", "t/ros", "--fake-dt", "0.02",
         "--fake-objects", "3", "--fake-gaussians", "400"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    router = Router()
    bridge = subprocess.Popen(
        [str(BRIDGE), "--prefix", "t/ros", "--ros2", "--allow-commands",
         "--connect", f"tcp/127.0.0.1:{router.port}"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    client = sc.Client("t/ros", frame_buffer=4, connect_timeout_s=10.0)
    yield router, client, bridge
    client.close()
    stop(bridge)
    stop(server)
    router.close()


def test_ros2_topics_decode_as_their_types_with_rosbags(ros):
    router, shm, _ = ros
    frames, objects = {}, {}
    deadline = time.monotonic() + 20

    def heard():
        cloud = router.topic_samples(f"{NS}/gaussians")
        tf = router.topic_samples("tf")
        wrench = router.topic_samples(f"{NS}/cube1/wrench")
        return (cloud, tf, wrench) if cloud and tf and wrench and len(cloud[2]) >= 3 else None

    while time.monotonic() < deadline:
        for recv, into in ((shm.recv_frame, frames), (shm.recv_objects, objects)):
            while (v := recv()) is not None:
                with v:
                    into[v.header.publish_unix_ns] = v.array.copy()
        with router.lock:
            got = heard()
        if got and len(frames) > 10:
            break
        time.sleep(0.005)
    cloud, tf, wrench = router.wait_for(heard, timeout_s=1)

    # Type names and hashes in the keys: rosbags' own.
    for (name, h, _), want in ((cloud, "sensor_msgs/msg/PointCloud2"), (tf, "tf2_msgs/msg/TFMessage"),
                               (wrench, "geometry_msgs/msg/WrenchStamped")):
        assert name == want
        assert h == TS.hash_rihs01(name), name

    # The point cloud: fields, sizes, and the centres of the shared-memory frame of its stamp.
    matched = 0
    for payload, att in cloud[2]:
        m = TS.deserialize_cdr(payload, cloud[0])
        assert m.header.frame_id == "world"
        assert [(f.name, f.offset, f.datatype, f.count) for f in m.fields] == [
            ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("rgb", 12, 7, 1), ("opacity", 16, 7, 1)]
        assert (m.height, m.width, m.point_step, m.row_step) == (1, 1200, 20, 24000)
        assert not m.is_bigendian and m.is_dense
        pts = np.frombuffer(bytes(m.data), dtype=np.float32).reshape(1200, 5)
        assert np.all((pts[:, 4] >= 0) & (pts[:, 4] <= 1))
        stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        if stamp in frames:
            assert np.array_equal(pts[:, :3], frames[stamp]["position_m"])
            matched += 1
        # rmw_zenoh's attachment: i64 sequence, i64 source time (ns), 0x10, 16-byte GID.
        assert att is not None and len(att) == 33 and att[16] == 0x10
    assert matched >= 1, "no point cloud matched a shared-memory frame by stamp"
    seqs = [int.from_bytes(a[:8], "little") for _, a in cloud[2]]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "sequence numbers step by 1"
    gids = {a[17:] for _, a in cloud[2]}
    assert len(gids) == 1 and gids != {a[17:] for _, a in tf[2]}

    # TF: one transform per object, named by it, at the shared-memory COM of its stamp.
    matched = 0
    for payload, _ in tf[2]:
        m = TS.deserialize_cdr(payload, tf[0])
        assert [t.child_frame_id for t in m.transforms] == ["cube0", "cube1", "cube2"]
        assert all(t.header.frame_id == "world" for t in m.transforms)
        h = m.transforms[0].header.stamp
        stamp = h.sec * 1_000_000_000 + h.nanosec
        if stamp in objects:
            want = objects[stamp]["position_m"].astype(np.float64)
            got = np.array([[t.transform.translation.x, t.transform.translation.y,
                             t.transform.translation.z] for t in m.transforms])
            assert np.array_equal(got, want)
            q = m.transforms[1].transform.rotation
            assert np.isclose(q.x**2 + q.y**2 + q.z**2 + q.w**2, 1.0, atol=1e-5)
            matched += 1
    assert matched >= 1, f"no TF message matched a shared-memory objects sample by stamp: {sorted(objects)[-5:]} {[TS.deserialize_cdr(p, tf[0]).transforms[0].header.stamp for p, _ in tf[2][-3:]]}"

    w = TS.deserialize_cdr(wrench[2][-1][0], wrench[0])
    assert w.header.frame_id == "world"
    assert np.isfinite([w.wrench.force.x, w.wrench.torque.z]).all()


def test_liveliness_tokens_put_the_node_and_its_topics_in_the_ros_graph(ros):
    router, _, _ = ros

    def graph():
        return [t.split("/") for t in router.tokens] if any("/MS/" in t for t in router.tokens) else None

    tokens = router.wait_for(graph)
    nodes = [t for t in tokens if t[5] == "NN"]
    assert len(nodes) == 1
    node = nodes[0]
    assert node[0] == "@ros2_lv" and node[1] == "0" and node[6:] == ["%", "%", "splatphys_bridge"]
    assert node[3] == node[4] == "0"
    entities = {(t[5], t[9]): t for t in tokens if t[5] in ("MP", "MS")}
    for kind, topic, ros_type in [
        ("MP", f"%{NS}%gaussians", "sensor_msgs/msg/PointCloud2"),
        ("MP", "%tf", "tf2_msgs/msg/TFMessage"),
        ("MP", f"%{NS}%cube2%wrench", "geometry_msgs/msg/WrenchStamped"),
        ("MS", f"%{NS}%cube0%cmd_pose", "geometry_msgs/msg/PoseStamped"),
        ("MS", f"%{NS}%cube0%cmd_twist", "geometry_msgs/msg/TwistStamped"),
    ]:
        t = entities[(kind, topic)]
        assert len(t) == 13, t
        assert t[2] == node[2] and t[3] == "0"  # same session and node
        assert ros_name(t[10]) == ros_type
        assert t[11] == TS.hash_rihs01(ros_type)
    ids = [int(t[4]) for t in tokens if t[5] in ("MP", "MS")]
    assert len(ids) == len(set(ids)) and 0 not in ids
    assert entities[("MP", f"%{NS}%gaussians")][12] == "2::,5:,:,:,,"  # best effort, depth 5


def test_pose_and_twist_from_ros_move_the_objects(ros):
    router, shm, bridge = ros
    router.wait_for(lambda: any("/MS/" in t for t in router.tokens))

    def put(topic, typename, msg):
        dds = typename.replace("/msg/", "::msg::dds_::") + "_"
        key = f"0/{NS}/{topic}/{dds}/{TS.hash_rihs01(typename)}"
        attachment = (1).to_bytes(8, "little") + time.time_ns().to_bytes(8, "little") + b"\x10" + bytes(16)
        router.session.put(key, bytes(TS.serialize_cdr(msg, typename)), attachment=attachment)

    T = TS.types
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="world")
    pose = T["geometry_msgs/msg/PoseStamped"](header=header, pose=T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=0.5, y=-0.25, z=3.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
    # Bad input first: undecodable bytes, a NaN pose, an unknown object. Each is refused on the
    # bridge's stderr; the bridge keeps running.
    dds = "geometry_msgs::msg::dds_::PoseStamped_/" + TS.hash_rihs01("geometry_msgs/msg/PoseStamped")
    router.session.put(f"0/{NS}/cube1/cmd_pose/{dds}", b"\x00\x01\x00\x00\x07")
    nan_pose = T["geometry_msgs/msg/PoseStamped"](header=header, pose=T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float("nan"), y=0.0, z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
    put("cube1/cmd_pose", "geometry_msgs/msg/PoseStamped", nan_pose)
    put("nosuch/cmd_pose", "geometry_msgs/msg/PoseStamped", pose)
    put("cube1/cmd_pose", "geometry_msgs/msg/PoseStamped", pose)

    def com(i):
        latest = None
        while (o := shm.recv_objects()) is not None:
            with o:
                latest = (o.objects["position_m"][i].copy(), o.objects["velocity_m_s"][i].copy())
        return latest

    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        s = com(1)
        # The free-fall stand-in moves the COM there and lets it fall on: x and y stay.
        if s is not None and np.allclose(s[0][:2], [0.5, -0.25], atol=1e-5):
            break
        time.sleep(0.01)
    else:
        raise AssertionError(f"cube1 never reached the pose sent on ROS 2: {s}")

    V = T["geometry_msgs/msg/Vector3"]
    twist = T["geometry_msgs/msg/TwistStamped"](header=header, twist=T["geometry_msgs/msg/Twist"](
        linear=V(x=1.5, y=0.0, z=0.0), angular=V(x=0.0, y=0.0, z=0.0)))
    put("cube2/cmd_twist", "geometry_msgs/msg/TwistStamped", twist)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        s = com(2)
        if s is not None and abs(s[1][0] - 1.5) < 1e-5:
            break
        time.sleep(0.01)
    else:
        raise AssertionError(f"cube2 never took the velocity sent on ROS 2: {s}")
    assert bridge.poll() is None
    stop(bridge)
    err = bridge.stderr.read().decode()
    assert "not a PoseStamped" in err and "NaN" in err and "no object named `nosuch`" in err, err
