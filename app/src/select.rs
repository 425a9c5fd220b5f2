//! `splatphys select`: which Gaussians a scene file makes into which object, written without
//! simulating: `selection.ply` (the scene's Gaussians placed in the world, INRIA PLY with an
//! `object_id` property, −1 for the captured background), one `masks/<object>.npy` per object
//! (`bool [N]` over the Gaussians of `selection.ply`, in its order) and `objects.json` (names,
//! ids, counts), for checking a selection in a splat viewer or handing it to other tools.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use splatphys_core::formats::ply::write_ply;
use splatphys_core::formats::posed::{PosedGaussian, cloud_from_posed};
use splatphys_ipc::Simulation;
use splatphys_ipc::wire::{BACKGROUND_OBJECT_ID, FrameGaussian, SceneGaussian};

use crate::plan::RunPlan;
use crate::world_sim::WorldSim;

/// Arguments of `splatphys select`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys select scenes/donut_drop.toml --out out/donut_selection
  splatphys select scenes/playbot_drop.toml --out out/playbot_selection")]
pub struct SelectArgs {
    /// Scene file (TOML); the built-in default scene when absent.
    pub scene: Option<PathBuf>,
    /// Output folder (created; files of the same names are overwritten).
    #[arg(long, short)]
    pub out: PathBuf,
}

/// Writes the selection of a scene (see the module docs).
///
/// # Errors
/// A bad scene (named with its key), an unwritable output folder.
pub fn run(args: &SelectArgs) -> Result<()> {
    let (plan, scene) = RunPlan::new(args.scene.as_deref(), None, None)?;
    let sim = WorldSim::new(&plan.name, &scene)
        .with_context(|| format!("building scene {:?}", plan.name))?;
    let n = sim.gaussian_count();
    let mut statics = vec![SceneGaussian::default(); n];
    sim.write_scene(&mut statics);
    let mut frame = vec![FrameGaussian::default(); n];
    sim.write_frame(&mut frame);
    let posed: Vec<PosedGaussian> = frame
        .iter()
        .zip(&statics)
        .map(|(f, s)| PosedGaussian {
            position_m: f.position_m,
            covariance_m2: f.covariance_m2,
            rotation_wxyz: f.rotation_wxyz,
            opacity: s.opacity,
            object_id: (s.object_id != BACKGROUND_OBJECT_ID).then_some(s.object_id),
        })
        .collect();
    let sh: Vec<[f32; 48]> = statics.iter().map(|s| s.sh).collect();
    let cloud = cloud_from_posed(&posed, &sh, sim.sh_degree() as u8, true);

    let masks_dir = args.out.join("masks");
    std::fs::create_dir_all(&masks_dir)
        .with_context(|| format!("creating {}", masks_dir.display()))?;
    let ply = args.out.join("selection.ply");
    let comments = vec![
        format!("splatphys selection of scene {}", plan.name),
        "world metres, z up; object_id -1 is the captured background".to_string(),
    ];
    write_ply(&ply, &cloud, &comments)?;
    let mut objects = Vec::new();
    for id in 0..sim.object_count() as u32 {
        let name = sim.object_name(id).unwrap_or("object").to_string();
        let mask: Vec<bool> = statics.iter().map(|s| s.object_id == id).collect();
        let count = mask.iter().filter(|m| **m).count();
        let file = masks_dir.join(format!("{id:03}_{}.npy", file_safe(&name)));
        npyz::to_file_1d(&file, mask).with_context(|| format!("writing {}", file.display()))?;
        objects.push(serde_json::json!({
            "id": id,
            "name": name,
            "gaussians": count,
            "mask": file.strip_prefix(&args.out).unwrap_or(&file),
        }));
    }
    let background = statics
        .iter()
        .filter(|s| s.object_id == BACKGROUND_OBJECT_ID)
        .count();
    let json = serde_json::json!({
        "scene": plan.name,
        "gaussians": n,
        "background_gaussians": background,
        "ply": "selection.ply",
        "objects": objects,
    });
    let json_path = args.out.join("objects.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&json)? + "\n")
        .with_context(|| format!("writing {}", json_path.display()))?;
    for o in &objects {
        eprintln!(
            "splatphys select: object {} {}: {} Gaussians",
            o["id"],
            o["name"].as_str().unwrap_or_default(),
            o["gaussians"]
        );
    }
    eprintln!(
        "splatphys select: {n} Gaussians ({background} background) -> {}",
        args.out.display()
    );
    Ok(())
}

/// An object name as a file name: letters, digits, `-` and `_` kept, anything else `_`.
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}
