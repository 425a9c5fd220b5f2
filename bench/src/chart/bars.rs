//! Grouped bar charts: panels side by side, each with its own y axis (linear or logarithmic),
//! one group of bars per category and one bar per series in every group, one legend for all
//! panels. Same fonts, colours and file pair as [`super::line_chart`].

use std::ops::Range;
use std::path::Path;

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::{COLOURS, ChartFiles, FONT_ENV, FONT_HINT, FONT_PATHS, axis_range, font, tick};

/// One panel of a [`bar_chart`].
#[derive(Debug, Clone, PartialEq)]
pub struct BarPanel {
    /// Panel caption.
    pub title: String,
    /// What the y axis shows, with its unit.
    pub y_label: String,
    /// Group names along x, left to right.
    pub categories: Vec<String>,
    /// `values[series][category]`; `None`, non-finite and (on a log axis) non-positive values
    /// draw no bar.
    pub values: Vec<Vec<Option<f64>>>,
    /// Logarithmic y axis.
    pub log_y: bool,
}

/// Panel size in pixels.
const PANEL: (u32, u32) = (420, 560);
/// Space above the panels for the title and the legend (pixels).
const HEADER: u32 = 80;
/// Share of a group's width the bars fill.
const GROUP_FILL: f64 = 0.8;

/// The x axis of a panel: `n` groups of width 1 centred on 0, 1, …, n − 1, labelled there.
struct GroupAxis {
    n: usize,
}

impl Ranged for GroupAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = (value + 0.5) / self.n.max(1) as f64;
        limit.0 + (f * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, _hint: H) -> Vec<f64> {
        (0..self.n).map(|i| i as f64).collect()
    }

    fn range(&self) -> Range<f64> {
        -0.5..self.n as f64 - 0.5
    }
}

fn size(panels: usize) -> (u32, u32) {
    (PANEL.0 * panels.max(1) as u32, PANEL.1 + HEADER)
}

fn draw_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    series: &[String],
    panels: &[BarPanel],
    text: bool,
) -> Result<()> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("drawing bar chart: {e}");
    root.fill(&WHITE).map_err(err)?;
    let (header, body) = root.split_vertically(HEADER);
    if text {
        let font = ("sans-serif", 24).into_font().color(&BLACK);
        header.draw_text(title, &font, (12, 8)).map_err(err)?;
    }
    let mut x = 12;
    for (i, name) in series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        header
            .draw(&Rectangle::new([(x, 46), (x + 18, 64)], colour.filled()))
            .map_err(err)?;
        x += 26;
        if text {
            let font = ("sans-serif", 16).into_font().color(&BLACK);
            header.draw_text(name, &font, (x, 47)).map_err(err)?;
            x += 9 * name.chars().count() as i32 + 24;
        }
    }
    for (area, panel) in body
        .split_evenly((1, panels.len().max(1)))
        .iter()
        .zip(panels)
    {
        let values = panel.values.iter().flatten().flatten().copied();
        let y = axis_range(values, panel.log_y);
        let n = panel.categories.len().max(1);
        let x = GroupAxis { n };
        if panel.log_y {
            draw_panel(area, panel, text, x, LogCoord::from(y.log_scale()))?;
        } else {
            // Bars grow from zero on a linear axis.
            let y = y.start.min(0.0)..y.end;
            draw_panel(area, panel, text, x, RangedCoordf64::from(y))?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

fn draw_panel<DB, X, Y>(
    area: &DrawingArea<DB, Shift>,
    panel: &BarPanel,
    text: bool,
    x: X,
    y: Y,
) -> Result<()>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("drawing bar chart: {e}");
    let base = y.range().start;
    let mut builder = ChartBuilder::on(area);
    builder.margin(12);
    if text {
        builder
            .caption(&panel.title, ("sans-serif", 18))
            .x_label_area_size(40)
            .y_label_area_size(70);
    }
    let mut chart = builder.build_cartesian_2d(x, y).map_err(err)?;
    let category = |v: &f64| {
        let i = v.round();
        if i >= 0.0 && (v - i).abs() < 1e-6 {
            panel
                .categories
                .get(i as usize)
                .cloned()
                .unwrap_or_default()
        } else {
            String::new()
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.disable_x_mesh();
    if text {
        mesh.y_desc(&panel.y_label)
            .x_label_formatter(&category)
            .y_label_formatter(&|v| tick(*v))
            .label_style(("sans-serif", 15));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(err)?;
    let ns = panel.values.len().max(1) as f64;
    let width = GROUP_FILL / ns;
    let mut bars = Vec::new();
    for (s, values) in panel.values.iter().enumerate() {
        let colour = COLOURS[s % COLOURS.len()];
        for (c, v) in values.iter().enumerate() {
            let Some(v) = v.filter(|v| v.is_finite() && (!panel.log_y || *v > 0.0)) else {
                continue;
            };
            let x0 = c as f64 - GROUP_FILL / 2.0 + s as f64 * width;
            bars.push(Rectangle::new(
                [(x0, base), (x0 + width, v)],
                colour.filled(),
            ));
        }
    }
    chart.draw_series(bars).map_err(err)?;
    Ok(())
}

/// Draws `panels` side by side to `STEM.svg` and `STEM.png`, the bars of series `i` in the
/// `i`-th chart colour, named `series[i]` in the legend above the panels. Creates the parent
/// directory. Without a font the SVG has no text and the PNG is skipped with a message, as for
/// [`super::line_chart`].
///
/// # Errors
/// File system and drawing errors.
pub fn bar_chart(
    stem: &Path,
    title: &str,
    series: &[String],
    panels: &[BarPanel],
) -> Result<ChartFiles> {
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let font = font();
    let size = size(panels.len());
    let svg = stem.with_extension("svg");
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw_bars(&root, title, series, panels, font.is_some())
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
        draw_bars(&root, title, series, panels, true)
            .with_context(|| format!("drawing {}", png.display()))?;
    }
    image::save_buffer(&png, &rgb, size.0, size.1, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("writing {}", png.display()))?;
    Ok(ChartFiles {
        svg,
        png: Some(png),
    })
}
