//! How the contact solver steps its contacts: the scheme and its settings.

/// How the solver steps its contacts (scene file: `[simulation] contact_solver`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ContactSolver {
    /// Sequential impulses iterated to convergence, flat patches as blocks, split-impulse
    /// push-out (module docs): the accurate default.
    #[default]
    SequentialImpulses,
    /// The soft step ([`super::soft_step`]): [`SolverSettings::substeps`] steps of one soft and
    /// one relaxing iteration each, the scheme of Box2D v3 and rapier: fewer passes, but soft
    /// contacts give under load (docs/results/performance.md).
    SoftStep,
}

impl ContactSolver {
    /// The scene-file name (`sequential-impulses`, `soft-step`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::SequentialImpulses => "sequential-impulses",
            Self::SoftStep => "soft-step",
        }
    }
}

/// How deformable material meets an immovable solid whose rule lets it leave: a "separate"
/// plane or box collider, a static or kinematic object (procedural or captured), the captured
/// ground (scene file: `[simulation] surface_contact`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SurfaceContact {
    /// The rule at every grid node that material reaches (Hu et al. 2018): inelastic, node by
    /// node; a rolling object slows.
    #[default]
    Grid,
    /// The particle barrier ([`super::barrier`]): elastic within the contact patch, friction on
    /// the patch; a rolling object rolls on. Host only.
    Barrier,
}

impl SurfaceContact {
    /// The scene-file name (`grid`, `barrier`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Grid => "grid",
            Self::Barrier => "barrier",
        }
    }
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// The scheme.
    pub scheme: ContactSolver,
    /// Soft step: steps per substep.
    pub substeps: usize,
    /// Soft step: the contact stiffness as a frequency (Hz), bounded by a quarter of the step
    /// rate; twice this against immovable bodies (Box2D's static softness).
    pub contact_hertz: f64,
    /// Soft step: the contact damping ratio ζ.
    pub damping_ratio: f64,
    /// Soft step: a flat patch's normal impulses step as one block ([`super::block`]).
    pub blocks: bool,
    /// Sequential impulses: most velocity iterations; soft step: most restitution passes.
    pub iterations: usize,
    /// The velocity iterations stop early once one changes no point's relative velocity by
    /// more than this (m/s): warm-started resting contact converges in a few, an impact takes
    /// them all. Zero: always [`Self::iterations`].
    pub converged_m_s: f64,
    /// Split-impulse iterations.
    pub push_iterations: usize,
    /// Fraction of the penetration removed per substep (β).
    pub baumgarte: f64,
    /// Penetration left alone (m).
    pub slop_m: f64,
    /// Approach speeds below this are resting contact (m/s): no restitution.
    pub resting_speed_m_s: f64,
    /// Largest push-out speed (m/s).
    pub max_push_m_s: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            scheme: ContactSolver::SequentialImpulses,
            substeps: 4,
            contact_hertz: 60.0,
            damping_ratio: 10.0,
            blocks: true,
            iterations: 60,
            converged_m_s: 1e-8,
            push_iterations: 6,
            baumgarte: 0.2,
            slop_m: 5e-5,
            resting_speed_m_s: 0.0,
            max_push_m_s: 0.5,
        }
    }
}
