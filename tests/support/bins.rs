//! The workspace's binaries from the cargo profile of the running test, refused when missing or
//! older than their sources.
//!
//! A test executable lives in `target/<profile>/deps/<name>-<hash>` and the binaries of that
//! profile in `target/<profile>/`. `cargo test -p splatphys-tests` alone builds none of them, so a
//! binary there may predate the code under test; [`bin`] compares its mtime with the newest source
//! file it is built from and panics, naming the file and the command that rebuilds it.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::SystemTime;

/// The workspace root (this package's parent folder).
pub fn workspace() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests package lies in the workspace root")
}

/// The workspace binary `name` from the same cargo profile as the running test.
///
/// # Panics
/// When the binary is missing, or older than the newest source file of the packages it is built
/// from (its own and its path dependencies); the message names the file and the command that
/// rebuilds it.
pub fn bin(name: &str) -> PathBuf {
    let dir = profile_dir();
    let path = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    let rebuild = rebuild_command(name, dir);
    let built = std::fs::metadata(&path)
        .and_then(|m| m.modified())
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e}; build the workspace's binaries first: `{rebuild}`",
                path.display()
            )
        });
    if let Some((source, changed)) = newest_source(name)
        && changed > built
    {
        panic!(
            "{} is stale: {} changed after it was built; rebuild it: `{rebuild}`",
            path.display(),
            source.display()
        );
    }
    path
}

/// `target/<profile>/`: the parent of the `deps/` folder holding the running test.
fn profile_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().expect("path of the running test");
        let deps = exe.parent().expect("test executable in a folder");
        assert!(
            deps.file_name().is_some_and(|n| n == "deps"),
            "{}: expected a test executable in target/<profile>/deps/",
            exe.display()
        );
        deps.parent().expect("target/<profile>/").to_path_buf()
    })
}

/// The cargo command that builds `name` in the profile whose output folder is `dir`.
fn rebuild_command(name: &str, dir: &Path) -> String {
    let profile = match dir.file_name().and_then(|n| n.to_str()) {
        Some("debug") => String::new(),
        Some("release") => " --release".to_owned(),
        Some(other) => format!(" --profile {other}"),
        None => String::new(),
    };
    match packages().as_ref().and_then(|p| p.bin_package.get(name)) {
        Some(package) => format!("cargo build{profile} -p {package} --bin {name}"),
        None => format!("cargo build{profile} --workspace"),
    }
}

/// Every source file of the workspace with its mtime, walked once: `*.rs`, and `*.html`/`*.js`
/// (pages a binary may embed). Left out:
/// - `target/`, `.git/` and other hidden folders: build output and tools, not sources;
/// - every `tests/`, `benches/` and `examples/` folder, this package included: no binary is built
///   from them, and cargo does not relink a binary when they change, so counting them would
///   refuse a binary that is up to date (editing a test would make every binary "stale" for good);
/// - `Cargo.toml`: cargo does not relink a binary when its manifest changes in ways that do not
///   touch it (a comment, the description, a dev-dependency: checked with cargo 1.95), which
///   would likewise refuse an up-to-date binary that no rebuild can refresh. A manifest change
///   that matters (dependencies, features) is caught only once a source file changes too.
fn sources() -> &'static [(PathBuf, SystemTime)] {
    static SOURCES: OnceLock<Vec<(PathBuf, SystemTime)>> = OnceLock::new();
    SOURCES.get_or_init(|| {
        let mut found = Vec::new();
        walk(&canonical(workspace()), &mut found);
        found
    })
}

fn walk(dir: &Path, found: &mut Vec<(PathBuf, SystemTime)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        if kind.is_dir() {
            let skip = name.starts_with('.')
                || matches!(&*name, "target" | "tests" | "benches" | "examples");
            if !skip {
                walk(&path, found);
            }
        } else if [".rs", ".html", ".js"]
            .iter()
            .any(|ext| name.ends_with(ext))
            && let Ok(modified) = entry.metadata().and_then(|m| m.modified())
        {
            found.push((path, modified));
        }
    }
}

/// `path` with symbolic links resolved, so that the walk and cargo's paths compare equal.
fn canonical(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

/// The newest source file binary `name` is built from, with its mtime: the files of its package
/// and of the workspace packages it depends on (normal and build dependencies, transitively).
/// When the package graph cannot be read, every source file of the workspace counts.
fn newest_source(name: &str) -> Option<(PathBuf, SystemTime)> {
    let dirs = packages().as_ref().and_then(|p| p.bin_dirs(name));
    sources()
        .iter()
        .filter(|(path, _)| {
            dirs.as_ref()
                .is_none_or(|dirs| dirs.iter().any(|d| path.starts_with(d)))
        })
        .max_by_key(|(_, modified)| *modified)
        .cloned()
}

/// The workspace's packages, from `cargo metadata --no-deps`.
struct Packages {
    /// Binary name -> its package's name.
    bin_package: HashMap<String, String>,
    /// Binary name -> its package's folder.
    bin_dir: HashMap<String, PathBuf>,
    /// Package folder -> the folders of its path dependencies (normal and build).
    deps: HashMap<PathBuf, Vec<PathBuf>>,
}

impl Packages {
    /// The folders of binary `name`'s package and of everything it depends on in the workspace.
    fn bin_dirs(&self, name: &str) -> Option<Vec<PathBuf>> {
        let mut seen = HashSet::new();
        let mut todo = vec![self.bin_dir.get(name)?.clone()];
        while let Some(dir) = todo.pop() {
            if seen.insert(dir.clone()) {
                todo.extend(self.deps.get(&dir).into_iter().flatten().cloned());
            }
        }
        Some(seen.into_iter().collect())
    }
}

/// The package graph, read once; `None` when `cargo metadata` fails (its reason is printed).
fn packages() -> &'static Option<Packages> {
    static PACKAGES: OnceLock<Option<Packages>> = OnceLock::new();
    PACKAGES.get_or_init(|| {
        let read = read_packages();
        if let Err(e) = &read {
            eprintln!("cargo metadata: {e}; every source file counts for the stale check");
        }
        read.ok()
    })
}

fn read_packages() -> Result<Packages, String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| env!("CARGO").into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--no-deps",
            "--offline",
            "--format-version",
            "1",
        ])
        .arg("--manifest-path")
        .arg(workspace().join("Cargo.toml"))
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).map_err(|e| e.to_string())?;
    let mut packages = Packages {
        bin_package: HashMap::new(),
        bin_dir: HashMap::new(),
        deps: HashMap::new(),
    };
    for package in meta["packages"].as_array().ok_or("no packages")? {
        let name = package["name"].as_str().ok_or("package without a name")?;
        let dir = package["manifest_path"]
            .as_str()
            .and_then(|m| Path::new(m).parent())
            .map(canonical)
            .ok_or("package without a manifest path")?;
        for target in package["targets"].as_array().into_iter().flatten() {
            let is_bin = target["kind"]
                .as_array()
                .is_some_and(|k| k.iter().any(|k| k == "bin"));
            if let (true, Some(bin)) = (is_bin, target["name"].as_str()) {
                packages.bin_package.insert(bin.to_owned(), name.to_owned());
                packages.bin_dir.insert(bin.to_owned(), dir.clone());
            }
        }
        let deps = package["dependencies"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|d| d["kind"] != "dev")
            .filter_map(|d| d["path"].as_str().map(|p| canonical(Path::new(p))))
            .collect();
        packages.deps.insert(dir, deps);
    }
    Ok(packages)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_client_is_built_from_its_package_and_ipc_but_not_the_physics() {
        let packages = packages().as_ref().expect("cargo metadata");
        let dirs = packages
            .bin_dirs("splatphys-probe")
            .expect("a workspace binary");
        let root = canonical(workspace());
        assert!(dirs.contains(&root.join("clients/probe")), "{dirs:?}");
        assert!(dirs.contains(&root.join("ipc")), "{dirs:?}");
        assert!(!dirs.contains(&root.join("sim-core")), "{dirs:?}");
        assert!(packages.bin_dirs("no-such-binary").is_none());
    }

    #[test]
    fn sources_leave_out_tests_build_output_and_manifests() {
        let root = canonical(workspace());
        let found = sources();
        assert!(found.iter().any(|(p, _)| p.ends_with("ipc/src/lib.rs")));
        for (path, _) in found {
            let inside = path.strip_prefix(&root).expect("inside the workspace");
            assert!(
                inside.components().all(|c| {
                    let c = c.as_os_str().to_string_lossy();
                    !c.starts_with('.') && !matches!(&*c, "target" | "tests" | "benches")
                }),
                "{}",
                path.display()
            );
            assert!(path.extension().is_some_and(|e| e != "toml"));
        }
    }

    #[test]
    fn rebuild_command_names_the_profile_and_the_package() {
        assert_eq!(
            rebuild_command("splatphys-probe", Path::new("/t/release")),
            "cargo build --release -p splatphys-probe --bin splatphys-probe"
        );
        assert_eq!(
            rebuild_command("splatphys", Path::new("/t/debug")),
            "cargo build -p splatphys --bin splatphys"
        );
        assert_eq!(
            rebuild_command("no-such-binary", Path::new("/t/fast")),
            "cargo build --profile fast --workspace"
        );
    }
}
