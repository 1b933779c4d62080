//! The incompressible flow solver: direct and iterative linear solvers, the momentum predictor
//! (2.35), the pressure projection (2.36)-(2.39), and the stepper that ties them together.

pub mod spectral;

pub use spectral::{AxisKind, Location, SpectralSolver};
