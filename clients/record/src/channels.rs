//! MCAP topics and schemas of a splatphys recording (documented in docs/reference/protocol.md).
//!
//! Raw channels carry the wire PODs unchanged, message encoding [`POD_ENCODING`]:
//! each message is the header struct's bytes followed by the payload slice's bytes
//! (little endian, layouts of `splatphys_ipc::wire`, version in the schema name).
//! `/pointcloud` is a `foxglove.PointCloud` in JSON so Foxglove shows the run.

/// Message encoding of the raw channels.
pub const POD_ENCODING: &str = "splatphys-pod";
/// Schema encoding of the raw channels (the schema data is a text description).
pub const POD_SCHEMA_ENCODING: &str = "splatphys-layout";

/// `/scene`: `SceneHeader` (2144 B) + `[N] SceneGaussian` (228 B each); once per generation.
pub const SCENE: &str = "/scene";
/// `/object_names`: `FrameHeader` (56 B) + `[M] ObjectName` (64 B each); once per generation.
pub const OBJECT_NAMES: &str = "/object_names";
/// `/frame`: `FrameHeader` (56 B) + `[N] FrameGaussian` (52 B each); every frame.
pub const FRAME: &str = "/frame";
/// `/objects`: `FrameHeader` (56 B) + `[M] ObjectState` (88 B each); every frame.
pub const OBJECTS: &str = "/objects";
/// `/status`: `Status` (600 B); about 10 Hz.
pub const STATUS: &str = "/status";
/// `/commands`: `CommandLogEntry` (480 B); every command any client sent, with its reply.
pub const COMMANDS: &str = "/commands";
/// `/pointcloud`: `foxglove.PointCloud` (JSON): positions and colours.
pub const POINTCLOUD: &str = "/pointcloud";

/// (topic, schema name, schema text) of the raw channels.
pub const RAW_CHANNELS: [(&str, &str, &str); 6] = [
    (
        SCENE,
        "splatphys.Scene.v3",
        "SceneHeader{u32 scene_generation,u32 layout_version,u32 gaussian_count,u32 object_count,u32 sh_degree,u32 reserved,f64 frame_dt_s,u8[64] scene_name,u8[64][32] object_names} + SceneGaussian[N]{f32[48] sh,f32 opacity,f32[3] scale_m,f32[4] rotation_wxyz,u32 object_id}",
    ),
    (
        OBJECT_NAMES,
        "splatphys.ObjectNames.v3",
        "FrameHeader + ObjectName[M]{u8[64] name} (UTF-8, NUL-terminated, index = object id)",
    ),
    (
        FRAME,
        "splatphys.Frame.v3",
        "FrameHeader{u64 step,f64 time_s,u64 substeps,u64 frame_index,u32 count,u32 scene_generation,u32 layout_version,u32 reserved,u64 publish_unix_ns} + FrameGaussian[N]{f32[3] position_m,f32[6] covariance_m2 (xx,xy,xz,yy,yz,zz),f32[4] rotation_wxyz}",
    ),
    (
        OBJECTS,
        "splatphys.Objects.v3",
        "FrameHeader + ObjectState[M]{u32 id,u32 contact_count,f32[3] position_m,f32[3] velocity_m_s,f32[4] orientation_wxyz,f32[3] angular_velocity_rad_s,f32 mass_kg,f32[3] contact_force_n,f32[3] contact_torque_n_m}",
    ),
    (
        STATUS,
        "splatphys.Status.v3",
        "Status (see splatphys_ipc::wire::Status; layout version 3)",
    ),
    (
        COMMANDS,
        "splatphys.CommandLogEntry.v3",
        "CommandLogEntry (see splatphys_ipc::wire::CommandLogEntry; layout version 3, little-endian)",
    ),
];

/// JSON schema of `foxglove.PointCloud` (the subset we write).
pub const POINTCLOUD_SCHEMA: &str = r#"{"title":"foxglove.PointCloud","type":"object","properties":{"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"frame_id":{"type":"string"},"pose":{"type":"object"},"point_stride":{"type":"integer"},"fields":{"type":"array"},"data":{"type":"string","contentEncoding":"base64"}}}"#;
