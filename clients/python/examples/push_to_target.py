#!/usr/bin/env python3
"""Closed loop: steer a kinematic "finger" so that it pushes an object (the captured donut) along
a table to a target point, repositioning the finger when the push goes off line.

Every step the loop reads the `objects` sample (COM of the donut and the finger), decides where
the finger should be one step later, and sends a `set-pose` for that step. The finger is lifted
over the donut and lowered behind it whenever it is not behind the donut on the line to the
target. At the end it prints the loop latency (from the `objects` sample's publish time to the
reply to the pose command) and the final distance to the target, and exits 0 when that distance
is within the tolerance.

    splatphys serve scenes/donut_push_finger.toml --realtime &
    python3 clients/python/examples/push_to_target.py --target 0.25,0.10

With `--lockstep` (server started with `--paused`) the loop advances the server one step at a
time itself, so the result does not depend on how fast either side runs.

With `--transport zenoh` the same loop runs through `splatphys-zenoh` (started with
`--allow-commands` beside the server), from this machine or another one:

    splatphys-zenoh --prefix splatphys/donut_push_finger --allow-commands &
    python3 clients/python/examples/push_to_target.py --transport zenoh --connect tcp/127.0.0.1:7447
"""

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import splatphys_client as sc  # noqa: E402

# Finger states.
LIFT, ACROSS, LOWER, PUSH = "lift", "across", "lower", "push"


def parse_xy(text):
    parts = [float(v) for v in text.split(",")]
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"{text!r}: give x,y in metres")
    return np.array(parts)


def args_from(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--prefix", default=os.environ.get("SPLATPHYS_PREFIX", "splatphys/donut_push_finger"),
                   help="service prefix of the server (default: $SPLATPHYS_PREFIX or splatphys/donut_push_finger)")
    p.add_argument("--object", default="donut", help="object to push (name or id)")
    p.add_argument("--finger", default="finger", help="kinematic finger (name or id)")
    p.add_argument("--finger-radius-m", type=float, default=0.015, help="finger radius, m")
    p.add_argument("--target", type=parse_xy, default=np.array([0.25, 0.10]), help="target x,y on the table, m")
    p.add_argument("--tolerance-m", type=float, default=0.01, help="success distance, m")
    p.add_argument("--max-speed", type=float, default=0.15, help="fastest finger travel, m/s")
    p.add_argument("--push-gain", type=float, default=1.5, help="push speed per metre of error, 1/s")
    p.add_argument("--timeout-s", type=float, default=40.0, help="give up after this much simulated time, s")
    p.add_argument("--lockstep", action="store_true", help="advance the (paused) server one step per loop")
    p.add_argument("--deformable", action="store_true", help="make the pushed object deformable first")
    p.add_argument("--transport", choices=["shm", "zenoh"], default="shm",
                   help="shared memory on this machine (default) or Zenoh through splatphys-zenoh")
    p.add_argument("--connect", action="append", default=None,
                   help="Zenoh endpoint of the bridge (repeatable; default tcp/127.0.0.1:7447)")
    p.add_argument("--verbose", action="store_true", help="print every loop")
    return p.parse_args(argv)


def gaussian_objects(client, timeout_s=5.0):
    """The object id of every published Gaussian, from the scene sample (which also fills
    `client.scene_info()`)."""
    deadline = time.monotonic() + timeout_s
    while True:
        scene = client.recv_scene()
        if scene is not None:
            ids = np.array(scene.gaussians["object_id"])
            scene.release()
            return ids
        if time.monotonic() > deadline:
            raise TimeoutError(f"no scene from the server within {timeout_s} s")
        time.sleep(0.001)


def object_extent(client, ids, object_id):
    """(horizontal radius, top z) of an object's Gaussians around its COM, from one frame."""
    frame = client.wait_frame(timeout_s=5.0)
    if frame is None:
        raise TimeoutError("no frame from the server")
    x = np.array(frame.gaussians["position_m"])[ids == object_id]
    frame.release()
    com = x.mean(axis=0)
    radius = float(np.percentile(np.linalg.norm(x[:, :2] - com[:2], axis=1), 98))
    return radius, float(np.percentile(x[:, 2], 98))


def newest_objects(client, after_step, timeout_s=5.0):
    """(step, publish time in ns, {id: (com, velocity)}) of the newest objects sample past
    `after_step`."""
    deadline = time.monotonic() + timeout_s
    best = None
    while True:
        while True:
            s = client.recv_objects()
            if s is None:
                break
            if s.header.step > after_step:
                a = s.objects
                state = {int(i): (np.array(p, float), np.array(v, float))
                         for i, p, v in zip(a["id"], a["position_m"], a["velocity_m_s"])}
                best = (s.header.step, s.header.publish_unix_ns, state)
            s.release()
        if best is not None:
            return best
        client.poll_status()
        if client.shutting_down:
            raise RuntimeError("the server is shutting down")
        if time.monotonic() > deadline:
            raise TimeoutError(f"no objects sample after step {after_step} within {timeout_s} s")
        client.wait(0.0002)


def accepted(client, cmd):
    r = client.command(cmd)
    if not r.accepted:
        raise RuntimeError(f"{type(cmd).__name__} refused: {r.reason}")
    return r


class Controller:
    """The finger's state machine (module docs); `next_position` is its only output."""

    def __init__(self, radius_m, finger_m, top_z, dt_s, a):
        self.clear = radius_m + finger_m + 0.01  # finger centre to donut COM, lowered behind it
        self.safe_z = top_z + finger_m + 0.02
        self.dt = dt_s
        self.a = a
        self.state = LIFT
        self.repositions = 0

    def next_position(self, donut, finger, target):
        c, f = donut[:2], finger[:2]
        err = target - c
        dist = float(np.linalg.norm(err))
        d = err / max(dist, 1e-9)
        behind = c - d * self.clear
        push_z = donut[2]
        travel = self.a.max_speed * self.dt
        if self.state == PUSH:
            to_donut = c - f
            off_line = math.degrees(math.acos(np.clip(np.dot(to_donut, d) / max(np.linalg.norm(to_donut), 1e-9), -1, 1)))
            if off_line > 30.0 or np.linalg.norm(to_donut) > self.clear + 0.03:
                self.state = LIFT
                self.repositions += 1
        if self.state == LIFT:
            goal = np.array([f[0], f[1], self.safe_z])
            if finger[2] >= self.safe_z - 0.002:
                self.state = ACROSS
        if self.state == ACROSS:
            goal = np.array([behind[0], behind[1], self.safe_z])
            if np.linalg.norm(f - behind) < 0.005:
                self.state = LOWER
        if self.state == LOWER:
            goal = np.array([behind[0], behind[1], push_z])
            if abs(finger[2] - push_z) < 0.002:
                self.state = PUSH
        if self.state == PUSH:
            # Along the line at a speed that falls with the error; across it, back onto the line
            # through the donut's COM.
            rel = f - c
            lateral = rel - d * np.dot(rel, d)
            v = d * min(self.a.max_speed, self.a.push_gain * dist) - 4.0 * lateral
            v *= min(1.0, self.a.max_speed / max(float(np.linalg.norm(v)), 1e-12))
            return np.array([f[0] + v[0] * self.dt, f[1] + v[1] * self.dt, push_z])
        move = goal - finger
        n = float(np.linalg.norm(move))
        return finger + move * min(1.0, travel / max(n, 1e-12))


def main(argv=None):
    a = args_from(argv)
    if a.transport == "zenoh":
        client = sc.ZenohClient(a.prefix, connect=a.connect or [sc.zenoh_client.DEFAULT_ENDPOINT],
                                connect_timeout_s=10.0)
    else:
        client = sc.Client(a.prefix, connect_timeout_s=10.0)
    ids = gaussian_objects(client)
    info = client.scene_info()
    donut_id, finger_id = client.object_id(a.object), client.object_id(a.finger)
    dt = info["frame_dt_s"]
    if a.lockstep:
        accepted(client, sc.Step(1))  # a paused server publishes frames only when it steps
    radius, top = object_extent(client, ids, donut_id)
    if a.deformable:
        accepted(client, sc.SetKind(donut_id, "deformable"))
    ctl = Controller(radius, a.finger_radius_m, top, dt, a)
    print(f"pushing {a.object!r} (radius {radius * 100:.1f} cm) to {a.target.tolist()} with {a.finger!r}, "
          f"{'lockstep' if a.lockstep else 'live'}, {1 / dt:.0f} steps/s")
    latencies = []
    step, t0 = -1, None
    still = 0
    while True:
        step, published_ns, state = newest_objects(client, step)
        donut, v_donut = state[donut_id]
        finger = state[finger_id][0]
        t0 = step if t0 is None else t0
        err = float(np.linalg.norm(a.target - donut[:2]))
        # Aim for half the tolerance: a push stops the donut within about a millimetre.
        still = still + 1 if err <= 0.5 * a.tolerance_m and np.linalg.norm(v_donut) < 0.005 else 0
        if still >= 3 or (step - t0) * dt > a.timeout_s:
            break
        goal = ctl.next_position(donut, finger, a.target) if err > 0.5 * a.tolerance_m else finger
        accepted(client, sc.SetPose(finger_id, goal.tolist(), (1.0, 0.0, 0.0, 0.0), at_step=step + 1))
        latencies.append((time.time_ns() - published_ns) / 1e6)
        if a.verbose:
            print(f"step {step} {ctl.state:6s} donut {donut.round(4).tolist()} finger {finger.round(4).tolist()} "
                  f"error {err * 100:.2f} cm")
        if a.lockstep:
            accepted(client, sc.Step(1))
    lat = np.array(latencies) if latencies else np.zeros(1)
    ok = err <= a.tolerance_m
    print(f"final error {err * 1000:.1f} mm ({'within' if ok else 'outside'} {a.tolerance_m * 1000:.0f} mm) "
          f"after {(step - t0) * dt:.2f} s simulated, {len(latencies)} commands, {ctl.repositions} repositionings")
    print(f"final position {donut[0]:.6f},{donut[1]:.6f},{donut[2]:.6f} m at step {step}")
    print(f"loop latency (objects published -> pose accepted): p50 {np.percentile(lat, 50):.2f} ms, "
          f"p99 {np.percentile(lat, 99):.2f} ms")
    client.close()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
