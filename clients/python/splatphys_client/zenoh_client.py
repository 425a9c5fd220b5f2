"""The same client over Zenoh, for a server on another machine: `splatphys-zenoh` runs beside
the server and republishes its services under a key prefix (docs/reference/protocol.md, "Zenoh
keys"); `ZenohClient` subscribes to those keys and offers `Client`'s API, so a program written
for shared memory runs unchanged over the network.

    from splatphys_client import ZenohClient, Impulse
    with ZenohClient("splatphys/vase", connect=["tcp/192.168.1.20:7447"]) as c:
        with c.wait_frame(timeout_s=1.0) as f:
            print(f.header.step, f.gaussians["position_m"].mean(axis=0))
        print(c.command(Impulse(object_id=0, impulse_n_s=(0, 0, 2))))

Differences from shared memory: samples are copies (the bytes crossed a socket), so `release()`
costs nothing; frames are best effort and newest-only (a slow reader sees the newest frame,
never a queue of old ones); the server's or the bridge's end is noticed through Zenoh
liveliness tokens (`<key>/alive/*`) as well as the status heartbeat. Needs `pip install
eclipse-zenoh` (1.x, the bridge's version).
"""

import collections
import ctypes
import threading
import time
from typing import Optional, Sequence

import numpy as np

from . import wire
from .client import (
    HEARTBEAT_TIMEOUT_S,
    MAX_FRAME_BUFFER,
    ClientApi,
    Command,
    LayoutMismatch,
    Reply,
    ServerGone,
    ServerNotFound,
    ServerShutDown,
    reply_of,
    scene_info_of,
)
from .wire import FrameHeader, ReplyMsg, SceneHeader, Status

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
# The bridge publishes the server's 10 Hz status; a network adds jitter that shared memory
# does not have, so the default silence allowed is longer.
ZENOH_HEARTBEAT_TIMEOUT_S = 2.0 * HEARTBEAT_TIMEOUT_S
OBJECTS_BUFFER = 64
# How long after a liveliness token ends the client waits for a final status (a clean
# shutdown's) before it raises ServerGone.
GONE_GRACE_S = 0.3


class CommandRefused(RuntimeError):
    """The bridge did not forward a command (started without `--allow-commands`, or the server
    did not answer in time); the message says which."""


class BytesView:
    """A received sample as bytes: `header` (a ctypes copy) and `array` (a read-only numpy view
    of the payload bytes), with `SampleView`'s interface."""

    def __init__(self, data: bytes, header_type, dtype: np.dtype):
        hsize = ctypes.sizeof(header_type)
        if len(data) < hsize:
            raise ValueError(f"{header_type.__name__}: sample of {len(data)} B is shorter than its header")
        self.raw = data
        self.header = header_type.from_buffer_copy(data[:hsize])
        count = getattr(self.header, "count", None)
        if count is None:
            count = self.header.gaussian_count
        if count * dtype.itemsize > len(data) - hsize:
            raise ValueError(
                f"{header_type.__name__}: header says {count} elements, payload has {len(data) - hsize} B"
            )
        self.array = np.frombuffer(data, dtype=dtype, count=count, offset=hsize)

    def release(self) -> None:
        """Nothing to give back (the bytes are this process's); kept for `SampleView`'s API."""
        self.array = None

    def __enter__(self) -> "BytesView":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    @property
    def gaussians(self) -> np.ndarray:
        return self.array

    @property
    def objects(self) -> np.ndarray:
        return self.array


class _Pending:
    """A command query in flight: `receive()` gives the reply once it arrived."""

    def __init__(self, replies, sequence: int):
        self._replies = replies
        self.sequence = sequence

    def receive(self):
        return self._replies.try_recv()

    def delete(self) -> None:
        self._replies = None


def _config(connect: Sequence[str], config_file: Optional[str]):
    import zenoh

    conf = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    if not config_file:
        conf.insert_json5("mode", '"client"')
        conf.insert_json5("scouting/multicast/enabled", "false")
    if connect:
        conf.insert_json5("connect/endpoints", "[" + ",".join(f'"{e}"' for e in connect) + "]")
    return conf


class ZenohClient(ClientApi):
    """A connection through `splatphys-zenoh` to the server under `prefix` (the bridge's key
    prefix, by default the server's service prefix), with `Client`'s methods.

    `connect`: Zenoh endpoints of the bridge or of a router it joined (default: the bridge's
    default `tcp/127.0.0.1:7447`). `config_file`: a Zenoh JSON5 configuration (TLS, user and
    password), applied before `connect`.
    """

    def __init__(
        self,
        prefix: str,
        connect: Sequence[str] = (DEFAULT_ENDPOINT,),
        config_file: Optional[str] = None,
        connect_timeout_s: float = 5.0,
        heartbeat_timeout_s: float = ZENOH_HEARTBEAT_TIMEOUT_S,
        frames: bool = True,
        objects: bool = True,
        commands: bool = True,
        frame_buffer: int = 2,
        command_timeout_s: float = 5.0,
    ):
        import zenoh

        self.prefix = prefix.rstrip("/")
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.command_timeout_s = command_timeout_s
        self._commands = commands
        self._lock = threading.Condition()
        self._frames = collections.deque(maxlen=max(1, min(frame_buffer, MAX_FRAME_BUFFER)))
        self._objects = collections.deque(maxlen=OBJECTS_BUFFER)
        self._statuses = collections.deque(maxlen=16)
        self._scenes = collections.deque(maxlen=4)
        self._names = collections.deque(maxlen=4)
        self._alive = set()
        self._gone = None
        start = time.monotonic()
        while True:
            try:
                self.session = zenoh.open(_config(connect, config_file))
                break
            except zenoh.ZError as e:
                if time.monotonic() - start > connect_timeout_s:
                    raise ServerNotFound(
                        f"no Zenoh peer at {', '.join(connect)} after {connect_timeout_s:.1f} s "
                        f"(is `splatphys-zenoh` running?): {e}"
                    ) from None
                time.sleep(0.1)
        self._subs = [
            self.session.liveliness().declare_subscriber(self._key("alive/*"), self._on_alive, history=True),
            self.session.declare_subscriber(self._key("status"), self._pusher(self._statuses)),
            self.session.declare_subscriber(self._key("scene"), self._pusher(self._scenes)),
            self.session.declare_subscriber(self._key("object_names"), self._pusher(self._names)),
        ]
        if frames:
            self._subs.append(self.session.declare_subscriber(self._key("frame"), self._pusher(self._frames)))
        if objects:
            self._subs.append(self.session.declare_subscriber(self._key("objects"), self._pusher(self._objects)))
        # The server is there when the bridge says so (its token) and a status arrived.
        while not ({"server", "bridge"} <= self._alive and self._statuses):
            if time.monotonic() - start > connect_timeout_s:
                self.close()
                raise ServerNotFound(
                    f"no splatphys server bridged under `{self.prefix}` at {', '.join(connect)} after "
                    f"{connect_timeout_s:.1f} s (alive: {sorted(self._alive) or 'nothing'})"
                )
            self.wait(0.01)
        # Late joiner: the scene and the names were published before this client subscribed.
        for leaf, queue in (("scene", self._scenes), ("object_names", self._names)):
            for reply in self.session.get(self._key(leaf), timeout=2.0):
                if reply.ok is not None:
                    self._push(queue, reply.ok.payload.to_bytes(), front=True)
        self._last_beat = time.monotonic()
        self.last_status: Optional[Status] = None
        self.shutting_down = False
        self._sequence = 1
        self._scene_info = None
        self._object_names = {}

    def _key(self, leaf: str) -> str:
        return f"{self.prefix}/{leaf}"

    def _push(self, queue, data: bytes, front: bool = False) -> None:
        with self._lock:
            if front:
                queue.appendleft(data)
            else:
                queue.append(data)
            self._lock.notify_all()

    def _pusher(self, queue):
        return lambda sample: self._push(queue, sample.payload.to_bytes())

    def _on_alive(self, sample) -> None:
        import zenoh

        who = str(sample.key_expr).rsplit("/", 1)[-1]
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._alive.add(who)
            else:
                self._alive.discard(who)
                self._gone = self._gone or (who, time.monotonic())
            self._lock.notify_all()

    def _pop(self, queue) -> Optional[bytes]:
        with self._lock:
            return queue.popleft() if queue else None

    def wait(self, timeout_s: float) -> None:
        """Waits up to `timeout_s` for anything to arrive."""
        with self._lock:
            self._lock.wait(timeout_s)

    def close(self) -> None:
        """Undeclares everything and closes the session; the client cannot be used afterwards."""
        for s in getattr(self, "_subs", []):
            s.undeclare()
        self._subs = []
        if getattr(self, "session", None) is not None:
            self.session.close()
            self.session = None

    def __enter__(self) -> "ZenohClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # Status, heartbeat and liveliness.
    def poll_status(self) -> Optional[Status]:
        """Drains `status`; raises ServerShutDown or ServerGone when the server or the bridge
        ended (liveliness), ServerGone after `heartbeat_timeout_s` without a status."""
        while (data := self._pop(self._statuses)) is not None:
            st = Status.from_buffer_copy(data[: ctypes.sizeof(Status)])
            self._last_beat = time.monotonic()
            self.shutting_down |= bool(st.flags & wire.STATUS_SHUTTING_DOWN)
            self.last_status = st
        # A token may end a moment before the last status (a clean shutdown's) arrives: wait
        # for it briefly before calling the end a crash.
        if self._gone is not None and not self.shutting_down and time.monotonic() - self._gone[1] > GONE_GRACE_S:
            who, at = self._gone
            raise ServerGone(
                f"splatphys {'server' if who == 'server' else 'bridge'} under `{self.prefix}` is gone "
                f"(its Zenoh liveliness token ended {time.monotonic() - at:.1f} s ago)"
            )
        silent = time.monotonic() - self._last_beat
        if not self.shutting_down and silent > self.heartbeat_timeout_s:
            raise ServerGone(
                f"splatphys server under `{self.prefix}` is gone: no status over Zenoh for "
                f"{silent * 1e3:.0f} ms"
            )
        return self.last_status

    # Scene.
    def recv_scene(self) -> Optional[BytesView]:
        """The next scene sample (once per generation; the first from a query at connect)."""
        data = self._pop(self._scenes)
        if data is None:
            return None
        view = BytesView(data, SceneHeader, wire.SCENE_GAUSSIAN_DTYPE)
        h = view.header
        if h.layout_version != wire.LAYOUT_VERSION:
            raise LayoutMismatch(f"server layout {h.layout_version}, client {wire.LAYOUT_VERSION}")
        self._scene_info = scene_info_of(h)
        self._take_object_names()
        return view

    def _take_object_names(self, timeout_s: float = 0.5) -> None:
        info = self._scene_info
        deadline = time.monotonic() + timeout_s
        while True:
            while (data := self._pop(self._names)) is not None:
                with BytesView(data, FrameHeader, wire.OBJECT_NAME_DTYPE) as v:
                    self._object_names[v.header.scene_generation] = [
                        wire.fixed_str(n) for n in v.array["name"]
                    ]
            names = self._object_names.get(info["generation"])
            if names is not None and len(names) == info["object_count"]:
                info["object_names"] = list(names)
                return
            if info["object_count"] <= wire.MAX_NAMED_OBJECTS or time.monotonic() > deadline:
                return
            self.wait(0.01)

    # Frames and objects.
    def _recv(self, queue, dtype) -> Optional[BytesView]:
        self.poll_status()
        data = self._pop(queue)
        if data is None:
            if self.shutting_down:
                raise ServerShutDown(f"splatphys server under `{self.prefix}` shut down")
            return None
        view = BytesView(data, FrameHeader, dtype)
        if view.header.layout_version != wire.LAYOUT_VERSION:
            raise LayoutMismatch(f"server layout {view.header.layout_version}, client {wire.LAYOUT_VERSION}")
        return view

    def recv_frame(self) -> Optional[BytesView]:
        """The oldest buffered frame, or None."""
        return self._recv(self._frames, wire.FRAME_GAUSSIAN_DTYPE)

    def latest_frame(self) -> Optional[BytesView]:
        """The newest buffered frame (older ones dropped), or None."""
        with self._lock:
            while len(self._frames) > 1:
                self._frames.popleft()
        return self.recv_frame()

    def recv_objects(self) -> Optional[BytesView]:
        """The oldest buffered objects sample, or None."""
        return self._recv(self._objects, wire.OBJECT_STATE_DTYPE)

    # Commands: a Zenoh query with the CommandMsg as payload, answered with the ReplyMsg.
    def send(self, cmd: Command):
        """Sends without waiting; returns (sequence, pending) for `poll_reply`."""
        if not self._commands:
            raise RuntimeError("this client was opened with commands=False")
        seq = self._sequence
        self._sequence += 1
        payload = bytes(cmd.to_msg(seq))
        replies = self.session.get(self._key("command"), payload=payload, timeout=self.command_timeout_s)
        return seq, _Pending(replies, seq)

    @staticmethod
    def poll_reply(pending) -> Optional[Reply]:
        """The reply to a pending command if it arrived; raises CommandRefused when the bridge
        answered with a reason instead."""
        r = pending.receive()
        if r is None:
            return None
        pending.delete()
        if r.ok is None:
            why = r.err.payload.to_string()
            if why == "Timeout":
                raise TimeoutError(f"no reply to command #{pending.sequence} through the bridge")
            raise CommandRefused(f"command #{pending.sequence}: {why}")
        return reply_of(ReplyMsg.from_buffer_copy(r.ok.payload.to_bytes()))
