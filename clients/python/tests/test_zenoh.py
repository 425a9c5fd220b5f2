"""`ZenohClient` through `splatphys-zenoh` against a live `splatphys serve --fake`, on loopback:
the frames, objects and scene a remote reader gets are byte for byte the shared-memory ones; a
command over Zenoh gets the server's reply; a bridge without `--allow-commands` refuses with the
reason; the server's and the bridge's end reach the remote client within 3 s.

Needs the `splatphys` and `splatphys-zenoh` binaries (`cargo build --release -p splatphys
-p splatphys-zenoh`) and `pip install eclipse-zenoh`; skipped with a message otherwise.
"""

import os
import signal
import socket
import subprocess
import time

import pytest

import splatphys_client as sc
from test_live import server_binary, stop

BIN = server_binary()
BRIDGE = BIN.parent / "splatphys-zenoh" if BIN is not None else None
try:
    import zenoh  # noqa: F401

    HAVE_ZENOH = True
except ImportError:
    HAVE_ZENOH = False

pytestmark = pytest.mark.skipif(
    BIN is None or not BRIDGE.exists() or not HAVE_ZENOH,
    reason="needs target/*/splatphys and splatphys-zenoh (cargo build --release -p splatphys "
    "-p splatphys-zenoh) and `pip install eclipse-zenoh`",
)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def bridged(request):
    """A fake server and a bridge under a fresh iceoryx2 prefix and a free port; yields
    (prefix, endpoint, server process, bridge process). `request.param`: extra bridge flags."""
    iox = f"spxzn_{request.node.name[:20]}_{os.getpid()}_"
    os.environ[sc.client.IOX2_PREFIX_ENV] = iox
    env = {**os.environ, sc.client.IOX2_PREFIX_ENV: iox}
    prefix, port = "t/zn", free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    server = subprocess.Popen(
        [str(BIN), "serve", "--fake", "--prefix", prefix, "--fake-dt", "0.01",
         "--fake-objects", "3", "--fake-gaussians", "400"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    bridge = subprocess.Popen(
        [str(BRIDGE), "--prefix", prefix, "--listen", endpoint] + getattr(request, "param", ["--allow-commands"]),
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    yield prefix, endpoint, server, bridge
    stop(bridge)
    stop(server)


def shm_bytes(view) -> bytes:
    return bytes(view.header) + view.array.tobytes()


def test_frames_objects_and_scene_are_byte_identical_to_shared_memory(bridged):
    prefix, endpoint, _, _ = bridged
    with sc.Client(prefix, frame_buffer=4) as local, sc.ZenohClient(
        prefix, connect=[endpoint], connect_timeout_s=20.0, frame_buffer=4
    ) as remote:
        info = remote.scene_info()
        assert info == local.scene_info()
        assert info["gaussian_count"] == 1200 and info["object_names"] == ["cube0", "cube1", "cube2"]
        frames = {"local": {}, "remote": {}}
        objects = {"local": {}, "remote": {}}
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            for side, c, as_bytes in (("local", local, shm_bytes), ("remote", remote, lambda v: v.raw)):
                for recv, into in ((c.recv_frame, frames), (c.recv_objects, objects)):
                    while (v := recv()) is not None:
                        with v:
                            into[side][v.header.step] = as_bytes(v)
            common = set(frames["local"]) & set(frames["remote"])
            common_objects = set(objects["local"]) & set(objects["remote"])
            if len(common) >= 5 and len(common_objects) >= 5:
                break
            time.sleep(0.002)
        assert len(common) >= 5, f"frames heard on both sides: {len(common)}"
        assert len(common_objects) >= 5, f"objects heard on both sides: {len(common_objects)}"
        for step in common:
            assert frames["remote"][step] == frames["local"][step], f"frame of step {step}"
            assert len(frames["remote"][step]) == 56 + 1200 * 52
        for step in common_objects:
            assert objects["remote"][step] == objects["local"][step], f"objects of step {step}"
        # The remote reader decodes with the shared-memory dtypes.
        f = remote.wait_frame(timeout_s=5.0)
        assert f is not None and f.gaussians["position_m"].shape == (1200, 3)


def test_a_command_over_zenoh_gets_the_servers_reply(bridged):
    prefix, endpoint, _, _ = bridged
    with sc.ZenohClient(prefix, connect=[endpoint], connect_timeout_s=20.0, frames=False) as c:
        r = c.command(sc.Impulse(c.object_id("cube1"), (0.0, 0.0, 2.0)), timeout_s=10.0)
        assert r.accepted and r.effective_step > 0 and r.sequence == 1
        r = c.command(sc.EditMaterial(0, poisson_ratio=0.7), timeout_s=10.0)
        assert not r.accepted and r.reject_code == 4 and "nu = 0.7" in r.reason
        assert c.command(sc.Pause(), timeout_s=10.0).accepted
        assert c.command(sc.Step(2), timeout_s=10.0).accepted
        r = c.command(sc.Reset(), timeout_s=10.0)
        assert r.accepted and r.generation == 1 and r.effective_step == 0


def test_a_clean_shutdown_reaches_the_remote_client_as_a_shutdown_not_a_crash(bridged):
    prefix, endpoint, server, bridge = bridged
    with sc.ZenohClient(prefix, connect=[endpoint], connect_timeout_s=20.0, frame_buffer=1) as c:
        assert c.command(sc.Shutdown(), timeout_s=10.0).accepted
        with pytest.raises(sc.ServerShutDown):
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                c.recv_frame()
                c.wait(0.01)
    assert server.wait(timeout=5) == 0
    assert bridge.wait(timeout=5) == 0


@pytest.mark.parametrize("bridged", [[]], indirect=True)
def test_a_bridge_without_allow_commands_refuses_with_the_reason(bridged):
    prefix, endpoint, _, _ = bridged
    with sc.ZenohClient(prefix, connect=[endpoint], connect_timeout_s=20.0, frames=False) as c:
        with pytest.raises(sc.CommandRefused, match="--allow-commands"):
            c.command(sc.Pause(), timeout_s=10.0)
        # Still connected, still hearing the server.
        assert c.poll_status() is not None


@pytest.mark.parametrize("victim", ["server", "bridge", "frozen bridge"])
def test_a_killed_server_or_bridge_reaches_the_remote_client_within_3_s(bridged, victim):
    """kill -9 of the server (the bridge drops its token after the 1 s heartbeat timeout), of
    the bridge (its socket closes), and a frozen bridge (SIGSTOP: the socket stays open and
    silent, as on a lost network: the link lease and the status heartbeat tell)."""
    prefix, endpoint, server, bridge = bridged
    with sc.ZenohClient(prefix, connect=[endpoint], connect_timeout_s=20.0) as c:
        assert c.wait_frame(timeout_s=5.0) is not None
        if victim == "frozen bridge":
            bridge.send_signal(signal.SIGSTOP)
        else:
            proc = server if victim == "server" else bridge
            proc.kill()
            proc.wait()
        killed = time.monotonic()
        with pytest.raises(sc.ServerGone):
            while time.monotonic() - killed < 10:
                c.recv_frame()
                c.wait(0.01)
        noticed = time.monotonic() - killed
        print(f"{victim}: noticed after {noticed:.2f} s")
        if victim == "frozen bridge":
            bridge.send_signal(signal.SIGCONT)
        assert noticed < 3.0
