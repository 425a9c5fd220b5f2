#!/usr/bin/env python3
"""MuJoCo side of `splatphys bench contact`: one rigid-body contact scene (stack, pyramid, pile)
built as MJCF and stepped with MuJoCo at its defaults (pip package `mujoco`, 4.x). Rust runs it
through bench/src/contact/mujoco.rs; it also runs by hand:

  python3 bench/mujoco/contact.py < scene.json > result.json

Input, ONE JSON document on stdin (SI units, world frame, z up):

  {"scene": "stack", "duration_s": 3.0, "dt_s": 0.002 or null,
   "gravity_m_s2": [0, 0, -9.81], "friction": 0.5,
   "bodies": [{"shape": "box", "half_extents_m": [hx, hy, hz]} or {"shape": "ball", "radius_m": r},
              each also with "center_m" (geometric centre at the start),
              "orientation_wxyz" (at the start), "mass_kg", "com_m" (world, at the start),
              "inertia_kg_m2" (3x3 about the COM, world axes at the start),
              optional "velocity_m_s" (COM velocity) and "omega_rad_s" (world), both at the start],
   "statics": [{"shape": "plane", "point_m": [..], "normal": [..]}
               or {"shape": "box", "center_m": [..], "half_extents_m": [..]}]}

Output, ONE JSON document on stdout:

  {"engine": "mujoco 4.x.y", "steps": N, "dt_s": dt, "wall_s": .., "simulated_s": N * dt,
   "bodies": [{"com_m", "orientation_wxyz", "velocity_m_s", "omega_rad_s"}, ...],
   "deepest_contact_m": .., "warnings": {"mjWARN_...": count, ...} (those that fired)}

Model: each body is a `freejoint` body whose frame is the body's geometric centre and start
orientation, with one box or sphere geom there and an explicit `<inertial>` in the body frame
(pos = R^T (com - centre), fullinertia = R^T I R); static planes are infinite worldbody planes
whose z axis is the normal, placed at point_m; static boxes are axis-aligned worldbody boxes.
Every geom, statics included, has friction "mu 0.005 0.0001" (MuJoCo combines geom friction by
the max, so every contact gets mu); contype/conaffinity, condim 3, solref/solimp and margin are
the defaults. Gravity is the input's; sleeping is explicitly disabled.

MuJoCo defaults used: timestep 0.002 s (unless dt_s is given), Euler integrator, Newton solver,
pyramidal friction cone, 100 iterations, 50 line-search iterations, tolerance 1e-8, impratio 1,
soft contacts (solref 0.02 1): there is no restitution coefficient, so none is passed.

Conventions of the output:
- steps = round(duration_s / dt_s) (at least 1), simulated_s = steps * dt_s;
- wall_s times the `mj_step` calls only (time.perf_counter; steps run in chunks of 10 with
  `mj_step(m, d, nstep)` so Python's per-call cost stays out);
- com_m: the COM (`xipos`) after a final `mj_forward` (after `mj_step` the kinematics are those
  of the state before the last integration);
- orientation_wxyz: the rotation FROM the start pose, q_now * q_start^-1;
- velocity_m_s: the COM velocity, world frame, and omega_rad_s the angular velocity, world frame:
  `mj_objectVelocity(mjOBJ_BODY, flg_local=0)`, which in MuJoCo is about the inertial frame (the
  COM). The free joint's own qvel[0:3] is the velocity of the body frame origin (here the
  geometric centre) and qvel[3:6] the angular velocity in body axes; `mjOBJ_XBODY` is also about
  the body frame origin; `cvel` is about the subtree COM (the body's COM for a free body).
- deepest_contact_m: max over the steps sampled every 10 steps of -dist over `d.contact`
  (0 when there never was a contact or no contact penetrated).

MuJoCo's warnings go to stderr (not to MUJOCO_LOG.TXT) and are counted in "warnings".

Exit codes: 0 success; 2 bad input (message on stderr); 3 `import mujoco` failed (the caller
skips MuJoCo); 1 anything else (e.g. MuJoCo refuses the model).
"""

import json
import math
import sys
import time

EXIT_BAD_INPUT = 2
EXIT_NO_MUJOCO = 3
# Steps between samples of the deepest contact.
SAMPLE_EVERY = 10
# The two torsional and rolling friction values of MuJoCo's default geom friction.
TORSIONAL_ROLLING = (0.005, 0.0001)


class BadInput(ValueError):
    """The input document is malformed; the message names the field."""


def _num(v, where, positive=False, nonnegative=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise BadInput(f"{where} must be a finite number, got {v!r}")
    if positive and not v > 0:
        raise BadInput(f"{where} must be positive, got {v!r}")
    if nonnegative and not v >= 0:
        raise BadInput(f"{where} must not be negative, got {v!r}")
    return float(v)


def _vec(v, n, where, positive=False):
    if not isinstance(v, list) or len(v) != n:
        raise BadInput(f"{where} must be a list of {n} numbers, got {v!r}")
    return [_num(x, f"{where}[{i}]", positive=positive) for i, x in enumerate(v)]


def _field(obj, key, where):
    if not isinstance(obj, dict) or key not in obj:
        raise BadInput(f"{where}: missing {key!r}")
    return obj[key]


def _unit_quat(v, where):
    q = _vec(v, 4, where)
    n = math.sqrt(sum(x * x for x in q))
    if n < 1e-9:
        raise BadInput(f"{where} must be a non-zero quaternion [w, x, y, z], got {v!r}")
    return [x / n for x in q]


def _unit(v, where):
    u = _vec(v, 3, where)
    n = math.sqrt(sum(x * x for x in u))
    if n < 1e-9:
        raise BadInput(f"{where} must be a non-zero vector, got {v!r}")
    return [x / n for x in u]


def parse(doc):
    """Checks the input document and returns it with numbers as floats and defaults filled in."""
    if not isinstance(doc, dict):
        raise BadInput("the input must be a JSON object")
    out = {
        "scene": str(doc.get("scene", "")),
        "duration_s": _num(_field(doc, "duration_s", "input"), "duration_s", positive=True),
        "dt_s": None,
        "gravity_m_s2": _vec(_field(doc, "gravity_m_s2", "input"), 3, "gravity_m_s2"),
        "friction": _num(_field(doc, "friction", "input"), "friction", nonnegative=True),
        "bodies": [],
        "statics": [],
    }
    if doc.get("dt_s") is not None:
        out["dt_s"] = _num(doc["dt_s"], "dt_s", positive=True)
    bodies = _field(doc, "bodies", "input")
    if not isinstance(bodies, list):
        raise BadInput("bodies must be a list")
    for i, b in enumerate(bodies):
        w = f"bodies[{i}]"
        shape = _field(b, "shape", w)
        body = {"shape": shape}
        if shape == "box":
            body["half_extents_m"] = _vec(
                _field(b, "half_extents_m", w), 3, f"{w}.half_extents_m", positive=True
            )
        elif shape == "ball":
            body["radius_m"] = _num(_field(b, "radius_m", w), f"{w}.radius_m", positive=True)
        else:
            raise BadInput(f"{w}.shape must be 'box' or 'ball', got {shape!r}")
        body["center_m"] = _vec(_field(b, "center_m", w), 3, f"{w}.center_m")
        body["orientation_wxyz"] = _unit_quat(
            _field(b, "orientation_wxyz", w), f"{w}.orientation_wxyz"
        )
        body["mass_kg"] = _num(_field(b, "mass_kg", w), f"{w}.mass_kg", positive=True)
        body["com_m"] = _vec(_field(b, "com_m", w), 3, f"{w}.com_m")
        rows = _field(b, "inertia_kg_m2", w)
        if not isinstance(rows, list) or len(rows) != 3:
            raise BadInput(f"{w}.inertia_kg_m2 must be a 3x3 list of lists")
        inertia = [_vec(r, 3, f"{w}.inertia_kg_m2[{k}]") for k, r in enumerate(rows)]
        scale = max(abs(x) for r in inertia for x in r)
        for r in range(3):
            for c in range(r + 1, 3):
                if abs(inertia[r][c] - inertia[c][r]) > 1e-6 * scale:
                    raise BadInput(f"{w}.inertia_kg_m2 is not symmetric")
        if not all(inertia[k][k] > 0 for k in range(3)):
            raise BadInput(f"{w}.inertia_kg_m2 must have a positive diagonal")
        body["inertia_kg_m2"] = inertia
        for key in ("velocity_m_s", "omega_rad_s"):
            v = b.get(key)
            body[key] = [0.0, 0.0, 0.0] if v is None else _vec(v, 3, f"{w}.{key}")
        out["bodies"].append(body)
    statics = doc.get("statics", [])
    if not isinstance(statics, list):
        raise BadInput("statics must be a list")
    for i, s in enumerate(statics):
        w = f"statics[{i}]"
        shape = _field(s, "shape", w)
        if shape == "plane":
            out["statics"].append(
                {
                    "shape": "plane",
                    "point_m": _vec(_field(s, "point_m", w), 3, f"{w}.point_m"),
                    "normal": _unit(_field(s, "normal", w), f"{w}.normal"),
                }
            )
        elif shape == "box":
            out["statics"].append(
                {
                    "shape": "box",
                    "center_m": _vec(_field(s, "center_m", w), 3, f"{w}.center_m"),
                    "half_extents_m": _vec(
                        _field(s, "half_extents_m", w), 3, f"{w}.half_extents_m", positive=True
                    ),
                }
            )
        else:
            raise BadInput(f"{w}.shape must be 'plane' or 'box', got {shape!r}")
    return out


def _f(xs):
    """Numbers as MJCF attribute text, to full double precision."""
    return " ".join(repr(float(x)) for x in xs)


def mjcf(inp, np, quat_to_mat):
    """The MJCF document of the parsed input."""
    friction = _f((inp["friction"],) + TORSIONAL_ROLLING)
    option = f'<option gravity="{_f(inp["gravity_m_s2"])}"'
    if inp["dt_s"] is not None:
        option += f' timestep="{_f([inp["dt_s"]])}"'
    option += '><flag sleep="disable"/></option>'
    lines = ['<mujoco model="splatphys-contact">', option, "<worldbody>"]
    for i, s in enumerate(inp["statics"]):
        if s["shape"] == "plane":
            lines.append(
                f'<geom name="static{i}" type="plane" size="0 0 1" pos="{_f(s["point_m"])}"'
                f' zaxis="{_f(s["normal"])}" friction="{friction}"/>'
            )
        else:
            lines.append(
                f'<geom name="static{i}" type="box" size="{_f(s["half_extents_m"])}"'
                f' pos="{_f(s["center_m"])}" friction="{friction}"/>'
            )
    for i, b in enumerate(inp["bodies"]):
        q = b["orientation_wxyz"]
        r = quat_to_mat(q)
        center = np.array(b["center_m"])
        ipos = r.T @ (np.array(b["com_m"]) - center)
        i_world = np.array(b["inertia_kg_m2"])
        i_world = 0.5 * (i_world + i_world.T)
        i_body = r.T @ i_world @ r
        full = [i_body[0, 0], i_body[1, 1], i_body[2, 2], i_body[0, 1], i_body[0, 2], i_body[1, 2]]
        if b["shape"] == "box":
            geom = f'type="box" size="{_f(b["half_extents_m"])}"'
        else:
            geom = f'type="sphere" size="{_f([b["radius_m"]])}"'
        lines += [
            f'<body name="body{i}" pos="{_f(center)}" quat="{_f(q)}">',
            f'<freejoint name="free{i}"/>',
            f'<geom name="geom{i}" {geom} friction="{friction}"/>',
            f'<inertial pos="{_f(ipos)}" mass="{_f([b["mass_kg"]])}" fullinertia="{_f(full)}"/>',
            "</body>",
        ]
    lines += ["</worldbody>", "</mujoco>"]
    return "\n".join(lines)


def simulate(inp, mujoco, np):
    """Builds and steps the model; returns the output document."""
    def quat_to_mat(q):
        m = np.zeros(9)
        mujoco.mju_quat2Mat(m, np.asarray(q, dtype=float))
        return m.reshape(3, 3)

    # Warnings to stderr, not to MUJOCO_LOG.TXT in the caller's directory.
    mujoco.set_mju_user_warning(lambda msg: print(f"contact.py: MuJoCo: {msg}", file=sys.stderr))
    model = mujoco.MjModel.from_xml_string(mjcf(inp, np, quat_to_mat))
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    steps = max(1, round(inp["duration_s"] / dt))
    # Body ids: the world is body 0, then the bodies in input order.
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"body{i}")
           for i in range(len(inp["bodies"]))]
    mujoco.mj_forward(model, data)
    # Start velocities: the free joint's qvel is (velocity of the body frame origin, world;
    # angular velocity, body axes); the input gives the COM velocity and world omega.
    for i, b in zip(ids, inp["bodies"]):
        adr = model.jnt_dofadr[model.body_jntadr[i]]
        omega = np.array(b["omega_rad_s"])
        r = data.xmat[i].reshape(3, 3)
        lever = data.xipos[i] - data.xpos[i]
        data.qvel[adr:adr + 3] = np.array(b["velocity_m_s"]) - np.cross(omega, lever)
        data.qvel[adr + 3:adr + 6] = r.T @ omega
    mujoco.mj_forward(model, data)
    deepest = 0.0
    wall = 0.0
    done = 0
    while done < steps:
        n = min(SAMPLE_EVERY, steps - done)
        t0 = time.perf_counter()
        mujoco.mj_step(model, data, nstep=n)
        wall += time.perf_counter() - t0
        done += n
        if data.ncon > 0:
            deepest = max(deepest, float(-np.min(data.contact.dist[: data.ncon])))
    # After mj_step the derived quantities lag one integration behind qpos / qvel.
    mujoco.mj_forward(model, data)
    res = np.zeros(6)
    bodies = []
    for i, b in zip(ids, inp["bodies"]):
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, i, res, 0)
        q0_inv = np.zeros(4)
        mujoco.mju_negQuat(q0_inv, np.array(b["orientation_wxyz"]))
        rel = np.zeros(4)
        mujoco.mju_mulQuat(rel, data.xquat[i], q0_inv)
        rel /= np.linalg.norm(rel)
        bodies.append(
            {
                "com_m": [float(x) for x in data.xipos[i]],
                "orientation_wxyz": [float(x) for x in rel],
                "velocity_m_s": [float(x) for x in res[3:6]],
                "omega_rad_s": [float(x) for x in res[0:3]],
            }
        )
    # MuJoCo's warnings that fired (a bad qacc means it reset the state: the run is void).
    warnings = {}
    for name in dir(mujoco.mjtWarning):
        if name.startswith("mjWARN_"):
            count = int(data.warning[int(getattr(mujoco.mjtWarning, name))].number)
            if count > 0:
                warnings[name] = count
    return {
        "engine": f"mujoco {mujoco.__version__}",
        "steps": steps,
        "dt_s": dt,
        "wall_s": wall,
        "simulated_s": steps * dt,
        "bodies": bodies,
        "deepest_contact_m": deepest,
        "warnings": warnings,
    }


def main() -> int:
    try:
        import mujoco
        import numpy as np
    except ImportError as e:
        print(f"contact.py: cannot import mujoco ({e}): pip install mujoco", file=sys.stderr)
        return EXIT_NO_MUJOCO
    try:
        inp = parse(json.load(sys.stdin))
    except json.JSONDecodeError as e:
        print(f"contact.py: bad input: not JSON: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BadInput as e:
        print(f"contact.py: bad input: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        out = simulate(inp, mujoco, np)
    except ValueError as e:
        # MuJoCo's compiler refuses the model (e.g. an inertia that breaks the triangle rule).
        print(f"contact.py: MuJoCo refused the scene: {e}", file=sys.stderr)
        return 1
    try:
        text = json.dumps(out, allow_nan=False)
    except ValueError:
        print("contact.py: MuJoCo's state is not finite at the end", file=sys.stderr)
        return 1
    sys.stdout.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
