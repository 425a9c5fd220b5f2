//! The bounds on what a command or a scene file may ask of the simulation, defined once: the
//! protocol's validation (`splatphys-ipc`), the scene loader and the world's checks
//! (`splatphys-core`) all read them from here.

/// Fastest a command may make any particle of an object move, m/s (the linear velocity plus the
/// spin's speed at the object's farthest particle).
pub const MAX_COMMAND_SPEED_M_S: f64 = 100.0;
/// Fastest a particle may move before a step counts as unstable (a blow-up), m/s. Ten times
/// [`MAX_COMMAND_SPEED_M_S`]: no command may push past that, so such a speed is never asked for.
pub const MAX_STABLE_SPEED_M_S: f64 = 1000.0;
/// Largest impulse magnitude a command may carry by default, N·s (`splatphys serve
/// --max-impulse` changes it).
pub const DEFAULT_MAX_IMPULSE_N_S: f64 = 1e3;
/// Largest `step N` a command may ask for.
pub const MAX_STEP_COUNT: u64 = 1_000_000;
/// Farthest from the origin a command may place an object, m.
pub const MAX_POSITION_M: f64 = 1e4;
/// Default particle-substeps per published frame a material edit may raise the world to (all
/// objects): about 10 s of stepping per frame on a 2-core machine.
pub const DEFAULT_MAX_PARTICLE_SUBSTEPS_PER_FRAME: f64 = 1e8;
/// Largest Young's modulus accepted, Pa: steel is 2e11; beyond 1e13 the stress overflows f32.
pub const MAX_YOUNGS_MODULUS_PA: f64 = 1e13;
/// Density range accepted, kg/m³: aerogel to osmium, with margin.
pub const DENSITY_RANGE_KG_M3: (f64, f64) = (0.1, 1e5);
/// Largest Poisson's ratio accepted: λ = E ν / ((1 + ν)(1 − 2ν)) stays finite in f32.
pub const MAX_POISSON_RATIO: f64 = 0.499;

const _: () = assert!(MAX_STABLE_SPEED_M_S > MAX_COMMAND_SPEED_M_S);
