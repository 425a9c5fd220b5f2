//! Line charts and CSV tables for the `bench` subcommands (plotters, no system font library).
//!
//! [`line_chart`] draws named series of (x, y) points, optionally on log axes, to `STEM.svg` and
//! `STEM.png`. Text is laid out with plotters' `ab_glyph` backend from a TrueType file found at
//! run time ([`FONT_ENV`] first, then [`FONT_PATHS`]); nothing links fontconfig. Without a font
//! the SVG is still written (series, grid and legend colours, but no text: the numbers are in the
//! CSV) and the PNG is skipped with a message naming the package to install.

use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Environment variable naming the TrueType font to use (only that file is tried when set).
pub const FONT_ENV: &str = "SPLATPHYS_CHART_FONT";
/// Fonts tried in order when [`FONT_ENV`] is not set (Debian/Ubuntu, Fedora, Arch, macOS).
pub const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
];
/// What to install when no font is found.
const FONT_HINT: &str = "install fonts-dejavu-core (Debian/Ubuntu), dejavu-sans-fonts (Fedora) \
                         or ttf-dejavu (Arch), or set SPLATPHYS_CHART_FONT to a .ttf file";

/// Series colours, in order (Tableau 10: distinct on white and for common colour blindness).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Chart size in pixels (SVG user units and PNG pixels).
const SIZE: (u32, u32) = (960, 640);

/// One named line of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) points in drawing order; non-finite points (and non-positive ones on a log axis)
    /// are left out.
    pub points: Vec<(f64, f64)>,
}

/// What [`line_chart`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChartFiles {
    /// `STEM.svg`, always written.
    pub svg: PathBuf,
    /// `STEM.png`, `None` when no font was found.
    pub png: Option<PathBuf>,
}

/// Registers the first TrueType font found as plotters' "sans-serif", once per process.
/// Returns the font's path, or `None` when there is none.
fn font() -> Option<&'static Path> {
    static FONT: OnceLock<Option<PathBuf>> = OnceLock::new();
    FONT.get_or_init(|| {
        let candidates: Vec<PathBuf> = match std::env::var_os(FONT_ENV) {
            Some(p) => vec![PathBuf::from(p)],
            None => FONT_PATHS.iter().map(PathBuf::from).collect(),
        };
        candidates.into_iter().find(|p| {
            let Ok(bytes) = std::fs::read(p) else {
                return false;
            };
            // plotters keeps a reference for the life of the process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
        })
    })
    .as_deref()
}

/// Compact tick label: 1000 -> "1k", 2500000 -> "2.5M", 0.25 -> "0.25".
fn tick(v: f64) -> String {
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    };
    let a = v.abs();
    if a >= 1e6 {
        format!("{}M", trim(format!("{:.2}", v / 1e6)))
    } else if a >= 1e3 {
        format!("{}k", trim(format!("{:.2}", v / 1e3)))
    } else if a >= 1.0 || a == 0.0 {
        trim(format!("{v:.2}"))
    } else {
        format!("{v:.2e}")
    }
}

/// Axis range covering `values`, padded; on a log axis only positive values count.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return if log { 1.0..10.0 } else { 0.0..1.0 };
    }
    if log {
        (lo / 1.5)..(hi * 1.5)
    } else {
        let pad = ((hi - lo) * 0.05).max(hi.abs() * 1e-3).max(1e-12);
        (lo - pad)..(hi + pad)
    }
}

struct Spec<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    series: &'a [Series],
    log: (bool, bool),
    text: bool,
}

fn draw<DB, X, Y>(root: &DrawingArea<DB, Shift>, spec: &Spec<'_>, x: X, y: Y) -> Result<()>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("drawing chart: {e}");
    root.fill(&WHITE).map_err(err)?;
    let mut builder = ChartBuilder::on(root);
    builder.margin(20);
    if spec.text {
        builder
            .caption(spec.title, ("sans-serif", 26))
            .x_label_area_size(50)
            .y_label_area_size(80);
    }
    let mut chart = builder.build_cartesian_2d(x, y).map_err(err)?;
    let mut mesh = chart.configure_mesh();
    if spec.text {
        mesh.x_desc(spec.x_label)
            .y_desc(spec.y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style(("sans-serif", 16));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(err)?;
    let keep = |(x, y): &(f64, f64)| {
        x.is_finite() && y.is_finite() && (!spec.log.0 || *x > 0.0) && (!spec.log.1 || *y > 0.0)
    };
    for (i, s) in spec.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()].to_rgba();
        let points: Vec<(f64, f64)> = s.points.iter().copied().filter(keep).collect();
        let line = chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(err)?;
        if spec.text {
            line.label(s.name.as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        }
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
            .map_err(err)?;
    }
    if spec.text {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Draws `spec` on `root` with linear or log axes.
fn draw_axes<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, spec: &Spec<'_>) -> Result<()> {
    let points = || spec.series.iter().flat_map(|s| s.points.iter().copied());
    let xr = axis_range(points().map(|p| p.0), spec.log.0);
    let yr = axis_range(points().map(|p| p.1), spec.log.1);
    let lin = |r: Range<f64>| RangedCoordf64::from(r);
    let log = |r: Range<f64>| LogCoord::from(r.log_scale());
    match spec.log {
        (false, false) => draw(root, spec, lin(xr), lin(yr)),
        (true, false) => draw(root, spec, log(xr), lin(yr)),
        (false, true) => draw(root, spec, lin(xr), log(yr)),
        (true, true) => draw(root, spec, log(xr), log(yr)),
    }
}

/// Draws `series` as a line chart to `STEM.svg` and `STEM.png` (x and y axes logarithmic when
/// `log_x` / `log_y`). Creates the parent directory. Without a font the PNG is skipped and a
/// message saying which package to install goes to stderr (see the module docs).
///
/// # Errors
/// File system and drawing errors.
pub fn line_chart(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_x: bool,
    log_y: bool,
) -> Result<ChartFiles> {
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let font = font();
    let spec = Spec {
        title,
        x_label,
        y_label,
        series,
        log: (log_x, log_y),
        text: font.is_some(),
    };
    let svg = stem.with_extension("svg");
    {
        let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
        draw_axes(&root, &spec).with_context(|| format!("writing {}", svg.display()))?;
    }
    if font.is_none() {
        eprintln!(
            "chart: no TrueType font found (tried {}): wrote {} without text and SKIPPED the \
             PNG; {FONT_HINT}",
            std::env::var(FONT_ENV).unwrap_or_else(|_| FONT_PATHS.join(", ")),
            svg.display()
        );
        return Ok(ChartFiles { svg, png: None });
    }
    let png = stem.with_extension("png");
    let mut rgb = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        draw_axes(&root, &spec).with_context(|| format!("drawing {}", png.display()))?;
    }
    image::save_buffer(&png, &rgb, SIZE.0, SIZE.1, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("writing {}", png.display()))?;
    Ok(ChartFiles {
        svg,
        png: Some(png),
    })
}

/// Writes a CSV table: `header` then one line per row (numbers in Rust's shortest round-trip
/// form, so values read back exactly). Creates the parent directory.
///
/// # Errors
/// When a row's length differs from the header's, and on file system errors.
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<f64>]) -> Result<()> {
    let mut out = header.join(",");
    out.push('\n');
    for (i, row) in rows.iter().enumerate() {
        anyhow::ensure!(
            row.len() == header.len(),
            "{}: row {i} has {} values for {} columns",
            path.display(),
            row.len(),
            header.len()
        );
        for (j, v) in row.iter().enumerate() {
            let sep = if j == 0 { "" } else { "," };
            write!(out, "{sep}{v}").expect("writing to a String cannot fail");
        }
        out.push('\n');
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_compact() {
        assert_eq!(tick(1000.0), "1k");
        assert_eq!(tick(2_500_000.0), "2.5M");
        assert_eq!(tick(12.0), "12");
        assert_eq!(tick(0.0), "0");
    }

    #[test]
    fn log_ranges_ignore_non_positive_values() {
        let r = axis_range([0.0, -1.0, 10.0, 1000.0].into_iter(), true);
        assert!(r.start > 0.0 && r.start < 10.0 && r.end > 1000.0, "{r:?}");
    }

    #[test]
    fn csv_rejects_ragged_rows_and_round_trips_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        write_csv(&p, &["a", "b"], &[vec![1.0, 0.1]]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "a,b\n1,0.1\n");
        assert!(write_csv(&p, &["a", "b"], &[vec![1.0]]).is_err());
    }

    #[test]
    fn charts_write_svg_and_png_when_a_font_exists() {
        let dir = tempfile::tempdir().unwrap();
        let stem = dir.path().join("sub/chart");
        let s = [Series {
            name: "y = x²".into(),
            points: (1..=4)
                .map(|i| (10f64.powi(i), 10f64.powi(2 * i)))
                .collect(),
        }];
        let files = line_chart(&stem, "t", "x", "y", &s, true, true).unwrap();
        let svg = std::fs::read_to_string(&files.svg).unwrap();
        assert!(svg.starts_with("<svg"), "{svg:.80}");
        match files.png {
            Some(png) => assert!(std::fs::metadata(png).unwrap().len() > 1000),
            None => assert!(font().is_none()),
        }
    }
}
