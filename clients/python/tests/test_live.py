"""splatphys_client against a live `splatphys serve --fake` process (free-fall stand-in).

Needs the `splatphys` binary: target/release/splatphys if built, else target/debug/splatphys
(`cargo build --release -p splatphys --bin splatphys`); skipped with a message when neither exists.
Each test uses its own iceoryx2 file prefix, so tests never see each other's services.
"""

import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

import splatphys_client as sc
from splatphys_client import wire

REPO = Path(__file__).resolve().parents[3]


def server_binary():
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    for profile in ("release", "debug"):
        b = target / profile / "splatphys"
        if b.exists():
            return b
    return None


BIN = server_binary()
needs_server = pytest.mark.skipif(
    BIN is None,
    reason="splatphys binary not built: run `cargo build --release -p splatphys --bin splatphys` first",
)


@pytest.fixture
def server(request):
    """Starts a fake server under a fresh iceoryx2 prefix; yields (prefix, process)."""
    iox = f"spxpy_{request.node.name[:24]}_{os.getpid()}_"
    os.environ[sc.client.IOX2_PREFIX_ENV] = iox
    prefix = "t/py"
    args = [str(BIN), "serve", "--fake", "--prefix", prefix]
    args += getattr(request, "param", ["--fake-dt", "0.001"])
    proc = subprocess.Popen(
        args,
        env={**os.environ, sc.client.IOX2_PREFIX_ENV: iox},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    yield prefix, proc
    stop(proc)


def stop(proc) -> None:
    """SIGTERM, then SIGKILL after 5 s, for a process that is still running."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def test_dtypes_match_the_rust_sizes():
    assert wire.FRAME_GAUSSIAN_DTYPE.itemsize == 52
    assert wire.SCENE_GAUSSIAN_DTYPE.itemsize == 228
    assert wire.OBJECT_STATE_DTYPE.itemsize == 88
    assert wire.FRAME_HEADER_DTYPE.itemsize == 56
    assert wire.STATUS_DTYPE.itemsize == 600
    assert wire.COMMAND_DTYPE.itemsize == 184
    assert wire.REPLY_DTYPE.itemsize == 256
    assert wire.COMMAND_LOG_DTYPE.itemsize == 480
    assert wire.FRAME_GAUSSIAN_DTYPE["position_m"].shape == (3,)


@needs_server
@pytest.mark.parametrize(
    "server", [["--fake-dt", "0.001", "--fake-objects", "70", "--fake-gaussians", "8"]],
    indirect=True,
)
def test_every_object_name_is_read_beyond_the_64_in_the_scene_header(server):
    prefix, _ = server
    with sc.Client(prefix) as c:
        info = c.scene_info()
        assert info["object_count"] == 70
        assert wire.MAX_NAMED_OBJECTS == 64
        assert info["object_names"] == [f"cube{i}" for i in range(70)]
        assert c.object_id("cube69") == 69


@needs_server
@pytest.mark.parametrize(
    "server", [["--fake-dt", "0.001", "--fake-objects", "3", "--fake-gaussians", "500"]],
    indirect=True,
)
def test_frames_arrive_as_zero_copy_views_with_the_right_count(server):
    prefix, _ = server
    with sc.Client(prefix) as c:
        info = c.scene_info()
        assert info["gaussian_count"] == 1500
        assert info["object_names"] == ["cube0", "cube1", "cube2"]
        last_index = None
        for _ in range(100):
            f = c.wait_frame(timeout_s=2.0)
            assert f is not None, "no frame within 2 s"
            with f:
                assert f.header.count == 1500
                assert f.array.shape == (1500,)
                assert f.array.dtype == wire.FRAME_GAUSSIAN_DTYPE
                # A view of the shared memory, not a copy.
                assert f.array.__array_interface__["data"][0] == f.address
                assert not f.array.flags.owndata
                pos = f.gaussians["position_m"]
                assert pos.shape == (1500, 3) and pos.dtype == np.float32
                # Free fall from z = 10 m: every Gaussian of a cube shares its COM height
                # plus an offset of at most 0.07 m (8x8x8 lattice at 1 cm).
                z = pos[:, 2].reshape(3, 500)
                assert np.all(z.max(axis=1) - z.min(axis=1) <= 0.0701)
                if last_index is not None:
                    assert f.header.frame_index > last_index
                last_index = f.header.frame_index
        o = None
        deadline = time.monotonic() + 2
        while o is None and time.monotonic() < deadline:
            o = c.recv_objects()
        assert o is not None
        with o:
            assert o.array.shape == (3,)
            assert list(o.objects["id"]) == [0, 1, 2]
            assert np.allclose(o.objects["mass_kg"], 1.0)


@needs_server
def test_commands_get_replies(server):
    prefix, _ = server
    with sc.Client(prefix, frames=False) as c:
        r = c.command(sc.Impulse(c.object_id("cube1"), (0.0, 0.0, 2.0)))
        assert r.accepted and r.effective_step > 0 and r.sequence == 1
        r = c.command(sc.EditMaterial(0, poisson_ratio=0.7))
        assert not r.accepted and r.reject_code == 4
        assert "nu = 0.7" in r.reason
        r = c.command(sc.SetVelocity(7, (0, 0, 0)))
        assert not r.accepted and r.reject_code == 3
        r = c.command(sc.Impulse(0, (float("nan"), 0, 0)))
        assert not r.accepted and r.reject_code == 2
        # Pose and angular velocity travel and are checked (the stand-in moves the COM).
        assert c.command(sc.SetPose(1, (0.5, 0.0, 3.0), at_step=40)).accepted
        assert c.command(sc.SetVelocity(1, (0, 0, 0), angular_velocity_rad_s=(0, 0, 1))).accepted
        r = c.command(sc.SetPose(1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0)))
        assert not r.accepted and r.reject_code == 4 and "not a rotation" in r.reason
        r = c.command(sc.SetVelocity(1, (0, 0, 0), angular_velocity_rad_s=(float("inf"), 0, 0)))
        assert not r.accepted and r.reject_code == 2
        assert c.command(sc.Pause()).accepted
        assert c.command(sc.Step(2)).accepted
        assert c.command(sc.Resume()).accepted
        # A reset's reply names the new generation and its first step.
        r = c.command(sc.Reset())
        assert r.accepted and r.generation == 1 and r.effective_step == 0


@needs_server
def test_shutdown_command_ends_the_stream_cleanly(server):
    prefix, proc = server
    with sc.Client(prefix, frame_buffer=1) as c:
        assert c.command(sc.Shutdown()).accepted
        with pytest.raises(sc.ServerShutDown):
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                f = c.recv_frame()
                if f is not None:
                    f.release()
                time.sleep(0.001)
    assert proc.wait(timeout=5) == 0


@needs_server
def test_killed_server_is_noticed_within_a_second(server):
    prefix, proc = server
    with sc.Client(prefix) as c:
        f = c.wait_frame(timeout_s=2.0)
        assert f is not None
        f.release()
        proc.kill()
        proc.wait()
        killed = time.monotonic()
        with pytest.raises(sc.ServerGone, match="no heartbeat"):
            while time.monotonic() - killed < 5:
                f = c.recv_frame()
                if f is not None:
                    f.release()
                time.sleep(0.001)
        # 1 s heartbeat timeout + one 0.1 s status period + slack.
        assert time.monotonic() - killed < 1.6


def test_no_server_raises_server_not_found(monkeypatch):
    monkeypatch.setenv(sc.client.IOX2_PREFIX_ENV, f"spxpy_none_{os.getpid()}_")
    with pytest.raises(sc.ServerNotFound, match="no splatphys server"):
        sc.Client("t/none", connect_timeout_s=0.2)
