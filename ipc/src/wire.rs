//! The wire contract: every type that crosses process boundaries over iceoryx2.
//!
//! All types are `#[repr(C)]` plain old data (bytemuck [`Pod`], iceoryx2 [`ZeroCopySend`]),
//! built from arrays of `f32`/`f64`/integers only (no glam types), with sizes checked at compile
//! time. Python and C clients map these layouts byte for byte; see `docs/reference/protocol.md`.
//! Every type carries an explicit iceoryx2 type name (`splatphys::<Type>`) so that clients in
//! other languages can open the services.
//!
//! Units are SI and stated in field names: metres (`_m`), seconds (`_s`), kilograms (`_kg`),
//! pascals (`_pa`). The world frame is right-handed and z up.
//!
//! Commands and replies travel as fixed-size PODs ([`CommandMsg`], [`ReplyMsg`]); the typed
//! Rust views are [`crate::command::Command`] and [`crate::command::Reply`].

use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::ZeroCopySend;

/// Version of the byte layout of every type in this module. Bumped on any change.
pub const LAYOUT_VERSION: u32 = 4;

/// Maximum SH degree carried on the wire (degree 3: 16 coefficients per colour channel).
pub const MAX_SH_DEGREE: u32 = 3;
/// SH coefficients per channel at [`MAX_SH_DEGREE`].
pub const SH_COEFFS_PER_CHANNEL: usize = 16;
/// Objects whose names fit into [`SceneHeader::object_names`] (every object's name is on the
/// `object_names` service as [`ObjectName`]s).
pub const MAX_NAMED_OBJECTS: usize = 64;
/// Bytes of one name in [`ObjectName`] (UTF-8, NUL padded, cut at a character boundary).
pub const OBJECT_NAME_FULL_BYTES: usize = 64;
/// Bytes per object name (UTF-8, NUL padded, always NUL-terminated: at most 31 bytes of text).
pub const OBJECT_NAME_BYTES: usize = 32;
/// Bytes of the scene name in [`SceneHeader::scene_name`].
pub const SCENE_NAME_BYTES: usize = 64;
/// Subscribers reported individually in [`Status::subscribers`].
pub const MAX_REPORTED_SUBSCRIBERS: usize = 8;
/// Bytes of the human-readable reason in [`ReplyMsg::message`].
pub const REPLY_MESSAGE_BYTES: usize = 224;

/// [`SceneGaussian::object_id`] of background Gaussians: claimed by no object, static.
pub const BACKGROUND_OBJECT_ID: u32 = u32::MAX;

/// User header of every `frame` and `objects` sample.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::FrameHeader")]
pub struct FrameHeader {
    /// Simulation step index after the step that produced this frame (0 = initial state).
    pub step: u64,
    /// Simulated time at this frame, seconds.
    pub time_s: f64,
    /// Substeps done since the start (or the last reset).
    pub substeps: u64,
    /// Frames published since the server started; consecutive frames differ by exactly 1.
    pub frame_index: u64,
    /// Elements in the payload slice (Gaussians for `frame`, objects for `objects`).
    pub count: u32,
    /// Scene generation; bumped on reset or on edits that change the Gaussian count.
    pub scene_generation: u32,
    /// [`LAYOUT_VERSION`] of the publisher.
    pub layout_version: u32,
    /// Reserved, zero.
    pub reserved: u32,
    /// Wall-clock time at which the server sent this sample, nanoseconds since the Unix epoch
    /// (for publish-to-draw latency; compare only on the same host).
    pub publish_unix_ns: u64,
}
const _: () = assert!(size_of::<FrameHeader>() == 56);

/// Dynamic state of one published Gaussian. `frame` payload: `[N]` of these, 52 bytes each,
/// in the order of the `scene` payload of the same generation.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::FrameGaussian")]
pub struct FrameGaussian {
    /// Centre in world metres.
    pub position_m: [f32; 3],
    /// World covariance Σ = Fe Σ0 Feᵀ, upper triangle (xx, xy, xz, yy, yz, zz), m².
    pub covariance_m2: [f32; 6],
    /// Rotation R of the polar decomposition of Fe (w, x, y, z); rotates SH view directions.
    pub rotation_wxyz: [f32; 4],
}
const _: () = assert!(size_of::<FrameGaussian>() == 52);

/// Static part of one published Gaussian. `scene` payload: `[N]` of these, 228 bytes each.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::SceneGaussian")]
pub struct SceneGaussian {
    /// SH coefficients `[16][3]` (coefficient-major, RGB inner), DC first, unused entries zero.
    pub sh: [f32; 48],
    /// Opacity in 0..1 (already through the sigmoid).
    pub opacity: f32,
    /// Initial scales (standard deviations) along the local axes, metres.
    pub scale_m: [f32; 3],
    /// Initial rotation (w, x, y, z), normalised.
    pub rotation_wxyz: [f32; 4],
    /// Object this Gaussian belongs to (index into the objects of the scene), or
    /// [`BACKGROUND_OBJECT_ID`] for the captured background that no object claims.
    pub object_id: u32,
}
const _: () = assert!(size_of::<SceneGaussian>() == 228);

impl Default for SceneGaussian {
    fn default() -> Self {
        Self {
            sh: [0.0; 48],
            opacity: 1.0,
            scale_m: [0.01; 3],
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            object_id: 0,
        }
    }
}

/// User header of every `scene` sample.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::SceneHeader")]
pub struct SceneHeader {
    /// Scene generation this static data belongs to.
    pub scene_generation: u32,
    /// [`LAYOUT_VERSION`] of the publisher.
    pub layout_version: u32,
    /// Gaussians in the payload (equals the `frame` count of this generation).
    pub gaussian_count: u32,
    /// Objects in the scene (equals the `objects` count).
    pub object_count: u32,
    /// SH degree actually used (0..=3); higher coefficients are zero.
    pub sh_degree: u32,
    /// Reserved, zero.
    pub reserved: u32,
    /// Fixed simulated time between published frames, seconds.
    pub frame_dt_s: f64,
    /// Scene name, UTF-8, NUL padded.
    pub scene_name: [u8; SCENE_NAME_BYTES],
    /// Names of objects `0..min(object_count, 64)`, UTF-8, NUL padded.
    pub object_names: [[u8; OBJECT_NAME_BYTES]; MAX_NAMED_OBJECTS],
}
const _: () = assert!(size_of::<SceneHeader>() == 32 + SCENE_NAME_BYTES + 64 * 32);

impl Default for SceneHeader {
    fn default() -> Self {
        Zeroable::zeroed()
    }
}

/// One object's name. `object_names` payload: `[M]` of these, indexed by object id, one for
/// every object, published with the scene (once per generation) under a [`FrameHeader`] whose
/// `count` is M. 64 bytes each.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::ObjectName")]
pub struct ObjectName {
    /// UTF-8, NUL padded.
    pub name: [u8; OBJECT_NAME_FULL_BYTES],
}
const _: () = assert!(size_of::<ObjectName>() == OBJECT_NAME_FULL_BYTES);

impl ObjectName {
    /// `name`, cut at a character boundary to fit.
    pub fn new(name: &str) -> Self {
        let mut n = Self::zeroed();
        write_fixed_str(&mut n.name, name);
        n
    }

    /// The name as text.
    pub fn text(&self) -> String {
        read_fixed_str(&self.name)
    }
}

/// Per-object state, `objects` payload: `[M]` of these, 64 bytes each.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::ObjectState")]
pub struct ObjectState {
    /// Object id (index into the scene's objects).
    pub id: u32,
    /// Contacts resolved for this object in the last step.
    pub contact_count: u32,
    /// Centre of mass, world metres.
    pub position_m: [f32; 3],
    /// Centre-of-mass velocity, m/s.
    pub velocity_m_s: [f32; 3],
    /// Orientation (w, x, y, z) relative to the rest pose.
    pub orientation_wxyz: [f32; 4],
    /// Angular velocity, rad/s, world frame.
    pub angular_velocity_rad_s: [f32; 3],
    /// Mass, kilograms.
    pub mass_kg: f32,
    /// Contact force on a rigid, static or kinematic object, averaged over the last step: the
    /// impulses it received (contacts, deformable objects' grids) over the step's time, newtons,
    /// world frame. Zero for deformable objects.
    pub contact_force_n: [f32; 3],
    /// The moment of those impulses about its centre of mass over the step's time, N·m.
    pub contact_torque_n_m: [f32; 3],
}
const _: () = assert!(size_of::<ObjectState>() == 88);

/// Wire form of a command (see [`crate::command::Command`] for the typed view).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::CommandMsg")]
pub struct CommandMsg {
    /// A [`crate::command::CommandKind`] code.
    pub kind: u32,
    /// Target object id (impulse, set velocity, edit material, set kind).
    pub object_id: u32,
    /// Client-chosen sequence number, echoed in the reply.
    pub sequence: u64,
    /// Impulse (N·s), velocity (m/s) or pose position (m, centre of mass), world frame.
    pub vector: [f64; 3],
    /// Point of application of an impulse, world metres (valid when `FIELD_POINT` is set).
    pub point_m: [f64; 3],
    /// Bit set of `FIELD_*` flags saying which optional fields are present.
    pub fields: u32,
    /// Material model code (edit material) or object kind code (set kind).
    pub code: u32,
    /// Young's modulus E, pascals.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio nu, dimensionless.
    pub poisson_ratio: f64,
    /// Density, kg/m³.
    pub density_kg_m3: f64,
    /// Coefficient of restitution e, 0..1.
    pub restitution: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Step count for `Step`, or the step at whose end a pose is reached (`SetPose`, valid
    /// when `FIELD_AT_STEP` is set).
    pub count: u64,
    /// Angular velocity, rad/s, world frame (`SetVelocity`, valid when `FIELD_ANGULAR` is set).
    pub angular_velocity_rad_s: [f64; 3],
    /// Orientation (w, x, y, z) relative to the rest pose (`SetPose`).
    pub orientation_wxyz: [f64; 4],
    /// [`LAYOUT_VERSION`] of the sender; the server rejects another version as malformed.
    pub layout_version: u32,
    /// Reserved, zero.
    pub reserved: u32,
}
const _: () = assert!(size_of::<CommandMsg>() == 184);

/// Wire form of a reply (see [`crate::command::Reply`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::ReplyMsg")]
pub struct ReplyMsg {
    /// Sequence number of the command this answers.
    pub sequence: u64,
    /// Step at which an accepted command takes effect.
    pub effective_step: u64,
    /// 1 accepted, 0 rejected.
    pub accepted: u32,
    /// A [`crate::command::RejectCode`] code when rejected, 0 otherwise.
    pub reject_code: u32,
    /// Human-readable reason, UTF-8, NUL padded, always NUL-terminated.
    pub message: [u8; REPLY_MESSAGE_BYTES],
    /// Scene generation after the command (a reset's reply names the new one).
    pub scene_generation: u32,
    /// [`LAYOUT_VERSION`] of the server.
    pub layout_version: u32,
}
const _: () = assert!(size_of::<ReplyMsg>() == 256);

impl Default for ReplyMsg {
    fn default() -> Self {
        Zeroable::zeroed()
    }
}

/// [`CommandLogEntry::event`]: a command and the reply it got.
pub const LOG_EVENT_COMMAND: u32 = 0;
/// [`CommandLogEntry::event`]: a step failed; the server restored the last good frame and
/// paused. `reply.message` holds the reason, `received_step` the restored step, and `command`
/// is zero.
pub const LOG_EVENT_STEP_FAILED: u32 = 1;

/// One entry of the `command_log` service: every command the server received, with its reply,
/// so a recorder captures the commands of every client; and every step failure.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::CommandLogEntry")]
pub struct CommandLogEntry {
    /// Step at which the server received it (it was applied before the next step).
    pub received_step: u64,
    /// Simulated time when it was received, seconds.
    pub received_time_s: f64,
    /// Simulated time at which an accepted command takes effect (the start of
    /// `reply.effective_step`), seconds.
    pub effective_time_s: f64,
    /// `LOG_EVENT_*`.
    pub event: u32,
    /// Reserved, zero.
    pub reserved: u32,
    /// Entries the server logged before this one: consecutive entries differ by exactly 1, so a
    /// subscriber counts what the log's overflow overwrote (it keeps 256 unread entries).
    pub log_index: u64,
    /// The command as received.
    pub command: CommandMsg,
    /// The reply sent.
    pub reply: ReplyMsg,
}
const _: () = assert!(size_of::<CommandLogEntry>() == 480);

/// Statistics of one subscriber of the `frame` service as seen by the server.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::SubscriberLag")]
pub struct SubscriberLag {
    /// Low 64 bits of the iceoryx2 subscriber id.
    pub id_lo: u64,
    /// High 64 bits of the iceoryx2 subscriber id.
    pub id_hi: u64,
    /// Frames this subscriber did not get (full buffer; for a lossless one: after the limit).
    pub frames_dropped: u64,
    /// Longest time the server waited on it in the last status period, milliseconds.
    pub max_wait_ms: f32,
    /// 1 when it asked for lossless delivery.
    pub lossless: u32,
}
const _: () = assert!(size_of::<SubscriberLag>() == 32);

/// [`LosslessAck::flags`]: every port of this lossless subscriber is connected (`frame`,
/// `objects`, `scene`, `object_names`, `command_log`) and it holds the current scene: the server
/// may publish the first frame.
pub const ACK_READY: u32 = 1;
/// [`LosslessAck::flags`]: [`LosslessAck::frame_index`] is valid.
pub const ACK_TOOK_FRAME: u32 = 2;

/// What a lossless subscriber (a recorder) tells the server on `lossless_ack`: that it is ready
/// before the first frame, and the newest frame it has taken (written) so far. The server waits
/// for the first before stepping and for the second to reach its last frame before it shuts
/// down (see `docs/reference/protocol.md`, "The lossless contract").
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::LosslessAck")]
pub struct LosslessAck {
    /// Low 64 bits of the iceoryx2 id of the sender's `frame` subscriber port.
    pub subscriber_id_lo: u64,
    /// High 64 bits of that id.
    pub subscriber_id_hi: u64,
    /// [`FrameHeader::frame_index`] of the newest frame whose frame and objects the sender has
    /// taken (valid with [`ACK_TOOK_FRAME`]).
    pub frame_index: u64,
    /// `ACK_*` flags.
    pub flags: u32,
    /// [`LAYOUT_VERSION`] of the sender.
    pub layout_version: u32,
}
const _: () = assert!(size_of::<LosslessAck>() == 32);

impl LosslessAck {
    /// The sender's `frame` subscriber id as one number.
    pub fn subscriber_id(&self) -> u128 {
        u128::from(self.subscriber_id_lo) | (u128::from(self.subscriber_id_hi) << 64)
    }
}

/// [`Status::flags`]: the server is shutting down; this is its last status.
pub const STATUS_SHUTTING_DOWN: u32 = 1;
/// [`Status::flags`]: stepping is paused.
pub const STATUS_PAUSED: u32 = 2;
/// [`Status::flags`]: the simulation reached its end.
pub const STATUS_FINISHED: u32 = 4;
/// [`Status::flags`]: a lossless subscriber is lagging (hit the backpressure limit recently).
pub const STATUS_LOSSLESS_LAGGING: u32 = 8;
/// [`Status::flags`]: a step failed; the last good frame was restored and stepping paused
/// (see [`Status::failure_reason`]). Cleared by `resume`, `step` or `reset`.
pub const STATUS_FAILED: u32 = 16;
/// [`Status::flags`]: the main loop has made no progress (no loop iteration, no substep) for
/// longer than [`crate::services::STALL_THRESHOLD`]; the heartbeat thread still beats.
pub const STATUS_STALLED: u32 = 32;
/// Bytes of [`Status::failure_reason`].
pub const FAILURE_REASON_BYTES: usize = 224;

/// Server heartbeat and statistics, published on `status` at [`crate::services::STATUS_PERIOD`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable, ZeroCopySend)]
#[type_name("splatphys::Status")]
pub struct Status {
    /// Increments by one per status message.
    pub heartbeat: u64,
    /// Current step.
    pub step: u64,
    /// Current simulated time, seconds.
    pub time_s: f64,
    /// Frames published so far.
    pub frames_published: u64,
    /// Steps per wall-clock second over the last period.
    pub steps_per_s: f64,
    /// Substeps per wall-clock second over the last period.
    pub substeps_per_s: f64,
    /// Frames skipped by best-effort subscribers (their buffer was full), total.
    pub frames_dropped: u64,
    /// Frames lossless subscribers (recorders) lost after the backpressure limit, total.
    pub recorder_frames_lost: u64,
    /// Commands received so far.
    pub commands_received: u64,
    /// Commands rejected so far.
    pub commands_rejected: u64,
    /// `STATUS_*` flags.
    pub flags: u32,
    /// Current scene generation.
    pub scene_generation: u32,
    /// Connected `frame` subscribers.
    pub subscriber_count: u32,
    /// Valid entries in `subscribers`.
    pub reported_subscribers: u32,
    /// Per-subscriber statistics, first `reported_subscribers` valid.
    pub subscribers: [SubscriberLag; MAX_REPORTED_SUBSCRIBERS],
    /// Main-loop progress: counts loop iterations and substeps; it moves at least once per
    /// substep while the server steps and about once a millisecond while it idles.
    pub progress: u64,
    /// Milliseconds since `progress` last moved, as seen by the heartbeat thread.
    pub progress_age_ms: u32,
    /// [`LAYOUT_VERSION`] of the server.
    pub layout_version: u32,
    /// Step that was restored after the last failure (valid with [`STATUS_FAILED`]).
    pub failure_step: u64,
    /// Why the last step failed, UTF-8, NUL-terminated (valid with [`STATUS_FAILED`]).
    pub failure_reason: [u8; FAILURE_REASON_BYTES],
}
const _: () =
    assert!(size_of::<Status>() == 96 + 32 * MAX_REPORTED_SUBSCRIBERS + 24 + FAILURE_REASON_BYTES);

impl Default for Status {
    fn default() -> Self {
        Self {
            layout_version: LAYOUT_VERSION,
            ..Zeroable::zeroed()
        }
    }
}

/// Writes `s` into a NUL-padded fixed buffer, truncating at a UTF-8 boundary so that at least
/// one NUL terminates it (C clients can read it as a C string).
pub fn write_fixed_str(dst: &mut [u8], s: &str) {
    dst.fill(0);
    let mut end = s.len().min(dst.len().saturating_sub(1));
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    dst[..end].copy_from_slice(&s.as_bytes()[..end]);
}

/// Reads a NUL-padded fixed buffer as a string (invalid UTF-8 replaced).
pub fn read_fixed_str(src: &[u8]) -> String {
    let end = src.iter().position(|&b| b == 0).unwrap_or(src.len());
    String::from_utf8_lossy(&src[..end]).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_strings_round_trip_and_truncate_on_char_boundary() {
        let mut buf = [0u8; 5];
        write_fixed_str(&mut buf, "ab");
        assert_eq!(read_fixed_str(&buf), "ab");
        write_fixed_str(&mut buf, "abcd"); // 4 bytes of text + the NUL
        assert_eq!(read_fixed_str(&buf), "abcd");
        assert_eq!(buf[4], 0);
        write_fixed_str(&mut buf, "abcdef");
        assert_eq!(read_fixed_str(&buf), "abcd");
        write_fixed_str(&mut buf, "abcé"); // 'é' is 2 bytes and does not fit before the NUL
        assert_eq!(read_fixed_str(&buf), "abc");
    }

    #[test]
    fn frame_gaussian_is_13_floats_without_padding() {
        let g = FrameGaussian {
            position_m: [1.0, 2.0, 3.0],
            ..Default::default()
        };
        let floats: &[f32] = bytemuck::cast_slice(std::slice::from_ref(&g));
        assert_eq!(floats.len(), 13);
        assert_eq!(&floats[..3], &[1.0, 2.0, 3.0]);
    }
}
