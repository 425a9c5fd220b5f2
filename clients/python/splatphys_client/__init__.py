"""splatphys_client: subscribe to a splatphys server from Python.

Frames, the scene and objects arrive as numpy structured arrays that view the iceoryx2 shared
memory without copying; commands go out with replies; a dead server is noticed through the
status heartbeat (1 s). `ZenohClient` offers the same API through `splatphys-zenoh`, for a server
on another machine. See docs/reference/protocol.md for the wire contract.

    from splatphys_client import Client, Impulse
    with Client("splatphys/vase") as c:
        with c.wait_frame(timeout_s=1.0) as f:
            print(f.header.step, f.gaussians["position_m"].mean(axis=0))
        print(c.command(Impulse(object_id=0, impulse_n_s=(0, 0, 2))))
"""

from .wire import (
    COMMAND_DTYPE,
    COMMAND_LOG_DTYPE,
    FRAME_GAUSSIAN_DTYPE,
    FRAME_HEADER_DTYPE,
    LAYOUT_VERSION,
    OBJECT_STATE_DTYPE,
    SCENE_GAUSSIAN_DTYPE,
    STATUS_DTYPE,
    CommandLogEntry,
    CommandMsg,
    FrameGaussian,
    FrameHeader,
    ObjectState,
    ReplyMsg,
    SceneGaussian,
    SceneHeader,
    Status,
)
from .client import (
    Client,
    Command,
    EditMaterial,
    Impulse,
    LayoutMismatch,
    Pause,
    Reply,
    Reset,
    Resume,
    SampleView,
    ServerGone,
    ServerNotFound,
    ServerShutDown,
    ServerStalled,
    SetKind,
    SetPose,
    SetVelocity,
    Shutdown,
    Step,
)
from .zenoh_client import BytesView, CommandRefused, ZenohClient

__all__ = [
    "COMMAND_DTYPE",
    "COMMAND_LOG_DTYPE",
    "FRAME_GAUSSIAN_DTYPE",
    "FRAME_HEADER_DTYPE",
    "LAYOUT_VERSION",
    "OBJECT_STATE_DTYPE",
    "SCENE_GAUSSIAN_DTYPE",
    "STATUS_DTYPE",
    "BytesView",
    "Client",
    "CommandRefused",
    "Command",
    "CommandLogEntry",
    "CommandMsg",
    "EditMaterial",
    "FrameGaussian",
    "FrameHeader",
    "Impulse",
    "LayoutMismatch",
    "ObjectState",
    "Pause",
    "Reply",
    "ReplyMsg",
    "Reset",
    "Resume",
    "SampleView",
    "SceneGaussian",
    "SceneHeader",
    "ServerGone",
    "ServerNotFound",
    "ServerShutDown",
    "ServerStalled",
    "SetKind",
    "SetPose",
    "SetVelocity",
    "Shutdown",
    "Status",
    "Step",
    "ZenohClient",
]
