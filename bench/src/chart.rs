//! Line charts, heat maps and CSV tables for the `bench` subcommands (plotters, no system font
//! library).
//!
//! [`line_chart`] draws named series of (x, y) points, optionally on log axes, to `STEM.svg` and
//! `STEM.png`; [`heat_map`] draws panels of categorical cells (one panel per method and
//! material, say) with a shared legend. Text is laid out with plotters' `ab_glyph` backend from a TrueType file found at
//! run time ([`FONT_ENV`] first, then [`FONT_PATHS`]); nothing links fontconfig. Without a font
//! the SVG is still written (series, grid and legend colours, but no text: the numbers are in the
//! CSV) and the PNG is skipped with a message naming the package to install. [`bar_chart`]
//! ([`bars`]) draws grouped bars, panels side by side.

pub mod bars;

pub use bars::{BarPanel, bar_chart};

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, ValueFormatter};
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

/// One panel of a [`heat_map`]: a grid of cells, each a category index or empty.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatPanel {
    /// Panel caption.
    pub title: String,
    /// `cells[y][x]`: index into [`HeatMap::categories`], `None` for no data (drawn grey).
    pub cells: Vec<Vec<Option<usize>>>,
}

/// A figure of [`HeatPanel`]s sharing axes and categories.
#[derive(Debug, Clone, Copy)]
pub struct HeatMap<'a> {
    /// Figure title.
    pub title: &'a str,
    /// What the columns of every panel are.
    pub x_label: &'a str,
    /// What the rows of every panel are.
    pub y_label: &'a str,
    /// Column labels, left to right.
    pub x_ticks: &'a [String],
    /// Row labels, bottom to top.
    pub y_ticks: &'a [String],
    /// Legend entries and their colours.
    pub categories: &'a [(String, RGBColor)],
    /// Panels, row by row.
    pub panels: &'a [HeatPanel],
    /// Panels per row of the figure.
    pub columns: usize,
    /// A vertical line in every panel at the left edge of column `.0` (`.0` = number of columns
    /// for the right edge), named `.1` in the legend.
    pub x_line: Option<(usize, &'a str)>,
}

/// Panel size in pixels.
const PANEL: (u32, u32) = (230, 215);
/// Space above the panels for the title, axis note and legend (pixels).
const HEAT_HEADER: u32 = 110;
/// Colour of a cell without data.
const NO_DATA: RGBColor = RGBColor(220, 220, 220);

fn heat_size(map: &HeatMap<'_>) -> (u32, u32) {
    let cols = map.columns.clamp(1, map.panels.len().max(1));
    let rows = map.panels.len().div_ceil(cols).max(1);
    (PANEL.0 * cols as u32, PANEL.1 * rows as u32 + HEAT_HEADER)
}

/// Every `step`-th label, so that labels of `n` cells fit in `pixels`.
fn label_step(n: usize, pixels: u32) -> usize {
    let fit = (pixels / 26).max(1) as usize;
    n.div_ceil(fit).max(1)
}

/// A heat-map axis: `n` cells of width 1 covering [0, n], key points (labels) at every `step`-th
/// cell centre.
struct CellAxis {
    n: usize,
    step: usize,
}

impl Ranged for CellAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = value / self.n.max(1) as f64;
        limit.0 + (f * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, _hint: H) -> Vec<f64> {
        (0..self.n)
            .step_by(self.step.max(1))
            .map(|i| i as f64 + 0.5)
            .collect()
    }

    fn range(&self) -> Range<f64> {
        0.0..self.n as f64
    }
}

fn draw_heat<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &HeatMap<'_>,
    text: bool,
) -> Result<()> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("drawing heat map: {e}");
    root.fill(&WHITE).map_err(err)?;
    let (header, body) = root.split_vertically(HEAT_HEADER);
    let width = header.dim_in_pixel().0 as i32;
    if text {
        header
            .draw_text(
                map.title,
                &("sans-serif", 24).into_font().color(&BLACK),
                (12, 8),
            )
            .map_err(err)?;
        let note = format!("in every panel: x = {}, y = {}", map.x_label, map.y_label);
        header
            .draw_text(
                &note,
                &("sans-serif", 15).into_font().color(&BLACK),
                (12, 42),
            )
            .map_err(err)?;
    }
    let mut x = 12;
    for (name, colour) in map.categories {
        header
            .draw(&Rectangle::new([(x, 72), (x + 18, 90)], colour.filled()))
            .map_err(err)?;
        x += 26;
        if text {
            header
                .draw_text(name, &("sans-serif", 15).into_font().color(&BLACK), (x, 73))
                .map_err(err)?;
            x += 9 * name.chars().count() as i32 + 24;
        }
        if x > width {
            break;
        }
    }
    if let Some((_, name)) = map.x_line {
        header
            .draw(&PathElement::new(
                vec![(x + 8, 70), (x + 8, 92)],
                BLACK.stroke_width(3),
            ))
            .map_err(err)?;
        if text {
            header
                .draw_text(
                    name,
                    &("sans-serif", 15).into_font().color(&BLACK),
                    (x + 18, 73),
                )
                .map_err(err)?;
        }
    }
    let cols = map.columns.clamp(1, map.panels.len().max(1));
    let rows = map.panels.len().div_ceil(cols).max(1);
    let (nx, ny) = (map.x_ticks.len().max(1), map.y_ticks.len().max(1));
    let (x_step, y_step) = (label_step(nx, PANEL.0 - 50), label_step(ny, PANEL.1 - 60));
    for (area, panel) in body.split_evenly((rows, cols)).iter().zip(map.panels) {
        let mut builder = ChartBuilder::on(area);
        builder.margin(6);
        if text {
            builder
                .caption(&panel.title, ("sans-serif", 15))
                .x_label_area_size(20)
                .y_label_area_size(38);
        }
        // Cell (i, j) covers [i, i + 1] × [j, j + 1]; labels sit at cell centres.
        let mut chart = builder
            .build_cartesian_2d(
                CellAxis {
                    n: nx,
                    step: x_step,
                },
                CellAxis {
                    n: ny,
                    step: y_step,
                },
            )
            .map_err(err)?;
        let label = |ticks: &[String], v: f64| {
            let i = (v - 0.5).round();
            if i >= 0.0 {
                ticks.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        let x_label = |v: &f64| label(map.x_ticks, *v);
        let y_label = |v: &f64| label(map.y_ticks, *v);
        let mut mesh = chart.configure_mesh();
        mesh.disable_mesh();
        if text {
            mesh.x_labels(nx)
                .y_labels(ny)
                .x_label_formatter(&x_label)
                .y_label_formatter(&y_label)
                .label_style(("sans-serif", 11));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw().map_err(err)?;
        let mut rects = Vec::new();
        for (iy, row) in panel.cells.iter().enumerate() {
            for (ix, cell) in row.iter().enumerate() {
                let colour = cell
                    .and_then(|k| map.categories.get(k))
                    .map_or(NO_DATA, |c| c.1);
                let corners = [(ix as f64, iy as f64), (ix as f64 + 1.0, iy as f64 + 1.0)];
                rects.push(Rectangle::new(corners, colour.filled()));
                rects.push(Rectangle::new(corners, WHITE.stroke_width(1)));
            }
        }
        chart.draw_series(rects).map_err(err)?;
        if let Some((k, _)) = map.x_line {
            let k = k.min(nx) as f64;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(k, 0.0), (k, ny as f64)],
                    BLACK.stroke_width(3),
                )))
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Draws `map` to `STEM.svg` and `STEM.png` (panels in rows of `map.columns`, a legend of the
/// categories above them). Creates the parent directory. Without a font the SVG has no text and
/// the PNG is skipped with a message, as for [`line_chart`].
///
/// # Errors
/// File system and drawing errors.
pub fn heat_map(stem: &Path, map: &HeatMap<'_>) -> Result<ChartFiles> {
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let font = font();
    let size = heat_size(map);
    let svg = stem.with_extension("svg");
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw_heat(&root, map, font.is_some())
            .with_context(|| format!("writing {}", svg.display()))?;
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
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw_heat(&root, map, true).with_context(|| format!("drawing {}", png.display()))?;
    }
    image::save_buffer(&png, &rgb, size.0, size.1, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("writing {}", png.display()))?;
    Ok(ChartFiles {
        svg,
        png: Some(png),
    })
}

/// Writes `rows` (flat JSON objects with the same keys) as CSV, columns in the first row's key
/// order (serde_json sorts them). See [`write_columns_csv`].
///
/// # Errors
/// File system errors.
pub fn write_rows_csv(path: &Path, rows: &[serde_json::Value]) -> Result<()> {
    let Some(first) = rows.first().and_then(|r| r.as_object()) else {
        return Ok(());
    };
    let keys: Vec<&str> = first.keys().map(String::as_str).collect();
    write_columns_csv(path, &keys, rows)
}

/// Writes the fields `columns` of `rows` (flat JSON objects) as CSV in that order: strings as
/// they are, `null` and missing fields empty, other values as JSON. Text columns such as a method
/// name are why [`write_csv`], numbers only, does not do here. Creates the parent directory.
///
/// # Errors
/// File system errors.
pub fn write_columns_csv(path: &Path, columns: &[&str], rows: &[serde_json::Value]) -> Result<()> {
    let mut w = csv_writer(path)?;
    w.write_record(columns)?;
    for r in rows {
        w.write_record(columns.iter().map(|k| match &r[*k] {
            serde_json::Value::String(s) => s.clone(),
            serde_json::Value::Null => String::new(),
            v => v.to_string(),
        }))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))
}

/// A CSV writer (RFC 4180 quoting) on a new file at `path`, its parent directory created.
fn csv_writer(path: &Path) -> Result<csv::Writer<std::fs::File>> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))
}

/// Writes a CSV table: `header` then one line per row (numbers in Rust's shortest round-trip
/// form, so values read back exactly). Creates the parent directory.
///
/// # Errors
/// When a row's length differs from the header's, and on file system errors.
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<f64>]) -> Result<()> {
    for (i, row) in rows.iter().enumerate() {
        anyhow::ensure!(
            row.len() == header.len(),
            "{}: row {i} has {} values for {} columns",
            path.display(),
            row.len(),
            header.len()
        );
    }
    let mut w = csv_writer(path)?;
    w.write_record(header)?;
    for row in rows {
        w.write_record(row.iter().map(f64::to_string))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))
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
    fn column_csv_quotes_text_with_commas_and_quotes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let rows = [serde_json::json!({"a": "x, y", "b": 2, "c": "say \"hi\""})];
        write_columns_csv(&p, &["a", "b", "c", "d"], &rows).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "a,b,c,d\n\"x, y\",2,\"say \"\"hi\"\"\",\n"
        );
    }

    #[test]
    fn heat_maps_write_svg_and_png_when_a_font_exists() {
        let dir = tempfile::tempdir().unwrap();
        let stem = dir.path().join("heat");
        let panels: Vec<HeatPanel> = (0..4)
            .map(|k| HeatPanel {
                title: format!("panel {k}"),
                cells: vec![
                    vec![Some(0), Some(1), None],
                    vec![Some(1), Some(k % 2), Some(0)],
                ],
            })
            .collect();
        let ticks = |n: usize| (0..n).map(|i| i.to_string()).collect::<Vec<_>>();
        let (x_ticks, y_ticks) = (ticks(3), ticks(2));
        let categories = [
            ("good".to_string(), RGBColor(0, 160, 0)),
            ("bad".to_string(), RGBColor(200, 0, 0)),
        ];
        let map = HeatMap {
            title: "t",
            x_label: "x",
            y_label: "y",
            x_ticks: &x_ticks,
            y_ticks: &y_ticks,
            categories: &categories,
            panels: &panels,
            columns: 2,
            x_line: Some((1, "line")),
        };
        let files = heat_map(&stem, &map).unwrap();
        let svg = std::fs::read_to_string(&files.svg).unwrap();
        // 6 cells per panel, each a filled rectangle of its category's colour.
        assert!(
            svg.contains("rgb(200,0,0)") || svg.contains("#C80000"),
            "{svg:.400}"
        );
        match files.png {
            Some(png) => {
                let img = image::open(png).unwrap();
                assert_eq!((img.width(), img.height()), heat_size(&map));
            }
            None => assert!(font().is_none()),
        }
    }

    #[test]
    fn row_csv_writes_text_and_leaves_nulls_empty() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        let rows = [
            serde_json::json!({"m": "com", "v": 1.5, "f": null}),
            serde_json::json!({"m": "mpm", "v": 2, "f": "nan"}),
        ];
        write_columns_csv(&p, &["m", "v", "f"], &rows).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "m,v,f\ncom,1.5,\nmpm,2,nan\n"
        );
        write_rows_csv(&p, &rows).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "f,m,v\n,com,1.5\nnan,mpm,2\n"
        );
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
