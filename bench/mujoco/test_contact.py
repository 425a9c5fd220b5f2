"""Tests of bench/mujoco/contact.py (run: python3 -m pytest bench/mujoco -q).

Each test runs the script as `bench contact` does: a child process, JSON in on stdin, JSON out on
stdout. Tests that need MuJoCo are skipped when `import mujoco` fails.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).with_name("contact.py")
GROUND = {"shape": "plane", "point_m": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}

try:
    import mujoco  # noqa: F401

    HAVE_MUJOCO = True
except ImportError:
    HAVE_MUJOCO = False

needs_mujoco = pytest.mark.skipif(not HAVE_MUJOCO, reason="mujoco is not installed")


def run(doc, env=None, cwd=None):
    """Runs the script on `doc` (a dict or raw text); returns the completed process."""
    text = doc if isinstance(doc, str) else json.dumps(doc)
    return subprocess.run(
        [sys.executable, str(SCRIPT.resolve())],
        input=text,
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=120,
        check=False,
    )


def simulate(doc):
    p = run(doc)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def ball(radius, center, mass=1.0, **extra):
    i = 0.4 * mass * radius * radius
    return {
        "shape": "ball",
        "radius_m": radius,
        "center_m": center,
        "orientation_wxyz": [1.0, 0.0, 0.0, 0.0],
        "mass_kg": mass,
        "com_m": center,
        "inertia_kg_m2": [[i, 0, 0], [0, i, 0], [0, 0, i]],
        **extra,
    }


def cube(half, center, mass=1.0, orientation=(1.0, 0.0, 0.0, 0.0)):
    # A cube's inertia about its centre is isotropic, so its world tensor is the same turned.
    i = mass * (2 * half) ** 2 / 6.0
    return {
        "shape": "box",
        "half_extents_m": [half] * 3,
        "center_m": center,
        "orientation_wxyz": list(orientation),
        "mass_kg": mass,
        "com_m": center,
        "inertia_kg_m2": [[i, 0, 0], [0, i, 0], [0, 0, i]],
    }


def scene(bodies, duration=1.0, dt=None, gravity=(0.0, 0.0, -9.81), statics=(GROUND,)):
    return {
        "scene": "test",
        "duration_s": duration,
        "dt_s": dt,
        "gravity_m_s2": list(gravity),
        "friction": 0.5,
        "bodies": bodies,
        "statics": list(statics),
    }


def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]


def rotate(q, v):
    """v turned by the unit quaternion q = [w, x, y, z]."""
    p = quat_mul(quat_mul(q, [0.0, *v]), [q[0], -q[1], -q[2], -q[3]])
    return p[1:]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


@needs_mujoco
def test_dropped_ball_rests_at_its_radius():
    r = 0.04
    out = simulate(scene([ball(r, [0.0, 0.0, r + 0.1])], duration=1.0))
    b = out["bodies"][0]
    assert abs(b["com_m"][2] - r) < 1e-3, b
    assert dist(b["velocity_m_s"], [0, 0, 0]) < 1e-2, b
    # It hit the ground, so some step saw a contact; soft contacts let it sink a little.
    assert 0.0 < out["deepest_contact_m"] < 0.02


@needs_mujoco
def test_resting_box_stays_put():
    h = 0.05
    start = [0.1, -0.2, h]
    out = simulate(scene([cube(h, start)], duration=1.0))
    b = out["bodies"][0]
    assert dist(b["com_m"], start) < 1e-3, b
    assert dist(b["orientation_wxyz"], [1, 0, 0, 0]) < 1e-3, b


@needs_mujoco
def test_turned_box_reports_rotation_from_its_start_pose():
    # A cube turned 90 degrees about z at the start, resting: its rotation FROM the start pose
    # stays the identity.
    h = 0.05
    s = math.sqrt(0.5)
    out = simulate(scene([cube(h, [0.0, 0.0, h], orientation=(s, 0.0, 0.0, s))], duration=0.5))
    b = out["bodies"][0]
    assert dist(b["com_m"], [0.0, 0.0, h]) < 1e-3, b
    assert dist(b["orientation_wxyz"], [1, 0, 0, 0]) < 1e-3, b


@needs_mujoco
def test_free_flight_reports_the_com_velocity():
    # Zero gravity, no statics: a box turned at the start whose COM sits 4 cm off its geometric
    # centre (the body frame origin), with a full inertia tensor, flying at v and spinning at w
    # about an axis through its COM. The COM must move at v: the free joint's own linear
    # velocity is the body origin's, which differs from v by w x (origin - com), here about
    # 0.1 m/s, so reading the wrong point fails by far more than the tolerance.
    q0 = [math.cos(0.3), math.sin(0.3) / math.sqrt(3), math.sin(0.3) / math.sqrt(3),
          math.sin(0.3) / math.sqrt(3)]
    center = [0.2, -0.1, 0.5]
    com = [0.23, -0.08, 0.515]
    v = [0.5, 0.2, -0.1]
    w = [0.3, -1.0, 2.0]
    body = {
        "shape": "box",
        "half_extents_m": [0.1, 0.07, 0.05],
        "center_m": center,
        "orientation_wxyz": q0,
        "mass_kg": 2.0,
        "com_m": com,
        "inertia_kg_m2": [[0.012, 0.001, 0.0005], [0.001, 0.015, -0.0008],
                          [0.0005, -0.0008, 0.018]],
        "velocity_m_s": v,
        "omega_rad_s": w,
    }
    lever = [c - o for c, o in zip(com, center)]
    assert dist(cross(w, lever), [0, 0, 0]) > 0.05
    for duration in (0.1, 0.5, 1.0):
        out = simulate(scene([body], duration=duration, gravity=(0, 0, 0), statics=()))
        b = out["bodies"][0]
        t = out["simulated_s"]
        assert out["deepest_contact_m"] == 0.0
        # MuJoCo's free joint integrates the body origin, not the COM: Euler's first-order
        # error in the origin's centripetal motion moves the COM velocity by ~4e-4 m/s in 1 s.
        assert dist(b["velocity_m_s"], v) < 2e-3, (duration, b)
        assert dist(b["com_m"], [c + x * t for c, x in zip(com, v)]) < 2e-3, (duration, b)
        # Angular velocity is reported in world axes: its size is conserved up to the same
        # integration error (the body is free, so |L| is, and w itself precesses).
        assert abs(math.hypot(*b["omega_rad_s"]) - math.hypot(*w)) < 0.02, (duration, b)
    # At the start (one step), world omega is what was set.
    out = simulate(scene([body], duration=0.002, gravity=(0, 0, 0), statics=()))
    assert dist(out["bodies"][0]["omega_rad_s"], w) < 1e-2, out


@needs_mujoco
@pytest.mark.parametrize("duration,dt,steps", [(0.3, 0.001, 300), (0.25, None, 125),
                                               (1.0, 1.0 / 120.0, 120)])
def test_steps_and_time(duration, dt, steps):
    out = simulate(scene([ball(0.05, [0.0, 0.0, 0.05])], duration=duration, dt=dt))
    assert out["steps"] == steps == round(duration / out["dt_s"])
    assert out["dt_s"] == (0.002 if dt is None else dt)
    assert out["wall_s"] > 0.0
    assert out["simulated_s"] == pytest.approx(steps * out["dt_s"])
    assert out["engine"].startswith("mujoco ")


@needs_mujoco
def test_warnings_are_counted_and_go_to_stderr(tmp_path):
    # A ball thrown down at an absurd speed: MuJoCo flags the velocity (and resets the state).
    # The warning is in the output and on stderr, and no MUJOCO_LOG.TXT lands in the cwd.
    doc = scene([ball(0.05, [0.0, 0.0, 0.2], velocity_m_s=[0.0, 0.0, -1e12])], duration=0.01)
    p = run(doc, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["warnings"].get("mjWARN_BADQVEL", 0) >= 1
    assert "QVEL" in p.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


@pytest.mark.parametrize(
    "doc,needle",
    [
        ("not json", "not JSON"),
        (scene([], duration=0.0), "duration_s"),
        (scene([{"shape": "cone"}]), "bodies[0].shape"),
        (scene([ball(0.05, [0.0, 0.0, 0.05], mass=-1.0)]), "bodies[0].mass_kg"),
        (scene([], statics=({"shape": "plane", "point_m": [0, 0, 0], "normal": [0, 0, 0]},)),
         "statics[0].normal"),
    ],
)
def test_bad_input_exits_2_with_a_message(doc, needle):
    if not HAVE_MUJOCO:
        pytest.skip("the script checks the import first")
    p = run(doc)
    assert p.returncode == 2
    assert needle in p.stderr and "bad input" in p.stderr


def test_missing_mujoco_exits_3(tmp_path):
    # A `mujoco` module that fails to import shadows the real one.
    (tmp_path / "mujoco.py").write_text("raise ImportError('no mujoco here')\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    p = run(scene([]), env=env)
    assert p.returncode == 3
    assert "mujoco" in p.stderr
