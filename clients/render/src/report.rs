//! [`RenderReport`]: what `splatphys-render live` and `splatphys-render mcap` print as their last
//! stdout line (one JSON object), and what `splatphys run` reads back into `summary.json`.

use serde::{Deserialize, Serialize};

/// The renderer's report of one run.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RenderReport {
    /// Frames rendered to PNG.
    pub frames_rendered: u64,
    /// Wanted frames not rendered (too slow, lost in the recording, or no scene).
    pub frames_dropped: u64,
    /// Step of the last rendered frame (0 when none).
    pub last_step: u64,
    /// Wall-clock seconds of the run.
    pub seconds: f64,
}

impl RenderReport {
    /// The report as one JSON line: `{"frames_rendered":N,"frames_dropped":M,"last_step":S,"seconds":T}`.
    pub fn json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The last line of `stdout` that parses as a report (`None` when none does).
    pub fn from_stdout(stdout: &str) -> Option<Self> {
        stdout
            .lines()
            .rev()
            .find_map(|l| serde_json::from_str(l).ok())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_is_one_json_line_that_reads_back() {
        let s = RenderReport {
            frames_rendered: 3,
            frames_dropped: 1,
            last_step: 7,
            seconds: 0.5,
        };
        assert_eq!(
            s.json(),
            r#"{"frames_rendered":3,"frames_dropped":1,"last_step":7,"seconds":0.5}"#
        );
        let out = format!("splatphys-render: done\n{}\n", s.json());
        assert_eq!(RenderReport::from_stdout(&out), Some(s));
        assert_eq!(RenderReport::from_stdout("no report"), None);
    }
}
