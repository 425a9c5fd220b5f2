"""The splatphys wire types (ipc/src/wire.rs) as ctypes structures and numpy dtypes.

Names, offsets and sizes match the Rust `#[repr(C)]` structs byte for byte; every size is
asserted at import. Each ctypes structure has `type_name()` returning the iceoryx2 type name
the Rust side registers (`splatphys::<Type>`), so services open with matching type details.
Units are SI and in the field names (see docs/reference/protocol.md).
"""

import ctypes

import numpy as np

LAYOUT_VERSION = 4
SH_COEFFS_PER_CHANNEL = 16
MAX_NAMED_OBJECTS = 64
OBJECT_NAME_BYTES = 32
OBJECT_NAME_FULL_BYTES = 64
SCENE_NAME_BYTES = 64
MAX_REPORTED_SUBSCRIBERS = 8
REPLY_MESSAGE_BYTES = 224
FAILURE_REASON_BYTES = 224
# SceneGaussian.object_id of the captured background (claimed by no object).
BACKGROUND_OBJECT_ID = 0xFFFFFFFF

STATUS_SHUTTING_DOWN = 1
STATUS_PAUSED = 2
STATUS_FINISHED = 4
STATUS_LOSSLESS_LAGGING = 8
# A step failed; the last good frame was restored and stepping paused (Status.failure_reason).
STATUS_FAILED = 16
# The server's loop made no progress for 5 s; its heartbeat thread still beats.
STATUS_STALLED = 32

# CommandLogEntry.event
LOG_EVENT_COMMAND = 0
LOG_EVENT_STEP_FAILED = 1

f32x3 = ctypes.c_float * 3
f32x4 = ctypes.c_float * 4
f64x3 = ctypes.c_double * 3


class _Wire(ctypes.Structure):
    """Base: iceoryx2 type name `splatphys::<class name>`."""

    @classmethod
    def type_name(cls) -> str:
        return "splatphys::" + cls.__name__


class FrameHeader(_Wire):
    """User header of `frame` and `objects` samples (56 B); publish_unix_ns is the wall clock."""

    _fields_ = [
        ("step", ctypes.c_uint64),
        ("time_s", ctypes.c_double),
        ("substeps", ctypes.c_uint64),
        ("frame_index", ctypes.c_uint64),
        ("count", ctypes.c_uint32),
        ("scene_generation", ctypes.c_uint32),
        ("layout_version", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("publish_unix_ns", ctypes.c_uint64),
    ]


class FrameGaussian(_Wire):
    """Dynamic state of one Gaussian (52 B): position m, covariance m² (xx,xy,xz,yy,yz,zz), R."""

    _fields_ = [
        ("position_m", f32x3),
        ("covariance_m2", ctypes.c_float * 6),
        ("rotation_wxyz", f32x4),
    ]


class SceneGaussian(_Wire):
    """Static part of one Gaussian (228 B)."""

    _fields_ = [
        ("sh", ctypes.c_float * 48),
        ("opacity", ctypes.c_float),
        ("scale_m", f32x3),
        ("rotation_wxyz", f32x4),
        ("object_id", ctypes.c_uint32),
    ]


class SceneHeader(_Wire):
    """User header of `scene` samples (2144 B)."""

    _fields_ = [
        ("scene_generation", ctypes.c_uint32),
        ("layout_version", ctypes.c_uint32),
        ("gaussian_count", ctypes.c_uint32),
        ("object_count", ctypes.c_uint32),
        ("sh_degree", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("frame_dt_s", ctypes.c_double),
        ("scene_name", ctypes.c_uint8 * SCENE_NAME_BYTES),
        ("object_names", (ctypes.c_uint8 * OBJECT_NAME_BYTES) * MAX_NAMED_OBJECTS),
    ]


class ObjectName(_Wire):
    """One object's name on the `object_names` service (64 B), UTF-8, NUL-terminated."""

    _fields_ = [("name", ctypes.c_uint8 * OBJECT_NAME_FULL_BYTES)]


class ObjectState(_Wire):
    """Per-object COM state (88 B); contact force (N) and torque (N m) of solid objects."""

    _fields_ = [
        ("id", ctypes.c_uint32),
        ("contact_count", ctypes.c_uint32),
        ("position_m", f32x3),
        ("velocity_m_s", f32x3),
        ("orientation_wxyz", f32x4),
        ("angular_velocity_rad_s", f32x3),
        ("mass_kg", ctypes.c_float),
        ("contact_force_n", f32x3),
        ("contact_torque_n_m", f32x3),
    ]


class CommandMsg(_Wire):
    """A command (184 B); see docs/reference/protocol.md for kinds, codes and field flags."""

    _fields_ = [
        ("kind", ctypes.c_uint32),
        ("object_id", ctypes.c_uint32),
        ("sequence", ctypes.c_uint64),
        ("vector", f64x3),
        ("point_m", f64x3),
        ("fields", ctypes.c_uint32),
        ("code", ctypes.c_uint32),
        ("youngs_modulus_pa", ctypes.c_double),
        ("poisson_ratio", ctypes.c_double),
        ("density_kg_m3", ctypes.c_double),
        ("restitution", ctypes.c_double),
        ("friction", ctypes.c_double),
        ("count", ctypes.c_uint64),
        ("angular_velocity_rad_s", f64x3),
        ("orientation_wxyz", ctypes.c_double * 4),
        ("layout_version", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]


class ReplyMsg(_Wire):
    """A reply (256 B); scene_generation is the generation after the command."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("effective_step", ctypes.c_uint64),
        ("accepted", ctypes.c_uint32),
        ("reject_code", ctypes.c_uint32),
        ("message", ctypes.c_uint8 * REPLY_MESSAGE_BYTES),
        ("scene_generation", ctypes.c_uint32),
        ("layout_version", ctypes.c_uint32),
    ]


class CommandLogEntry(_Wire):
    """One `command_log` entry (480 B): a command and its reply, or a step failure."""

    _fields_ = [
        ("received_step", ctypes.c_uint64),
        ("received_time_s", ctypes.c_double),
        ("effective_time_s", ctypes.c_double),
        ("event", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("log_index", ctypes.c_uint64),
        ("command", CommandMsg),
        ("reply", ReplyMsg),
    ]


class SubscriberLag(_Wire):
    """Per-subscriber statistics inside Status (32 B)."""

    _fields_ = [
        ("id_lo", ctypes.c_uint64),
        ("id_hi", ctypes.c_uint64),
        ("frames_dropped", ctypes.c_uint64),
        ("max_wait_ms", ctypes.c_float),
        ("lossless", ctypes.c_uint32),
    ]


class LosslessAck(_Wire):
    """A lossless subscriber's readiness and newest frame taken, on `lossless_ack` (32 B)."""

    _fields_ = [
        ("subscriber_id_lo", ctypes.c_uint64),
        ("subscriber_id_hi", ctypes.c_uint64),
        ("frame_index", ctypes.c_uint64),
        ("flags", ctypes.c_uint32),
        ("layout_version", ctypes.c_uint32),
    ]


class Status(_Wire):
    """Server heartbeat and statistics (600 B), 10 Hz."""

    _fields_ = [
        ("heartbeat", ctypes.c_uint64),
        ("step", ctypes.c_uint64),
        ("time_s", ctypes.c_double),
        ("frames_published", ctypes.c_uint64),
        ("steps_per_s", ctypes.c_double),
        ("substeps_per_s", ctypes.c_double),
        ("frames_dropped", ctypes.c_uint64),
        ("recorder_frames_lost", ctypes.c_uint64),
        ("commands_received", ctypes.c_uint64),
        ("commands_rejected", ctypes.c_uint64),
        ("flags", ctypes.c_uint32),
        ("scene_generation", ctypes.c_uint32),
        ("subscriber_count", ctypes.c_uint32),
        ("reported_subscribers", ctypes.c_uint32),
        ("subscribers", SubscriberLag * MAX_REPORTED_SUBSCRIBERS),
        ("progress", ctypes.c_uint64),
        ("progress_age_ms", ctypes.c_uint32),
        ("layout_version", ctypes.c_uint32),
        ("failure_step", ctypes.c_uint64),
        ("failure_reason", ctypes.c_uint8 * FAILURE_REASON_BYTES),
    ]


def _dtype(struct: type) -> np.dtype:
    """The numpy structured dtype of a ctypes structure (same names, offsets, itemsize)."""
    return np.dtype(struct)


FRAME_HEADER_DTYPE = _dtype(FrameHeader)
FRAME_GAUSSIAN_DTYPE = _dtype(FrameGaussian)
SCENE_GAUSSIAN_DTYPE = _dtype(SceneGaussian)
SCENE_HEADER_DTYPE = _dtype(SceneHeader)
OBJECT_STATE_DTYPE = _dtype(ObjectState)
COMMAND_DTYPE = _dtype(CommandMsg)
REPLY_DTYPE = _dtype(ReplyMsg)
COMMAND_LOG_DTYPE = _dtype(CommandLogEntry)
STATUS_DTYPE = _dtype(Status)
OBJECT_NAME_DTYPE = _dtype(ObjectName)

# Sizes of the Rust structs (compile-time asserted there); a mismatch here is a contract break.
RUST_SIZES = {
    FrameHeader: 56,
    FrameGaussian: 52,
    SceneGaussian: 228,
    SceneHeader: 32 + SCENE_NAME_BYTES + MAX_NAMED_OBJECTS * OBJECT_NAME_BYTES,
    ObjectName: OBJECT_NAME_FULL_BYTES,
    ObjectState: 88,
    CommandMsg: 184,
    ReplyMsg: 256,
    CommandLogEntry: 480,
    SubscriberLag: 32,
    LosslessAck: 32,
    Status: 96 + 32 * MAX_REPORTED_SUBSCRIBERS + 24 + FAILURE_REASON_BYTES,
}
for _t, _size in RUST_SIZES.items():
    assert ctypes.sizeof(_t) == _size, f"{_t.__name__}: {ctypes.sizeof(_t)} B != Rust {_size} B"
    assert np.dtype(_t).itemsize == _size, f"{_t.__name__} dtype itemsize != {_size}"
# Spot-check offsets the dtypes rely on.
assert FRAME_GAUSSIAN_DTYPE.fields["rotation_wxyz"][1] == 36
assert OBJECT_STATE_DTYPE.fields["mass_kg"][1] == 60
assert OBJECT_STATE_DTYPE.fields["contact_force_n"][1] == 64
assert SCENE_GAUSSIAN_DTYPE.fields["object_id"][1] == 224
assert STATUS_DTYPE.fields["subscribers"][1] == 96


def fixed_str(buf) -> str:
    """A NUL-padded UTF-8 byte array as a string."""
    raw = bytes(buf)
    return raw.split(b"\0", 1)[0].decode("utf-8", "replace")
