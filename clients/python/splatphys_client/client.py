"""Connect to a splatphys server: scene, frames and objects as zero-copy numpy views,
status heartbeat, commands with replies.

Samples live in the server's shared memory. A `SampleView` exposes them as numpy arrays that
point straight into that memory (no copy); call `release()` (or leave its `with` block) as soon
as you are done: iceoryx2 needs samples released explicitly, and the `frame` service lends a
subscriber only one sample at a time. Arrays must not be used after the release: copy what you
keep (`view.array.copy()`).
"""

import ctypes
import os
import time
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
import iceoryx2 as iox2

from . import wire
from .wire import (
    CommandMsg,
    FrameGaussian,
    FrameHeader,
    ObjectName,
    ObjectState,
    ReplyMsg,
    SceneGaussian,
    SceneHeader,
    Status,
)

IOX2_PREFIX_ENV = "SPLATPHYS_IOX2_PREFIX"
HEARTBEAT_TIMEOUT_S = 1.0
MAX_FRAME_BUFFER = 4


class ServerNotFound(RuntimeError):
    """No server under the prefix within the connect timeout."""


class ServerGone(RuntimeError):
    """The server's heartbeat stopped (killed or hung)."""


class ServerShutDown(RuntimeError):
    """The server shut down cleanly and everything it sent was received."""


class LayoutMismatch(RuntimeError):
    """The server speaks another wire layout version."""


class ServerStalled(RuntimeError):
    """The server beats but its loop made no progress for 5 s (STATUS_STALLED)."""


def _copy(struct_type, ptr: int):
    """A Python-owned copy of the struct at `ptr` (shared memory)."""
    out = struct_type()
    ctypes.memmove(ctypes.addressof(out), ptr, ctypes.sizeof(struct_type))
    return out


class SampleView:
    """A received sample: `header` (a copy) and `array` (a numpy view of shared memory).

    `array` has the structured dtype of the element type, e.g. `array["position_m"]` is an
    (N, 3) float32 view for frames. Valid until `release()`.
    """

    def __init__(self, sample, header_type, element_type, dtype: np.dtype):
        self._sample = sample
        self.header = _copy(header_type, sample.user_header_ptr)
        payload = sample.payload()
        # iceoryx2 0.10's Python binding reports a slice's length in bytes.
        nbytes = payload.len()
        count = getattr(self.header, "count", None)
        if count is None:
            count = getattr(self.header, "gaussian_count")
        if count * dtype.itemsize > nbytes:
            sample.delete()
            raise ValueError(
                f"{element_type.__name__}: header says {count} elements, payload has {nbytes} B"
            )
        self.address = payload.as_ptr()
        buf = (ctypes.c_uint8 * (count * dtype.itemsize)).from_address(self.address)
        self.array = np.frombuffer(buf, dtype=dtype, count=count)
        self.array.flags.writeable = False

    def release(self) -> None:
        """Gives the sample back to iceoryx2; `array` must not be used afterwards."""
        if self._sample is not None:
            self.array = None
            self._sample.delete()
            self._sample = None

    def __enter__(self) -> "SampleView":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    # Frame conveniences.
    @property
    def gaussians(self) -> np.ndarray:
        """Alias of `array` for frames and scenes."""
        return self.array

    @property
    def objects(self) -> np.ndarray:
        """Alias of `array` for objects samples."""
        return self.array


@dataclass
class Reply:
    """The server's answer to one command."""

    sequence: int
    accepted: bool
    effective_step: int
    reject_code: int
    reason: str
    # Scene generation after the command (a reset's reply names the new one).
    generation: int = 0


# Commands: each builds a CommandMsg (see docs/reference/protocol.md for the codes).
FIELD_POINT, FIELD_MODEL, FIELD_E, FIELD_NU = 1, 2, 4, 8
FIELD_DENSITY, FIELD_RESTITUTION, FIELD_FRICTION = 16, 32, 64
FIELD_ANGULAR, FIELD_AT_STEP = 128, 256
MATERIAL_MODELS = {
    "jelly": 0, "fixed-corotated": 0, "neo-hookean": 1, "snow": 2, "sand": 3,
    "metal": 4, "plasticine": 5, "foam": 6,
}
OBJECT_KINDS = {"deformable": 0, "rigid": 1, "static": 2, "kinematic": 3}


class Command:
    """Base of the command builders."""

    kind = 0

    def to_msg(self, sequence: int) -> CommandMsg:
        m = CommandMsg()
        m.kind = self.kind
        m.sequence = sequence
        m.layout_version = wire.LAYOUT_VERSION
        self.fill(m)
        return m

    def fill(self, m: CommandMsg) -> None:
        pass


@dataclass
class Impulse(Command):
    """Impulse in N·s (world) on `object_id`, at `point_m` (world m) or at the COM."""

    object_id: int
    impulse_n_s: Sequence[float]
    point_m: Optional[Sequence[float]] = None
    kind = 1

    def fill(self, m):
        m.object_id = self.object_id
        m.vector[:] = [float(x) for x in self.impulse_n_s]
        if self.point_m is not None:
            m.point_m[:] = [float(x) for x in self.point_m]
            m.fields |= FIELD_POINT


@dataclass
class SetVelocity(Command):
    """Set the COM velocity of `object_id`, m/s, and optionally its angular velocity, rad/s
    (None: unchanged). A kinematic object keeps both until its next command."""

    object_id: int
    velocity_m_s: Sequence[float]
    angular_velocity_rad_s: Optional[Sequence[float]] = None
    kind = 2

    def fill(self, m):
        m.object_id = self.object_id
        m.vector[:] = [float(x) for x in self.velocity_m_s]
        if self.angular_velocity_rad_s is not None:
            m.angular_velocity_rad_s[:] = [float(x) for x in self.angular_velocity_rad_s]
            m.fields |= FIELD_ANGULAR


@dataclass
class SetPose(Command):
    """Drive kinematic `object_id` to COM `position_m` (world m) and `orientation_wxyz`
    (relative to its rest pose), reached at the end of step `at_step` (None: of the current
    step), moving at constant velocity; it then holds still."""

    object_id: int
    position_m: Sequence[float]
    orientation_wxyz: Sequence[float] = (1.0, 0.0, 0.0, 0.0)
    at_step: Optional[int] = None
    kind = 10

    def fill(self, m):
        m.object_id = self.object_id
        m.vector[:] = [float(x) for x in self.position_m]
        m.orientation_wxyz[:] = [float(x) for x in self.orientation_wxyz]
        if self.at_step is not None:
            m.count = int(self.at_step)
            m.fields |= FIELD_AT_STEP


@dataclass
class EditMaterial(Command):
    """Edit the material of `object_id`; None keeps a value."""

    object_id: int
    model: Optional[str] = None
    youngs_modulus_pa: Optional[float] = None
    poisson_ratio: Optional[float] = None
    density_kg_m3: Optional[float] = None
    restitution: Optional[float] = None
    friction: Optional[float] = None
    kind = 3

    def fill(self, m):
        m.object_id = self.object_id
        if self.model is not None:
            m.code = MATERIAL_MODELS[self.model]
            m.fields |= FIELD_MODEL
        for flag, name in [
            (FIELD_E, "youngs_modulus_pa"), (FIELD_NU, "poisson_ratio"),
            (FIELD_DENSITY, "density_kg_m3"), (FIELD_RESTITUTION, "restitution"),
            (FIELD_FRICTION, "friction"),
        ]:
            v = getattr(self, name)
            if v is not None:
                setattr(m, name, float(v))
                m.fields |= flag


@dataclass
class SetKind(Command):
    """Make `object_id` deformable, rigid, static or kinematic."""

    object_id: int
    object_kind: str
    kind = 4

    def fill(self, m):
        m.object_id = self.object_id
        m.code = OBJECT_KINDS[self.object_kind]


class Pause(Command):
    kind = 5


class Resume(Command):
    kind = 6


@dataclass
class Step(Command):
    """While paused, advance `count` frames."""

    count: int
    kind = 7

    def fill(self, m):
        m.count = self.count


class Reset(Command):
    kind = 8


class Shutdown(Command):
    kind = 9


def iox_config():
    """The iceoryx2 config every splatphys process uses (file prefix from SPLATPHYS_IOX2_PREFIX)."""
    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    config = iox2.config.global_config()
    prefix = os.environ.get(IOX2_PREFIX_ENV)
    if prefix:
        config.global_cfg.prefix = iox2.FileName.new(prefix)
    return config


def scene_info_of(h: SceneHeader) -> dict:
    """The scene info dict of a scene header (the first 64 object names; the rest come from
    `object_names`)."""
    return {
        "scene_name": wire.fixed_str(h.scene_name),
        "generation": h.scene_generation,
        "gaussian_count": h.gaussian_count,
        "object_count": h.object_count,
        "frame_dt_s": h.frame_dt_s,
        "object_names": [
            wire.fixed_str(h.object_names[i])
            for i in range(min(h.object_count, wire.MAX_NAMED_OBJECTS))
        ],
    }


def reply_of(m: ReplyMsg) -> Reply:
    """The `Reply` of a `ReplyMsg`."""
    return Reply(
        sequence=m.sequence,
        accepted=m.accepted == 1,
        effective_step=m.effective_step,
        reject_code=m.reject_code,
        reason=wire.fixed_str(m.message),
        generation=m.scene_generation,
    )


class ClientApi:
    """What every transport's client offers on top of its own `recv_scene`, `recv_frame`,
    `poll_status`, `send`, `poll_reply` and `wait(timeout_s)`: waiting for the scene, names,
    the next frame and a command's reply."""

    _scene_info: Optional[dict] = None
    last_status: Optional[Status] = None

    def scene_info(self, timeout_s: float = 2.0) -> dict:
        """Scene name, counts, frame dt (s) and object names, waiting for the scene header."""
        deadline = time.monotonic() + timeout_s
        while self._scene_info is None:
            v = self.recv_scene()
            if v is not None:
                v.release()
                break
            self.poll_status()
            if time.monotonic() > deadline:
                raise TimeoutError(f"no scene header within {timeout_s} s")
            self.wait(0.001)
        return self._scene_info

    def object_id(self, name_or_id) -> int:
        """The id of an object given by name (from the scene header) or number."""
        if isinstance(name_or_id, int):
            return name_or_id
        names = self.scene_info()["object_names"]
        if name_or_id in names:
            return names.index(name_or_id)
        return int(str(name_or_id).lstrip("#"))

    def wait_frame(self, timeout_s: float = 1.0):
        """Waits up to `timeout_s` for the next frame."""
        deadline = time.monotonic() + timeout_s
        while True:
            f = self.recv_frame()
            if f is not None or time.monotonic() >= deadline:
                return f
            self.wait(min(0.0002, max(0.0, deadline - time.monotonic())))

    def command(self, cmd: Command, timeout_s: float = 2.0) -> Reply:
        """Sends `cmd` and waits up to `timeout_s` for its reply."""
        seq, pending = self.send(cmd)
        deadline = time.monotonic() + timeout_s
        while True:
            r = self.poll_reply(pending)
            if r is not None:
                return r
            self.poll_status()
            if time.monotonic() > deadline:
                pending.delete()
                st = self.last_status
                if st is not None and st.flags & wire.STATUS_STALLED:
                    raise ServerStalled(
                        f"server stalled: its loop made no progress for {st.progress_age_ms} ms "
                        f"(at step {st.step}); no reply to command #{seq}"
                    )
                raise TimeoutError(f"no reply to command #{seq} within {timeout_s} s")
            self.wait(0.0001)


class Client(ClientApi):
    """A connection to the server under `prefix` (e.g. `splatphys/vase`)."""

    def __init__(
        self,
        prefix: str,
        connect_timeout_s: float = 5.0,
        heartbeat_timeout_s: float = HEARTBEAT_TIMEOUT_S,
        frames: bool = True,
        objects: bool = True,
        commands: bool = True,
        frame_buffer: int = 2,
        node_name: str = "splatphys-python",
    ):
        self.prefix = prefix.rstrip("/")
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.node = (
            iox2.NodeBuilder.new()
            .name(iox2.NodeName.new(node_name))
            .config(iox_config())
            .create(iox2.ServiceType.Ipc)
        )
        start = time.monotonic()
        while True:
            try:
                self._status_service = self._pubsub("status", Status, None).open()
                break
            except iox2.PublishSubscribeOpenError:
                if time.monotonic() - start > connect_timeout_s:
                    raise ServerNotFound(
                        f"no splatphys server under prefix `{self.prefix}` after "
                        f"{connect_timeout_s:.1f} s (is `splatphys serve` running?)"
                    ) from None
                self.node.try_cleanup_dead_nodes()
                time.sleep(0.02)
        self._scene_service = self._pubsub("scene", iox2.Slice[SceneGaussian], SceneHeader).open()
        self.status_sub = self._status_service.subscriber_builder().history_request(1).create()
        self.scene_sub = self._scene_service.subscriber_builder().history_request(1).create()
        try:
            self._names_service = self._pubsub("object_names", iox2.Slice[ObjectName], FrameHeader).open()
            self.names_sub = self._names_service.subscriber_builder().history_request(1).create()
        except iox2.PublishSubscribeOpenError:
            # A server without `object_names` (a replay of an older recording): the scene
            # header names the first 64 objects.
            self.names_sub = None
        self._object_names = {}  # scene generation -> every object's name
        self.frame_sub = self.objects_sub = self.command_client = None
        if frames:
            self._frame_service = self._pubsub("frame", iox2.Slice[FrameGaussian], FrameHeader).open()
            buf = max(1, min(frame_buffer, MAX_FRAME_BUFFER))
            self.frame_sub = self._frame_service.subscriber_builder().buffer_size(buf).create()
        if objects:
            self._objects_service = self._pubsub("objects", iox2.Slice[ObjectState], FrameHeader).open()
            self.objects_sub = self._objects_service.subscriber_builder().buffer_size(4).create()
        if commands:
            self._command_service = (
                self.node.service_builder(self._name("command"))
                .request_response(CommandMsg, ReplyMsg)
                .open()
            )
            self.command_client = self._command_service.client_builder().create()
        self._last_beat = time.monotonic()
        self.last_status: Optional[Status] = None
        self.shutting_down = False
        self._sequence = 1
        self._scene_info = None

    def _name(self, leaf: str):
        return iox2.ServiceName.new(f"{self.prefix}/{leaf}")

    def _pubsub(self, leaf: str, payload, header):
        b = self.node.service_builder(self._name(leaf)).publish_subscribe(payload)
        return b.user_header(header) if header is not None else b

    def close(self) -> None:
        """Releases every port; the client cannot be used afterwards."""
        for port in ("command_client", "objects_sub", "frame_sub", "names_sub", "scene_sub", "status_sub"):
            p = getattr(self, port, None)
            if p is not None:
                p.delete()
                setattr(self, port, None)

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def wait(self, timeout_s: float) -> None:
        """Waits up to `timeout_s` (iceoryx2's node wait; a signal ends it early)."""
        self.node.wait(iox2.Duration.from_micros(max(0, int(timeout_s * 1e6))))

    # Status and heartbeat.
    def poll_status(self) -> Optional[Status]:
        """Drains `status`; raises ServerGone after `heartbeat_timeout_s` of silence."""
        while True:
            s = self.status_sub.receive()
            if s is None:
                break
            st = _copy(Status, s.payload_ptr)
            s.delete()
            self._last_beat = time.monotonic()
            self.shutting_down |= bool(st.flags & wire.STATUS_SHUTTING_DOWN)
            self.last_status = st
        silent = time.monotonic() - self._last_beat
        if not self.shutting_down and silent > self.heartbeat_timeout_s:
            self.node.try_cleanup_dead_nodes()
            raise ServerGone(
                f"splatphys server under `{self.prefix}` is gone: no heartbeat for "
                f"{silent * 1e3:.0f} ms"
            )
        return self.last_status

    # Scene.
    def recv_scene(self) -> Optional[SampleView]:
        """The next scene sample (once per generation; the first comes from history)."""
        s = self.scene_sub.receive()
        if s is None:
            return None
        view = SampleView(s, SceneHeader, SceneGaussian, wire.SCENE_GAUSSIAN_DTYPE)
        if view.header.layout_version != wire.LAYOUT_VERSION:
            view.release()
            raise LayoutMismatch(f"server layout {view.header.layout_version}, client {wire.LAYOUT_VERSION}")
        self._scene_info = scene_info_of(view.header)
        self._take_object_names()
        return view

    def _take_object_names(self, timeout_s: float = 0.5) -> None:
        """Every object's name from `object_names` into the scene info (the scene header holds
        only the first 64). The server publishes them right after the scene; waits up to
        `timeout_s` for those of the scene's generation."""
        if self.names_sub is None or self._scene_info is None:
            return
        info = self._scene_info
        deadline = time.monotonic() + timeout_s
        while True:
            s = self.names_sub.receive()
            if s is not None:
                with SampleView(s, FrameHeader, ObjectName, wire.OBJECT_NAME_DTYPE) as v:
                    names = [wire.fixed_str(n) for n in v.array["name"]]
                    self._object_names[v.header.scene_generation] = names
                continue
            names = self._object_names.get(info["generation"])
            if names is not None and len(names) == info["object_count"]:
                info["object_names"] = list(names)
                return
            if info["object_count"] <= wire.MAX_NAMED_OBJECTS or time.monotonic() > deadline:
                return
            time.sleep(0.001)

    # Frames and objects.
    def _recv(self, sub, element_type, dtype) -> Optional[SampleView]:
        self.poll_status()
        if sub is None:
            return None
        s = sub.receive()
        if s is None:
            if self.shutting_down:
                raise ServerShutDown(f"splatphys server under `{self.prefix}` shut down")
            return None
        view = SampleView(s, FrameHeader, element_type, dtype)
        if view.header.layout_version != wire.LAYOUT_VERSION:
            view.release()
            raise LayoutMismatch(f"server layout {view.header.layout_version}, client {wire.LAYOUT_VERSION}")
        return view

    def recv_frame(self) -> Optional[SampleView]:
        """The oldest buffered frame, or None. Release it before receiving the next."""
        return self._recv(self.frame_sub, FrameGaussian, wire.FRAME_GAUSSIAN_DTYPE)

    def latest_frame(self) -> Optional[SampleView]:
        """The newest buffered frame (older ones are released), or None."""
        newest = self.recv_frame()
        while newest is not None and self.frame_sub.has_samples():
            newest.release()
            newest = self.recv_frame()
        return newest

    def recv_objects(self) -> Optional[SampleView]:
        """The oldest buffered objects sample, or None."""
        return self._recv(self.objects_sub, ObjectState, wire.OBJECT_STATE_DTYPE)

    # Commands.
    def send(self, cmd: Command):
        """Sends without waiting; returns (sequence, pending) for `poll_reply`."""
        seq = self._sequence
        self._sequence += 1
        return seq, self.command_client.send_copy(cmd.to_msg(seq))

    @staticmethod
    def poll_reply(pending) -> Optional[Reply]:
        """The reply to a pending command if it arrived (the pending handle is released then)."""
        r = pending.receive()
        if r is None:
            return None
        m = _copy(ReplyMsg, r.payload_ptr)
        r.delete()
        pending.delete()
        return reply_of(m)
