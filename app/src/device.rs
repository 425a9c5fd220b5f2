//! `--device` of `splatphys run` and `serve`: where deformable objects' MPM runs, and giving the
//! world its GPU.

use std::ffi::OsString;

use clap::Args;
use splatphys_core::scene::{Device, Scene};
use splatphys_core::world::World;

use crate::child_args::opt;

/// The device flag.
#[derive(Args, Debug, Clone, Default)]
pub struct DeviceArgs {
    /// Where deformable objects' MPM runs: `cpu`, or `gpu` (through wgpu: Vulkan, Metal or
    /// DirectX 12; an object steps there while nothing but grid colliders can reach it, and on
    /// the CPU while a solid object, the captured background or another deformable object is
    /// near). Overrides `[simulation] device`. Without a GPU adapter the run stays on the CPU
    /// with a warning.
    #[arg(long, value_parser = parse_device)]
    pub device: Option<Device>,
}

fn parse_device(s: &str) -> Result<Device, String> {
    s.parse::<Device>().map_err(|e| e.to_string())
}

impl DeviceArgs {
    /// Writes the flag into `scene`'s settings.
    pub fn apply(&self, scene: &mut Scene) {
        if let Some(d) = self.device {
            scene.simulation.device = d;
        }
    }

    /// The flag for a child server, if given.
    pub fn child_arg(&self) -> Option<OsString> {
        self.device.map(|d| opt("--device", d))
    }
}

/// Gives `world` a GPU when its scene asks for one (`[simulation] device = "gpu"`): `None` when
/// it asks for the CPU, else the GPU's name or why there is none (no adapter, or a build without
/// the `gpu` feature).
pub fn connect(world: &mut World) -> Option<Result<String, String>> {
    if world.settings().device != Device::Gpu {
        return None;
    }
    Some(open().map(|backend| {
        let name = backend.name();
        world.set_device(Some(backend));
        name
    }))
}

/// [`connect`], saying on stderr under `who` where MPM runs; without a GPU the world stays on
/// the CPU with a warning.
pub fn attach(world: &mut World, who: &str) {
    match connect(world) {
        None => {}
        Some(Ok(name)) => {
            eprintln!(
                "{who}: deformable objects' MPM on {name} where only grid colliders reach them"
            )
        }
        Some(Err(why)) => eprintln!("{who}: warning: device \"gpu\": {why}; running on the CPU"),
    }
}

#[cfg(feature = "gpu")]
fn open() -> Result<std::sync::Arc<dyn splatphys_core::world::DeviceBackend>, String> {
    match splatphys_gpu::GpuBackend::open() {
        Ok(b) => {
            if b.is_software() {
                eprintln!(
                    "warning: {} is a software adapter: slower than the CPU path (for checks, \
                     not for runs)",
                    splatphys_core::world::DeviceBackend::name(&b)
                );
            }
            Ok(std::sync::Arc::new(b))
        }
        Err(e) => Err(e.to_string()),
    }
}

#[cfg(not(feature = "gpu"))]
fn open() -> Result<std::sync::Arc<dyn splatphys_core::world::DeviceBackend>, String> {
    Err("this splatphys was built without the `gpu` feature".into())
}
