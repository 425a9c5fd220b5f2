//! The wire contract as other languages see it, checked against the Rust layout
//! (`core::mem::offset_of!` and `size_of`):
//! - the C header `clients/c/splatphys.h` is what cbindgen generates from `ipc/src/wire.rs` now
//!   (regenerate it with `SPLATPHYS_BLESS=1 cargo test -p splatphys-ipc --test layout`), and a
//!   C program compiled against it prints `sizeof` and `offsetof` of every field;
//! - the offset tables of `docs/reference/protocol.md`;
//! - the Python client's ctypes structures and numpy dtypes (`clients/python`).
//!
//! The C and Python checks need `cc` and `python3` with numpy; without them they fail under CI
//! (`CI` set) and are skipped with a message elsewhere.

use std::collections::BTreeMap;
use std::mem::offset_of;
use std::path::{Path, PathBuf};
use std::process::Command;

use splatphys_ipc::wire::{
    CommandLogEntry, CommandMsg, FrameGaussian, FrameHeader, LosslessAck, ObjectName, ObjectState,
    ReplyMsg, SceneGaussian, SceneHeader, Status, SubscriberLag,
};

/// (field, offset) of every field of a struct, in declaration order.
type Fields = Vec<(&'static str, usize)>;

macro_rules! layout {
    ($t:ty; $($f:ident),+ $(,)?) => {
        (stringify!($t), size_of::<$t>(), vec![$((stringify!($f), offset_of!($t, $f))),+])
    };
}

/// Every wire struct: (name, size, fields).
fn rust_layout() -> Vec<(&'static str, usize, Fields)> {
    vec![
        layout!(FrameHeader; step, time_s, substeps, frame_index, count, scene_generation,
            layout_version, reserved, publish_unix_ns),
        layout!(FrameGaussian; position_m, covariance_m2, rotation_wxyz),
        layout!(SceneGaussian; sh, opacity, scale_m, rotation_wxyz, object_id),
        layout!(SceneHeader; scene_generation, layout_version, gaussian_count, object_count,
            sh_degree, reserved, frame_dt_s, scene_name, object_names),
        layout!(ObjectName; name),
        layout!(ObjectState; id, contact_count, position_m, velocity_m_s, orientation_wxyz,
            angular_velocity_rad_s, mass_kg, contact_force_n, contact_torque_n_m),
        layout!(CommandMsg; kind, object_id, sequence, vector, point_m, fields, code,
            youngs_modulus_pa, poisson_ratio, density_kg_m3, restitution, friction, count,
            angular_velocity_rad_s, orientation_wxyz, layout_version, reserved),
        layout!(ReplyMsg; sequence, effective_step, accepted, reject_code, message,
            scene_generation, layout_version),
        layout!(CommandLogEntry; received_step, received_time_s, effective_time_s, event,
            reserved, log_index, command, reply),
        layout!(SubscriberLag; id_lo, id_hi, frames_dropped, max_wait_ms, lossless),
        layout!(LosslessAck; subscriber_id_lo, subscriber_id_hi, frame_index, flags,
            layout_version),
        layout!(Status; heartbeat, step, time_s, frames_published, steps_per_s, substeps_per_s,
            frames_dropped, recorder_frames_lost, commands_received, commands_rejected, flags,
            scene_generation, subscriber_count, reported_subscribers, subscribers, progress,
            progress_age_ms, layout_version, failure_step, failure_reason),
    ]
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

/// Whether a missing tool fails the test (under CI) or skips it.
fn tool_missing(what: &str) {
    assert!(
        std::env::var_os("CI").is_none(),
        "{what} is missing, and CI must run this check"
    );
    eprintln!("skipped: {what} is missing");
}

#[test]
fn protocol_md_offset_tables_match_the_rust_layout() {
    let doc =
        std::fs::read_to_string(root().join("docs/reference/protocol.md")).expect("protocol.md");
    // "### Name (N B)" headings, then "| offset | `field` | ..." rows.
    let mut tables: BTreeMap<String, (usize, Vec<(String, usize)>)> = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in doc.lines() {
        if let Some(h) = line.strip_prefix("### ") {
            current = h.split_once(" (").and_then(|(name, rest)| {
                let size = rest.split_once(" B)")?.0.parse().ok()?;
                tables.insert(name.to_owned(), (size, Vec::new()));
                Some(name.to_owned())
            });
        } else if let Some(name) = &current {
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            if cells.len() > 3
                && let Ok(offset) = cells[1].parse::<usize>()
            {
                let field = cells[2].trim_matches('`').to_owned();
                tables.get_mut(name).expect("table").1.push((field, offset));
            }
        }
    }
    for (name, size, fields) in rust_layout() {
        let (doc_size, doc_fields) = tables.get(name).unwrap_or_else(|| {
            panic!("docs/reference/protocol.md has no `### {name} (N B)` table")
        });
        assert_eq!(
            *doc_size, size,
            "{name}: size in docs/reference/protocol.md"
        );
        let want: Vec<(String, usize)> = fields.iter().map(|(f, o)| (f.to_string(), *o)).collect();
        assert_eq!(
            doc_fields, &want,
            "{name}: offset table in docs/reference/protocol.md"
        );
    }
}

#[test]
fn python_client_dtypes_match_the_rust_layout() {
    let script = r#"
import ctypes, json
from splatphys_client import wire
out = {}
for name in dir(wire):
    t = getattr(wire, name)
    if isinstance(t, type) and issubclass(t, ctypes.Structure) and t is not wire._Wire:
        dt = wire.np.dtype(t)
        fields = [(f, getattr(t, f).offset) for f, _ in t._fields_]
        assert [(f, dt.fields[f][1]) for f, _ in t._fields_] == fields, name
        out[name] = {"size": ctypes.sizeof(t), "itemsize": dt.itemsize, "fields": fields}
print(json.dumps(out))
"#;
    let run = Command::new("python3")
        .arg("-c")
        .arg(script)
        .env("PYTHONPATH", root().join("clients/python"))
        .output();
    let out = match run {
        Ok(o) if o.status.success() => o.stdout,
        Ok(o) => {
            let err = String::from_utf8_lossy(&o.stderr);
            if err.contains("No module named 'numpy'") || err.contains("No module named 'iceoryx2'")
            {
                return tool_missing("python3's numpy");
            }
            panic!("the Python wire module failed: {err}");
        }
        Err(_) => return tool_missing("python3"),
    };
    let py: serde_json::Value = serde_json::from_slice(&out).expect("json");
    for (name, size, fields) in rust_layout() {
        let t = &py[name];
        assert!(!t.is_null(), "the Python client has no {name}");
        assert_eq!(t["size"], size, "{name}: Python size");
        assert_eq!(t["itemsize"], size, "{name}: numpy itemsize");
        let got: Vec<(String, usize)> = t["fields"]
            .as_array()
            .expect("fields")
            .iter()
            .map(|f| {
                (
                    f[0].as_str().unwrap().to_owned(),
                    f[1].as_u64().unwrap() as usize,
                )
            })
            .collect();
        let want: Vec<(String, usize)> = fields.iter().map(|(f, o)| (f.to_string(), *o)).collect();
        assert_eq!(got, want, "{name}: Python field offsets");
    }
}

/// Prefix of every type and constant in the C header (`splatphys_Status`, ...).
const C_PREFIX: &str = "splatphys_";

/// The header cbindgen makes of `ipc/src/wire.rs`.
fn generated_header() -> String {
    let config = cbindgen::Config {
        language: cbindgen::Language::C,
        include_guard: Some("SPLATPHYS_WIRE_H".into()),
        header: Some(format!(
            "/* The splatphys wire contract (layout version {}), generated by cbindgen from\n * \
             ipc/src/wire.rs. Do not edit: SPLATPHYS_BLESS=1 cargo test -p splatphys-ipc \
             --test layout\n * regenerates it. Little-endian; strings are UTF-8, NUL-terminated. \
             */",
            splatphys_ipc::wire::LAYOUT_VERSION
        )),
        no_includes: true,
        sys_includes: vec!["stdint.h".into()],
        documentation: true,
        export: cbindgen::ExportConfig {
            include: rust_layout().iter().map(|l| l.0.to_owned()).collect(),
            prefix: Some(C_PREFIX.into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut out = Vec::new();
    cbindgen::Builder::new()
        .with_config(config)
        .with_src(root().join("ipc/src/wire.rs"))
        .generate()
        .expect("cbindgen")
        .write(&mut out);
    String::from_utf8(out).expect("utf-8")
}

#[test]
fn c_header_is_current_and_c_sees_the_rust_layout() {
    let path = root().join("clients/c/splatphys.h");
    let header = generated_header();
    if std::env::var_os("SPLATPHYS_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).expect("mkdir");
        std::fs::write(&path, &header).expect("write header");
    }
    let checked_in = std::fs::read_to_string(&path).expect("clients/c/splatphys.h");
    assert!(
        checked_in == header,
        "clients/c/splatphys.h is stale: regenerate it with \
         `SPLATPHYS_BLESS=1 cargo test -p splatphys-ipc --test layout`"
    );

    // A C program printing sizeof and offsetof of every field.
    let mut c = String::from(
        "#include <stddef.h>\n#include <stdio.h>\n#include \"splatphys.h\"\nint main(void) {\n",
    );
    let mut want = String::new();
    for (name, size, fields) in rust_layout() {
        c += &format!("  printf(\"{name} %zu\\n\", sizeof({C_PREFIX}{name}));\n");
        want += &format!("{name} {size}\n");
        for (f, o) in fields {
            c += &format!("  printf(\"{name}.{f} %zu\\n\", offsetof({C_PREFIX}{name}, {f}));\n");
            want += &format!("{name}.{f} {o}\n");
        }
    }
    c += "  return 0;\n}\n";
    let dir = tempfile_dir();
    let src = dir.join("layout.c");
    let exe = dir.join("layout");
    std::fs::write(&src, c).expect("write C");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let built = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Werror", "-I"])
        .arg(root().join("clients/c"))
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .output();
    match built {
        Ok(o) if o.status.success() => {}
        Ok(o) => panic!(
            "the C program does not compile against the header: {}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(_) => return tool_missing("a C compiler (cc)"),
    }
    let out = Command::new(&exe).output().expect("run the C program");
    assert_eq!(String::from_utf8_lossy(&out.stdout), want, "C layout");
    let _ = std::fs::remove_dir_all(dir);
}

/// A fresh directory under the target's temporary folder.
fn tempfile_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("splatphys-layout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
