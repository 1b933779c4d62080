//! The incompressible flow solver: direct and iterative linear solvers, the momentum predictor
//! (2.35), the pressure projection (2.36)-(2.39), and the stepper that ties them together. The
//! two linear solves of a step are strategies: [`MomentumSolver`](momentum::MomentumSolver) and [`PressureSolver`](projection::PressureSolver).

pub mod forcing;
pub mod krylov;
pub mod linalg;
pub mod momentum;
pub mod projection;
pub mod sor;
pub mod spectral;
pub mod stepper;
