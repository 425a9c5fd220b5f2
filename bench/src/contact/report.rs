//! What `bench contact` prints and writes once every scene has run: the comparison table (one
//! column per engine, then the ratios splatphys / rapier and splatphys / mujoco), `contact.csv`
//! and `contact_bodies.csv`, and the bar chart `contact.svg` / `contact.png`.
//!
//! An engine that did not run a scene (rapier without the `rapier` feature, MuJoCo skipped or
//! `--no-mujoco`) shows '-' in its column and draws no bar; so does a metric an engine does not
//! report (COM drift of a pile, the deepest contact during the run of any engine but MuJoCo).

use std::path::Path;

use anyhow::{Context, Result};
use serde::Serialize;

use super::{ContactBenchArgs, ContactRow, OURS};
use crate::chart::{self, BarPanel};

/// The rows of one scene: splatphys always, the references where they ran.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRows {
    /// The splatphys run.
    pub ours: ContactRow,
    /// The rapier3d run (`None` without the `rapier` feature).
    pub rapier: Option<ContactRow>,
    /// The MuJoCo run (`None` when skipped).
    pub mujoco: Option<ContactRow>,
}

impl SceneRows {
    /// Every row present, splatphys first.
    pub fn all(&self) -> impl Iterator<Item = &ContactRow> {
        std::iter::once(&self.ours)
            .chain(&self.rapier)
            .chain(&self.mujoco)
    }
}

/// Writes `rows` as CSV with a header of their field names.
///
/// # Errors
/// When the file cannot be created or written.
pub fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    for r in rows {
        w.serialize(r)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))
}

/// The metrics of the table: label and how to read it from a row.
type Metric = (&'static str, fn(&ContactRow) -> Option<f64>);

const METRICS: [Metric; 12] = [
    ("steps", |r| Some(r.steps as f64)),
    ("mean step, ms", |r| Some(r.dt_mean_s * 1e3)),
    ("wall time per step, µs", |r| Some(r.us_per_step)),
    ("wall s per simulated s", |r| Some(r.wall_s_per_sim_s)),
    ("max COM drift, mm", |r| r.max_drift_mm),
    ("mean COM drift, mm", |r| r.mean_drift_mm),
    ("deepest overlap at end, mm", |r| r.max_penetration_mm),
    ("deepest contact during run, mm", |r| {
        r.deepest_contact_during_run_mm
    }),
    ("max COM speed at end, m/s", |r| Some(r.max_speed_m_s)),
    ("kinetic energy at end, J", |r| Some(r.kinetic_energy_j)),
    ("bodies below 1 cm/s at end", |r| {
        Some(r.below_1cm_s_at_end as f64)
    }),
    ("asleep at end", |r| Some(r.asleep_at_end as f64)),
];

fn cell(v: Option<f64>) -> String {
    match v {
        None => "-".into(),
        Some(v) if v == v.trunc() && v.abs() < 1e9 => format!("{v:.0}"),
        Some(v) if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e5) => format!("{v:.3e}"),
        Some(v) => format!("{v:.3}"),
    }
}

/// `a / b`, `None` when either is missing or b is 0.
fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    a.zip(b).and_then(|(a, b)| (b != 0.0).then(|| a / b))
}

/// The comparison table: per scene, each metric for the three engines and the ratios of
/// splatphys to each reference.
pub fn format_table(table: &[SceneRows]) -> String {
    let line = |scene: &str, metric: &str, cells: [String; 5]| {
        let [a, b, c, d, e] = cells;
        format!("{scene:<9} {metric:<30} {a:>12} {b:>12} {c:>12} {d:>12} {e:>12}\n")
    };
    let mut s = line(
        "scene",
        "metric",
        [OURS, "rapier3d", "mujoco", "ours/rapier", "ours/mujoco"].map(String::from),
    );
    for t in table {
        let o = &t.ours;
        let name = |r: &Option<ContactRow>, what: &str| {
            r.as_ref()
                .map_or_else(|| format!("{what}: not run"), |r| r.engine.clone())
        };
        s.push_str(&format!(
            "{} ({} bodies, {} particles, {:.2} s simulated; {}, {})\n",
            o.scene,
            o.bodies,
            o.particles.unwrap_or(0),
            o.simulated_s,
            name(&t.rapier, "rapier3d"),
            name(&t.mujoco, "mujoco"),
        ));
        for (label, get) in METRICS {
            let ours = get(o);
            let rapier = t.rapier.as_ref().and_then(get);
            let mujoco = t.mujoco.as_ref().and_then(get);
            s.push_str(&line(
                o.scene,
                label,
                [
                    cell(ours),
                    cell(rapier),
                    cell(mujoco),
                    cell(ratio(ours, rapier)),
                    cell(ratio(ours, mujoco)),
                ],
            ));
        }
    }
    s
}

/// Smallest value drawn on the chart's log axes (a rapier drift of exactly 0 still shows).
const CHART_FLOOR: f64 = 1e-4;

/// An engine of the chart: its legend name and its row of a scene.
type Engine = (String, fn(&SceneRows) -> Option<&ContactRow>);

/// Bars of max COM drift, deepest overlap at the end, time per step and the share of bodies at
/// rest per scene, one series per engine that ran at least one scene.
///
/// # Errors
/// When the chart cannot be written.
pub fn draw(stem: &Path, table: &[SceneRows], a: &ContactBenchArgs) -> Result<()> {
    let name_of = |get: fn(&SceneRows) -> Option<&ContactRow>| {
        table.iter().find_map(|t| get(t).map(|r| r.engine.clone()))
    };
    let engines: Vec<Engine> = [
        (|t: &SceneRows| Some(&t.ours)) as fn(&SceneRows) -> Option<&ContactRow>,
        |t| t.rapier.as_ref(),
        |t| t.mujoco.as_ref(),
    ]
    .into_iter()
    .filter_map(|get| name_of(get).map(|n| (n, get)))
    .collect();
    let panel = |title: &str, y: &str, log_y: bool, get: fn(&ContactRow) -> Option<f64>| {
        let used: Vec<&SceneRows> = table.iter().filter(|t| get(&t.ours).is_some()).collect();
        let floor = if log_y {
            CHART_FLOOR
        } else {
            f64::NEG_INFINITY
        };
        BarPanel {
            title: title.into(),
            y_label: y.into(),
            categories: used.iter().map(|t| t.ours.scene.to_owned()).collect(),
            values: engines
                .iter()
                .map(|(_, row)| {
                    used.iter()
                        .map(|t| row(t).and_then(get).map(|v| v.max(floor)))
                        .collect()
                })
                .collect(),
            log_y,
        }
    };
    let panels: Vec<BarPanel> = [
        panel("max COM drift at the end", "mm", true, |r| r.max_drift_mm),
        panel("deepest overlap at the end", "mm", true, |r| {
            r.max_penetration_mm
        }),
        panel("wall time per step", "µs", true, |r| Some(r.us_per_step)),
        panel(
            "bodies below 1 cm/s at the end",
            "% of bodies",
            false,
            |r| Some(100.0 * r.below_1cm_s_at_end as f64 / r.bodies.max(1) as f64),
        ),
    ]
    .into_iter()
    .filter(|p| !p.categories.is_empty())
    .collect();
    let durations: Vec<String> = table
        .iter()
        .map(|t| format!("{} {:.2} s", t.ours.scene, t.ours.simulated_s))
        .collect();
    let names: Vec<String> = engines.iter().map(|(n, _)| n.clone()).collect();
    chart::bar_chart(
        stem,
        &format!(
            "Contact: splatphys ({} thread{}) vs {} ({})",
            a.threads,
            if a.threads == 1 { "" } else { "s" },
            if names.len() > 1 {
                names[1..].join(" and ")
            } else {
                "no reference".into()
            },
            durations.join(", ")
        ),
        &names,
        &panels,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(engine: &str, steps: u64, deepest: Option<f64>) -> ContactRow {
        ContactRow {
            bench: "contact",
            scene: "cubes",
            engine: engine.into(),
            bodies: 125,
            particles: None,
            threads: 1,
            simulated_s: 3.0,
            steps,
            dt_mean_s: 3.0 / steps as f64,
            dt_min_s: 3.0 / steps as f64,
            dt_max_s: 3.0 / steps as f64,
            wall_s: 1.0,
            cpu_s: None,
            us_per_step: 1e6 / steps as f64,
            wall_s_per_sim_s: 1.0 / 3.0,
            max_drift_mm: None,
            mean_drift_mm: None,
            max_penetration_mm: Some(0.5),
            deepest_contact_during_run_mm: deepest,
            max_speed_m_s: 0.001,
            kinetic_energy_j: 1e-6,
            below_1cm_s_at_end: 125,
            asleep_at_end: 0,
        }
    }

    #[test]
    fn table_has_a_column_per_engine_and_both_ratios() {
        let t = SceneRows {
            ours: row(OURS, 3000, None),
            rapier: Some(row("rapier3d 0.36.1", 1500, None)),
            mujoco: Some(row("mujoco 4.0.0", 1500, Some(1.25))),
        };
        let s = format_table(std::slice::from_ref(&t));
        let header = s.lines().next().unwrap();
        for col in [OURS, "rapier3d", "mujoco", "ours/rapier", "ours/mujoco"] {
            assert!(header.contains(col), "{header}");
        }
        assert!(s.contains("rapier3d 0.36.1, mujoco 4.0.0"), "{s}");
        let steps = s.lines().find(|l| l.contains(" steps ")).unwrap();
        let cells: Vec<&str> = steps.split_whitespace().collect();
        assert_eq!(cells[2..], ["3000", "1500", "1500", "2", "2"], "{steps}");
        // Only MuJoCo reports the deepest contact during the run.
        let deep = s.lines().find(|l| l.contains("during run")).unwrap();
        let cells: Vec<&str> = deep.split_whitespace().collect();
        assert_eq!(
            cells[cells.len() - 5..],
            ["-", "-", "1.250", "-", "-"],
            "{deep}"
        );
        let rest = s.lines().find(|l| l.contains("below 1 cm/s")).unwrap();
        assert!(rest.split_whitespace().filter(|c| *c == "125").count() == 3);
        // A reference that did not run: its column and ratio are '-'.
        let t = SceneRows { mujoco: None, ..t };
        let s = format_table(&[t]);
        assert!(s.contains("mujoco: not run"), "{s}");
        let steps = s.lines().find(|l| l.contains(" steps ")).unwrap();
        let cells: Vec<&str> = steps.split_whitespace().collect();
        assert_eq!(cells[2..], ["3000", "1500", "-", "2", "-"], "{steps}");
    }
}
