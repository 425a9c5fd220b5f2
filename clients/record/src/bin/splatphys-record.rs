//! `splatphys-record`: record a run to MCAP, replay it, export objects to CSV.

use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Parser;
use splatphys_record::cli::{Cli, Cmd};
use splatphys_record::export::{ExportOptions, export_frames};
use splatphys_record::read::{Recording, object_names, objects_csv};
use splatphys_record::recorder::{RecordEnd, RecordOptions, record};
use splatphys_record::replay::{ReplayOptions, replay};
use splatphys_record::writer::ChunkCompression;

/// With the `dhat-heap` feature every allocation is counted with its call stack (`dhat-heap.json`
/// at exit), to attribute the recorder's memory.
#[cfg(feature = "dhat-heap")]
#[global_allocator]
static ALLOC: dhat::Alloc = dhat::Alloc;

fn main() -> Result<()> {
    #[cfg(feature = "dhat-heap")]
    let _profiler = dhat::Profiler::new_heap();
    match Cli::parse().command {
        Cmd::Record {
            prefix,
            out,
            lz4,
            frames,
            pointcloud_every,
            connect_timeout_s,
            chunk_mb,
        } => {
            if chunk_mb == 0 {
                bail!("--chunk-mb must be at least 1");
            }
            let mut opts = RecordOptions::new(&prefix);
            opts.writer.chunk_size_bytes = chunk_mb.saturating_mul(1 << 20);
            opts.max_frames = frames;
            opts.writer.pointcloud_every = pointcloud_every;
            opts.connect_timeout = Duration::from_secs_f64(connect_timeout_s.max(0.0));
            if lz4 {
                opts.writer.compression = ChunkCompression::Lz4;
            }
            let (end, counts) =
                record(&out, &opts).with_context(|| format!("recording {prefix}"))?;
            eprintln!(
                "splatphys-record: {} frames, {} objects, {} scenes, {} commands ({} lost from the command log), {} status -> {} ({end:?})",
                counts.frames,
                counts.objects,
                counts.scenes,
                counts.commands,
                counts.commands_lost,
                counts.statuses,
                out.display()
            );
            if let RecordEnd::ServerGone(msg) = end {
                bail!("{msg} (the recording up to that point is complete)");
            }
        }
        Cmd::Replay {
            file,
            prefix,
            fast,
            wait_for_subscribers,
            wait_timeout_s,
            lossless_limit_ms,
            recover,
        } => {
            let opts = ReplayOptions {
                realtime: !fast,
                wait_for_subscribers,
                wait_timeout: Duration::from_secs_f64(wait_timeout_s.max(0.0)),
                lossless_limit: Duration::from_millis(lossless_limit_ms),
                recover,
            };
            let r = replay(&file, &prefix, &opts)
                .with_context(|| format!("replaying {}", file.display()))?;
            if let Some(damage) = &r.damage {
                eprintln!(
                    "splatphys-record replay: {} ends early ({damage}); replayed what came before",
                    file.display()
                );
            }
            eprintln!(
                "splatphys-record replay: {} frames, {} scenes under {prefix}, peak memory {}",
                r.counts.frames,
                r.counts.scenes,
                peak_rss_mb().map_or("unknown".into(), |mb| format!("{mb:.1} MB"))
            );
        }
        Cmd::Export {
            file,
            out,
            every,
            steps,
            mut formats,
            recover,
        } => {
            formats.sort();
            formats.dedup();
            let opts = ExportOptions {
                every,
                steps,
                formats,
            };
            let spinner = indicatif::ProgressBar::new_spinner();
            spinner.set_style(
                indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            let mut msgs = Recording::open(&file, recover)?;
            let report = export_frames(&mut msgs, &file, &out, &opts, |r| {
                spinner.set_message(format!(
                    "{} frames exported of {} read",
                    r.frames, r.frames_seen
                ));
                spinner.tick();
            })
            .with_context(|| format!("exporting {}", file.display()))?;
            spinner.finish_and_clear();
            if let Some(damage) = msgs.damage() {
                eprintln!(
                    "splatphys-record export: {} ends early ({damage}); exported what came before",
                    file.display()
                );
            }
            if report.frames == 0 {
                bail!(
                    "no frame of {} matched (read {} frames; check --every and --steps)",
                    file.display(),
                    report.frames_seen
                );
            }
            eprintln!(
                "splatphys-record export: {} of {} frames -> {} files in {}",
                report.frames,
                report.frames_seen,
                report.files.len(),
                out.display()
            );
        }
        Cmd::ExportObjects { file, out, recover } => {
            // Two streamed passes: the names come first in the file, the rows from all of it.
            let names = object_names(Recording::open(&file, recover)?)?;
            let msgs = Recording::open(&file, recover)?;
            let rows = match out {
                Some(p) => {
                    let mut f = std::io::BufWriter::new(
                        std::fs::File::create(&p)
                            .with_context(|| format!("creating {}", p.display()))?,
                    );
                    objects_csv(msgs, &file, names, &mut f)?
                }
                None => objects_csv(msgs, &file, names, &mut std::io::stdout().lock())?,
            };
            eprintln!("splatphys-record: {rows} object rows");
        }
    }
    Ok(())
}

/// Peak resident set size of this process, MB (`VmHWM` of /proc/self/status; Linux only).
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1000.0)
}
