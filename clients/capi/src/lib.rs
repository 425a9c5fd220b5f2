//! splatphys-capi: the splatphys client as a C library (`libsplatphys_client.so` / `.a`, header
//! `clients/c/splatphys_client.h`, which includes the wire header `clients/c/splatphys.h`; a
//! header-only C++ wrapper is `clients/c/splatphys_client.hpp`).
//!
//! A [`splatphys_Client`] is one connection to a server under a prefix. Frames are borrowed
//! zero-copy: [`splatphys_wait_frame`] hands out pointers into the shared-memory sample, valid
//! until [`splatphys_release_frame`], the next wait, or [`splatphys_disconnect`]; a client holds
//! at most one frame, and the frame path allocates nothing. Objects and status are copied into
//! caller-owned memory. Commands are the wire's `splatphys_CommandMsg`, checked here before
//! they are sent, answered with the server's `splatphys_ReplyMsg`.
//!
//! Every function returns a [`splatphys_Result`] code; after a failure
//! [`splatphys_last_error`] describes it (per thread). A client is used from one thread at a
//! time. No function unwinds into C: a panic becomes [`splatphys_Result::SPLATPHYS_ERR_INTERNAL`].

#![allow(non_camel_case_types)]

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Duration;

use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection, FrameSample};
use splatphys_ipc::command::{Reply, decode};
use splatphys_ipc::wire::{
    CommandMsg, FrameGaussian, FrameHeader, LAYOUT_VERSION, ObjectState, ReplyMsg, SceneHeader,
    Status,
};

/// What a call did. Zero is success; positive values are outcomes a loop expects (a timeout);
/// negative values are errors, described by [`splatphys_last_error`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum splatphys_Result {
    /// Done.
    SPLATPHYS_OK = 0,
    /// Nothing arrived within the timeout (no frame yet, no reply yet).
    SPLATPHYS_TIMEOUT = 1,
    /// The server answered a command with a rejection (the reply says why).
    SPLATPHYS_REJECTED = 2,
    /// A pointer was null, a string not UTF-8, a number out of range, a command malformed.
    SPLATPHYS_ERR_INVALID_ARGUMENT = -1,
    /// No server under the prefix within the connect timeout.
    SPLATPHYS_ERR_NOT_FOUND = -2,
    /// The server stopped sending heartbeats (killed or hung).
    SPLATPHYS_ERR_SERVER_GONE = -3,
    /// The server shut down cleanly and every frame was received.
    SPLATPHYS_ERR_SHUT_DOWN = -4,
    /// SIGINT or SIGTERM arrived while waiting.
    SPLATPHYS_ERR_INTERRUPTED = -5,
    /// The shared-memory transport failed (see the message).
    SPLATPHYS_ERR_IPC = -6,
    /// A caller's buffer is too small (the count needed is written where the call says).
    SPLATPHYS_ERR_BUFFER_TOO_SMALL = -7,
    /// No object has that name.
    SPLATPHYS_ERR_NO_SUCH_OBJECT = -8,
    /// A bug in the library (a panic was caught); the message says where.
    SPLATPHYS_ERR_INTERNAL = -99,
}
use splatphys_Result as R;

/// `splatphys_CommandMsg::kind`: what a command does (the values of the wire's command kinds;
/// `docs/reference/protocol.md` lists each one's fields).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum splatphys_CommandKind {
    /// Add `vector` (N s) to `object_id` (at `point_m` when `fields` has
    /// `SPLATPHYS_FIELD_POINT`).
    SPLATPHYS_COMMAND_IMPULSE = 1,
    /// Set `object_id`'s velocity to `vector` (m/s; angular with `SPLATPHYS_FIELD_ANGULAR`).
    SPLATPHYS_COMMAND_SET_VELOCITY = 2,
    /// Edit `object_id`'s material (the `SPLATPHYS_FIELD_*` bits say which values).
    SPLATPHYS_COMMAND_EDIT_MATERIAL = 3,
    /// Switch `object_id`'s kind (`code`).
    SPLATPHYS_COMMAND_SET_KIND = 4,
    /// Pause the simulation.
    SPLATPHYS_COMMAND_PAUSE = 5,
    /// Resume it.
    SPLATPHYS_COMMAND_RESUME = 6,
    /// Advance `count` steps while paused.
    SPLATPHYS_COMMAND_STEP = 7,
    /// Back to the start.
    SPLATPHYS_COMMAND_RESET = 8,
    /// Stop the server.
    SPLATPHYS_COMMAND_SHUTDOWN = 9,
    /// Drive a kinematic object to `point_m` and `orientation_wxyz`.
    SPLATPHYS_COMMAND_SET_POSE = 10,
}

/// `splatphys_CommandMsg::fields`: `point_m` is present.
pub const SPLATPHYS_FIELD_POINT: u32 = 1;
/// `fields`: `code` (material model) is present.
pub const SPLATPHYS_FIELD_MODEL: u32 = 2;
/// `fields`: `youngs_modulus_pa` is present.
pub const SPLATPHYS_FIELD_E: u32 = 4;
/// `fields`: `poisson_ratio` is present.
pub const SPLATPHYS_FIELD_NU: u32 = 8;
/// `fields`: `density_kg_m3` is present.
pub const SPLATPHYS_FIELD_DENSITY: u32 = 16;
/// `fields`: `restitution` is present.
pub const SPLATPHYS_FIELD_RESTITUTION: u32 = 32;
/// `fields`: `friction` is present.
pub const SPLATPHYS_FIELD_FRICTION: u32 = 64;
/// `fields`: `angular_velocity_rad_s` is present.
pub const SPLATPHYS_FIELD_ANGULAR: u32 = 128;
/// `fields`: `count` is a pose's `at_step`.
pub const SPLATPHYS_FIELD_AT_STEP: u32 = 256;

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(message: impl Into<String>) {
    let text = message.into().replace('\0', " ");
    LAST_ERROR.with(|e| *e.borrow_mut() = CString::new(text).unwrap_or_default());
}

fn fail(code: R, message: impl Into<String>) -> R {
    set_error(message);
    code
}

fn ipc_error(e: &IpcError) -> R {
    let code = match e {
        IpcError::ServerNotFound { .. } => R::SPLATPHYS_ERR_NOT_FOUND,
        IpcError::ServerGone { .. } => R::SPLATPHYS_ERR_SERVER_GONE,
        IpcError::ServerShutDown { .. } => R::SPLATPHYS_ERR_SHUT_DOWN,
        IpcError::Interrupted => R::SPLATPHYS_ERR_INTERRUPTED,
        IpcError::NoReply { .. } => R::SPLATPHYS_TIMEOUT,
        _ => R::SPLATPHYS_ERR_IPC,
    };
    fail(code, e.to_string())
}

/// Runs `f`, turning a panic into [`splatphys_Result::SPLATPHYS_ERR_INTERNAL`].
fn guard(f: impl FnOnce() -> R) -> R {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        fail(R::SPLATPHYS_ERR_INTERNAL, format!("internal error: {what}"))
    })
}

/// A C caller's timeout in seconds, or the invalid-argument code (with its message set).
fn timeout(seconds: f64) -> Result<Duration, R> {
    if seconds.is_finite() && seconds >= 0.0 {
        Ok(Duration::from_secs_f64(seconds.min(1e6)))
    } else {
        Err(fail(
            R::SPLATPHYS_ERR_INVALID_ARGUMENT,
            "timeout_s must be a number >= 0",
        ))
    }
}

/// One connection to a server (opaque to C).
pub struct splatphys_Client {
    conn: Connection,
    frame: Option<FrameSample>,
    names: Vec<String>,
    status: Option<Status>,
    objects: Vec<ObjectState>,
    objects_header: Option<FrameHeader>,
    scene: Option<SceneHeader>,
}

impl splatphys_Client {
    /// Takes whatever names, status, objects and scene header have arrived (never blocks).
    fn refresh(&mut self) -> Result<(), IpcError> {
        while let Some(names) = self.conn.recv_object_names()? {
            self.names = names.payload().iter().map(|n| n.text()).collect();
        }
        while let Some(scene) = self.conn.recv_scene()? {
            self.scene = Some(*scene.user_header());
        }
        // Drains the service and checks the heartbeat; the newest status (or the last one).
        if let Some(s) = self.conn.poll_status()? {
            self.status = Some(s);
        }
        while let Some(o) = self.conn.recv_objects()? {
            self.objects.clear();
            self.objects.extend_from_slice(o.payload());
            self.objects_header = Some(*o.user_header());
        }
        Ok(())
    }
}

/// Connects to the server under `prefix` (e.g. `"splatphys/default"`), waiting up to
/// `timeout_s` seconds for it to appear; `*out` receives the client.
///
/// Returns `SPLATPHYS_OK`, `SPLATPHYS_ERR_NOT_FOUND`, `SPLATPHYS_ERR_INVALID_ARGUMENT` or
/// `SPLATPHYS_ERR_IPC`.
///
/// # Safety
/// `prefix` is a NUL-terminated string; `out` points to writable memory for one pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_connect(
    prefix: *const c_char,
    timeout_s: f64,
    out: *mut *mut splatphys_Client,
) -> splatphys_Result {
    guard(|| {
        if prefix.is_null() || out.is_null() {
            return fail(
                R::SPLATPHYS_ERR_INVALID_ARGUMENT,
                "prefix and out must not be null",
            );
        }
        // SAFETY: the caller promises a NUL-terminated string.
        let Ok(prefix) = unsafe { CStr::from_ptr(prefix) }.to_str() else {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "prefix is not UTF-8");
        };
        let wait = match timeout(timeout_s) {
            Ok(wait) => wait,
            Err(code) => return code,
        };
        let mut opts = ClientOptions::new(prefix);
        opts.node_name = "splatphys-capi".into();
        opts.connect_timeout = wait;
        match Connection::connect(&opts) {
            Ok(conn) => {
                let client = Box::new(splatphys_Client {
                    conn,
                    frame: None,
                    names: Vec::new(),
                    status: None,
                    objects: Vec::new(),
                    objects_header: None,
                    scene: None,
                });
                // SAFETY: checked non-null above; the caller owns the memory.
                unsafe { *out = Box::into_raw(client) };
                R::SPLATPHYS_OK
            }
            Err(e) => ipc_error(&e),
        }
    })
}

/// Disconnects and frees the client (a borrowed frame is released). Null is ignored.
///
/// # Safety
/// `client` came from [`splatphys_connect`] and is not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_disconnect(client: *mut splatphys_Client) {
    if !client.is_null() {
        // SAFETY: the caller hands back what splatphys_connect gave it, once.
        let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(client) })));
    }
}

/// The message of the last failure on this thread (empty when none), NUL-terminated, valid
/// until the next call into the library on this thread.
#[unsafe(no_mangle)]
pub extern "C" fn splatphys_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Waits up to `timeout_s` for a frame and borrows the newest one: `*header` points to its
/// header and `*gaussians` to its `*count` Gaussians, in shared memory, until
/// [`splatphys_release_frame`], the next wait, or [`splatphys_disconnect`]. A frame already
/// borrowed is released first. Allocates nothing.
///
/// Returns `SPLATPHYS_OK`, `SPLATPHYS_TIMEOUT` (nothing new; the pointers are set to null),
/// `SPLATPHYS_ERR_SERVER_GONE`, `SPLATPHYS_ERR_SHUT_DOWN`, `SPLATPHYS_ERR_INTERRUPTED`,
/// `SPLATPHYS_ERR_INVALID_ARGUMENT` or `SPLATPHYS_ERR_IPC`.
///
/// # Safety
/// `client` is a live client; the out pointers point to writable memory.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_wait_frame(
    client: *mut splatphys_Client,
    timeout_s: f64,
    header: *mut *const FrameHeader,
    gaussians: *mut *const FrameGaussian,
    count: *mut usize,
) -> splatphys_Result {
    guard(|| {
        if client.is_null() || header.is_null() || gaussians.is_null() || count.is_null() {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "null argument");
        }
        let wait = match timeout(timeout_s) {
            Ok(wait) => wait,
            Err(code) => return code,
        };
        // SAFETY: checked non-null; the caller promises a live client used by one thread.
        let c = unsafe { &mut *client };
        // SAFETY: the out pointers are checked non-null and writable.
        unsafe {
            *header = std::ptr::null();
            *gaussians = std::ptr::null();
            *count = 0;
        }
        c.frame = None;
        let taken = (|| -> Result<Option<FrameSample>, IpcError> {
            if let Some(f) = c.conn.latest_frame()? {
                return Ok(Some(f));
            }
            let Some(f) = c.conn.wait_frame(wait)? else {
                return Ok(None);
            };
            if c.conn.frame_pending()? {
                drop(f);
                return c.conn.latest_frame();
            }
            Ok(Some(f))
        })();
        match taken {
            Ok(Some(f)) => {
                // SAFETY: as above; the sample lives in `c.frame` until released.
                unsafe {
                    *header = f.user_header() as *const FrameHeader;
                    *gaussians = f.payload().as_ptr();
                    *count = f.payload().len();
                }
                c.frame = Some(f);
                R::SPLATPHYS_OK
            }
            Ok(None) => R::SPLATPHYS_TIMEOUT,
            Err(e) => ipc_error(&e),
        }
    })
}

/// Releases the borrowed frame (its pointers are invalid afterwards). No-op without one.
///
/// # Safety
/// `client` is a live client or null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_release_frame(client: *mut splatphys_Client) {
    if !client.is_null() {
        // SAFETY: a live client, used by one thread.
        let c = unsafe { &mut *client };
        c.frame = None;
    }
}

/// Copies the newest objects (`[capacity]` at `out`) and their frame header into caller
/// memory; `*count` receives the number of objects (also when the buffer is too small).
///
/// Returns `SPLATPHYS_OK`, `SPLATPHYS_TIMEOUT` (no objects sample has arrived yet),
/// `SPLATPHYS_ERR_BUFFER_TOO_SMALL`, or the errors of [`splatphys_wait_frame`].
///
/// # Safety
/// `client` is live; `out` holds `capacity` elements (may be null when `capacity` is 0);
/// `count` and `header` (may be null) are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_objects(
    client: *mut splatphys_Client,
    out: *mut ObjectState,
    capacity: usize,
    count: *mut usize,
    header: *mut FrameHeader,
) -> splatphys_Result {
    guard(|| {
        if client.is_null() || count.is_null() || (out.is_null() && capacity > 0) {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "null argument");
        }
        // SAFETY: checked non-null; one thread.
        let c = unsafe { &mut *client };
        if let Err(e) = c.refresh() {
            return ipc_error(&e);
        }
        let n = c.objects.len();
        // SAFETY: checked non-null.
        unsafe { *count = n };
        let Some(objects_header) = c.objects_header else {
            return R::SPLATPHYS_TIMEOUT;
        };
        if n > capacity {
            return fail(
                R::SPLATPHYS_ERR_BUFFER_TOO_SMALL,
                format!("{n} objects, room for {capacity}"),
            );
        }
        // SAFETY: `out` holds `capacity >= n` elements; `header` is null or writable.
        unsafe {
            std::ptr::copy_nonoverlapping(c.objects.as_ptr(), out, n);
            if !header.is_null() {
                *header = objects_header;
            }
        }
        R::SPLATPHYS_OK
    })
}

/// Copies the newest status into `*out`, waiting up to `timeout_s` for the first one (the
/// server sends about ten a second).
///
/// Returns `SPLATPHYS_OK`, `SPLATPHYS_TIMEOUT` (none arrived in time), or the errors of
/// [`splatphys_wait_frame`].
///
/// # Safety
/// `client` is live; `out` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_status(
    client: *mut splatphys_Client,
    timeout_s: f64,
    out: *mut Status,
) -> splatphys_Result {
    guard(|| {
        if client.is_null() || out.is_null() {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "null argument");
        }
        let wait = match timeout(timeout_s) {
            Ok(wait) => wait,
            Err(code) => return code,
        };
        // SAFETY: checked non-null; one thread.
        let c = unsafe { &mut *client };
        let start = std::time::Instant::now();
        loop {
            if let Err(e) = c.refresh() {
                return ipc_error(&e);
            }
            if let Some(s) = c.status {
                // SAFETY: checked non-null.
                unsafe { *out = s };
                return R::SPLATPHYS_OK;
            }
            if start.elapsed() >= wait {
                return R::SPLATPHYS_TIMEOUT;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    })
}

/// The id of the object named `name` (as the scene file names it), waiting up to `timeout_s`
/// for the server's list of names.
///
/// Returns `SPLATPHYS_OK`, `SPLATPHYS_ERR_NO_SUCH_OBJECT` (the message lists the names),
/// `SPLATPHYS_TIMEOUT` (no names arrived), or the errors of [`splatphys_wait_frame`].
///
/// # Safety
/// `client` is live; `name` is NUL-terminated; `id` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_object_id(
    client: *mut splatphys_Client,
    name: *const c_char,
    timeout_s: f64,
    id: *mut u32,
) -> splatphys_Result {
    guard(|| {
        if client.is_null() || name.is_null() || id.is_null() {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "null argument");
        }
        let wait = match timeout(timeout_s) {
            Ok(wait) => wait,
            Err(code) => return code,
        };
        // SAFETY: the caller promises a NUL-terminated string.
        let Ok(name) = unsafe { CStr::from_ptr(name) }.to_str() else {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "name is not UTF-8");
        };
        // SAFETY: checked non-null; one thread.
        let c = unsafe { &mut *client };
        let start = std::time::Instant::now();
        loop {
            if let Err(e) = c.refresh() {
                return ipc_error(&e);
            }
            if !c.names.is_empty() {
                break;
            }
            if start.elapsed() >= wait {
                return fail(
                    R::SPLATPHYS_TIMEOUT,
                    "the server's object names did not arrive",
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        match c.names.iter().position(|n| n == name) {
            Some(i) => {
                // SAFETY: checked non-null.
                unsafe { *id = i as u32 };
                R::SPLATPHYS_OK
            }
            None => fail(
                R::SPLATPHYS_ERR_NO_SUCH_OBJECT,
                format!("no object {name:?}; the scene has {:?}", c.names),
            ),
        }
    })
}

/// Sends `command` (the wire form; its `sequence` and `layout_version` are filled in here) and
/// waits up to `timeout_s` for the server's reply, copied into `*reply` (may be null).
///
/// Returns `SPLATPHYS_OK` (accepted: `reply->effective_step` says when it acts),
/// `SPLATPHYS_REJECTED` (`reply->reject_code` and `reply->message` say why),
/// `SPLATPHYS_ERR_INVALID_ARGUMENT` (an unknown kind, model or object-kind code: not sent),
/// `SPLATPHYS_TIMEOUT` (no reply in time), or the errors of [`splatphys_wait_frame`].
///
/// # Safety
/// `client` is live; `command` is readable; `reply` is null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn splatphys_send_command(
    client: *mut splatphys_Client,
    command: *const CommandMsg,
    timeout_s: f64,
    reply: *mut ReplyMsg,
) -> splatphys_Result {
    guard(|| {
        if client.is_null() || command.is_null() {
            return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, "null argument");
        }
        let wait = match timeout(timeout_s) {
            Ok(wait) => wait,
            Err(code) => return code,
        };
        // SAFETY: checked non-null; the caller promises a readable CommandMsg.
        let mut msg = unsafe { *command };
        msg.layout_version = LAYOUT_VERSION;
        let cmd = match decode(&msg) {
            Ok(cmd) => cmd,
            Err(e) => return fail(R::SPLATPHYS_ERR_INVALID_ARGUMENT, format!("command: {e}")),
        };
        // SAFETY: checked non-null; one thread.
        let c = unsafe { &mut *client };
        match c.conn.command(&cmd, wait) {
            Ok(r) => {
                let generation = c.scene.map_or(0, |s| s.scene_generation);
                if !reply.is_null() {
                    // SAFETY: checked non-null, writable by contract.
                    unsafe { *reply = r.to_msg(0, generation) };
                }
                match r {
                    Reply::Accepted { .. } => R::SPLATPHYS_OK,
                    Reply::Rejected { reason, .. } => fail(R::SPLATPHYS_REJECTED, reason),
                }
            }
            Err(e) => ipc_error(&e),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatphys_ipc::command::{self as wire, CommandKind};

    #[test]
    fn the_c_names_carry_the_wire_values() {
        use splatphys_CommandKind as C;
        let pairs = [
            (C::SPLATPHYS_COMMAND_IMPULSE, CommandKind::Impulse),
            (C::SPLATPHYS_COMMAND_SET_VELOCITY, CommandKind::SetVelocity),
            (
                C::SPLATPHYS_COMMAND_EDIT_MATERIAL,
                CommandKind::EditMaterial,
            ),
            (C::SPLATPHYS_COMMAND_SET_KIND, CommandKind::SetKind),
            (C::SPLATPHYS_COMMAND_PAUSE, CommandKind::Pause),
            (C::SPLATPHYS_COMMAND_RESUME, CommandKind::Resume),
            (C::SPLATPHYS_COMMAND_STEP, CommandKind::Step),
            (C::SPLATPHYS_COMMAND_RESET, CommandKind::Reset),
            (C::SPLATPHYS_COMMAND_SHUTDOWN, CommandKind::Shutdown),
            (C::SPLATPHYS_COMMAND_SET_POSE, CommandKind::SetPose),
        ];
        for (c, w) in pairs {
            assert_eq!(c as u32, w as u32, "{c:?}");
        }
        assert_eq!(
            [
                SPLATPHYS_FIELD_POINT,
                SPLATPHYS_FIELD_MODEL,
                SPLATPHYS_FIELD_E,
                SPLATPHYS_FIELD_NU,
                SPLATPHYS_FIELD_DENSITY,
                SPLATPHYS_FIELD_RESTITUTION,
                SPLATPHYS_FIELD_FRICTION,
                SPLATPHYS_FIELD_ANGULAR,
                SPLATPHYS_FIELD_AT_STEP,
            ],
            [
                wire::FIELD_POINT,
                wire::FIELD_MODEL,
                wire::FIELD_E,
                wire::FIELD_NU,
                wire::FIELD_DENSITY,
                wire::FIELD_RESTITUTION,
                wire::FIELD_FRICTION,
                wire::FIELD_ANGULAR,
                wire::FIELD_AT_STEP,
            ]
        );
    }

    #[test]
    fn bad_arguments_are_refused_with_a_message_not_a_crash() {
        // SAFETY: null pointers are what is being tested; nothing is dereferenced.
        let r = unsafe { splatphys_connect(std::ptr::null(), 1.0, std::ptr::null_mut()) };
        assert_eq!(r, splatphys_Result::SPLATPHYS_ERR_INVALID_ARGUMENT);
        // SAFETY: the message is NUL-terminated and read before the next call.
        let msg = unsafe { CStr::from_ptr(splatphys_last_error()) }
            .to_string_lossy()
            .into_owned();
        assert!(msg.contains("null"), "{msg}");
        let mut client = std::ptr::null_mut();
        let prefix = CString::new("splatphys/capi-nobody-here").unwrap();
        // SAFETY: valid string and out pointer.
        let r = unsafe { splatphys_connect(prefix.as_ptr(), f64::NAN, &mut client) };
        assert_eq!(r, splatphys_Result::SPLATPHYS_ERR_INVALID_ARGUMENT);
        // SAFETY: valid string and out pointer; no server exists under this prefix.
        let r = unsafe { splatphys_connect(prefix.as_ptr(), 0.2, &mut client) };
        assert_eq!(r, splatphys_Result::SPLATPHYS_ERR_NOT_FOUND);
        assert!(client.is_null());
        // SAFETY: null is documented as ignored.
        unsafe {
            splatphys_disconnect(std::ptr::null_mut());
            splatphys_release_frame(std::ptr::null_mut());
        }
    }
}
