//! Arguments of the child processes `splatphys run` and `serve` start (the server, the recorder,
//! the renderer, the viewer), built here and nowhere else: every option is one word,
//! `--flag=value`, so a value that begins with `-` (a camera at x = -0.7, a negative number in
//! any format) is never read as a flag by the child's parser.

use std::ffi::OsString;
use std::fmt::Display;
use std::path::Path;

/// `--flag=value` as one argument.
pub fn opt(flag: &str, value: impl Display) -> OsString {
    format!("{flag}={value}").into()
}

/// `--flag=path` as one argument (the path kept byte for byte).
pub fn opt_path(flag: &str, path: &Path) -> OsString {
    let mut arg = OsString::from(format!("{flag}="));
    arg.push(path.as_os_str());
    arg
}

/// `x,y,z` of a 3-vector (Rust's shortest round-trip formatting: never an exponent, any sign).
pub fn vec3(v: [f32; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Arg, Command};

    /// A parser like the renderer's and the viewer's: options taking a value, none of them
    /// allowing hyphen values.
    fn parser() -> Command {
        Command::new("child")
            .arg(Arg::new("camera-pos").long("camera-pos"))
            .arg(Arg::new("fov-deg").long("fov-deg"))
            .arg(Arg::new("out").long("out"))
    }

    #[test]
    fn values_with_any_sign_and_format_reach_the_child_unchanged() {
        let cases: [[f32; 3]; 4] = [
            [-0.7, -0.5, 0.35],
            [0.0, -0.0, 1e-30],
            [-1e30, 3.4e38, -1.17e-38],
            [f32::MIN_POSITIVE, -f32::EPSILON, 12345.678],
        ];
        for v in cases {
            let m = parser()
                .try_get_matches_from([
                    OsString::from("child"),
                    opt("--camera-pos", vec3(v)),
                    opt("--fov-deg", -45.5_f32),
                    opt_path("--out", Path::new("-weird dir/x")),
                ])
                .unwrap_or_else(|e| panic!("{v:?}: {e}"));
            let pos: Vec<f32> = m
                .get_one::<String>("camera-pos")
                .expect("camera-pos")
                .split(',')
                .map(|c| c.parse().expect("a number"))
                .collect();
            assert_eq!(pos.len(), 3);
            for (got, want) in pos.iter().zip(v) {
                assert_eq!(got.to_bits(), want.to_bits(), "{v:?}");
            }
            assert_eq!(m.get_one::<String>("fov-deg").unwrap(), "-45.5");
            assert_eq!(m.get_one::<String>("out").unwrap(), "-weird dir/x");
        }
    }

    #[test]
    fn the_old_two_word_form_is_what_failed() {
        // Regression: `--camera-pos -0.7,-0.5,0.35` as two words is an unknown flag `-0`.
        let e = parser()
            .try_get_matches_from(["child", "--camera-pos", "-0.7,-0.5,0.35"])
            .unwrap_err();
        assert!(e.to_string().contains("-0"), "{e}");
    }
}
