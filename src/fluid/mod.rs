//! The incompressible flow solver: direct and iterative linear solvers, the momentum predictor
//! (2.35), the pressure projection (2.36)-(2.39), and the stepper that ties them together. The
//! two linear solves of a step are strategies: [`MomentumSolver`] and [`PressureSolver`].

pub mod forcing;
pub mod krylov;
pub mod linalg;
pub mod momentum;
pub mod projection;
pub mod sor;
pub mod spectral;
pub mod stepper;

pub use forcing::{BodyForce, Forcing};
pub use krylov::{KrylovInfo, KrylovParams, KrylovWorkspace, LinOp, Precond};
pub use momentum::{
    Coefficient, HelmholtzPrecond, ImplicitTerm, KrylovMomentum, Materials, MomentumSolver, MomentumSystem,
};
pub use projection::{PressureSolver, SpectralPcg};
pub use sor::{SorMomentum, SorParams};
pub use spectral::{AxisKind, Location, SpectralSolver};
pub use stepper::{FlowConfig, FlowStepper, PredictorSolver, StepInfo, ViscousScheme};
