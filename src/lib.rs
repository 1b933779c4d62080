//! # eulermembrane
//!
//! Full Eulerian simulation of elastic capsules and red blood cells in incompressible viscous
//! flow, after Ii, Gong, Sugiyama, Wu, Huang & Takagi, *A full Eulerian fluid-membrane coupling
//! method with a smoothed volume-of-fluid approach* (Commun. Comput. Phys. 2012). The membrane
//! lives on the fluid's fixed Cartesian grid as a smoothed volume-of-fluid function `phi` and a
//! surface deformation tensor `G_s`: no markers, no surface mesh. Equation numbers such as
//! (2.35) in this documentation refer to that paper.
//!
//! Modules, in the order the data flows:
//! - [`grid`]: the staggered (MAC) grid, boundaries, fields and discrete operators;
//! - [`interface`]: geometry from `phi`, MTHINC advection, convolved-curvature advection, shapes;
//! - [`membrane`]: surface constitutive laws, stress, Jacobian, bending, `G_s` transport;
//! - [`fluid`]: Poisson/Helmholtz solvers, Krylov and SOR, the projection stepper;
//! - [`diagnostics`] and [`io`]: measurements, ParaView output, checkpoints.
//!
//! Worked examples, each a page to read top to bottom, are in the repository's `examples/`:
//! `capsule_in_shear` (a capsule in shear against the small-deformation theory), `custom_law`
//! (a user's [`membrane::law::SurfaceLaw`] checked with `testing::check_law`), `custom_effect` (a
//! user's [`simulation::effect::Effect`]), `checkpoint_restart` (a bit-for-bit restart) and
//! `custom_driver` (a time loop of one's own through [`simulation::Simulation::prepare`],
//! `commit` and `discard`). Run one with `cargo run --release --example NAME`.
//!
//! # Quick start: a pressure-driven channel
//! ```
//! use eulermembrane::fluid::forcing::BodyForce;
//! use eulermembrane::fluid::momentum::Materials;
//! use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper};
//! use eulermembrane::grid::{Boundary, Grid};
//!
//! // Periodic in x and z, walls at y = 0 and y = 1.
//! let mut bc = [[Boundary::Periodic; 2]; 3];
//! bc[1] = [Boundary::wall(), Boundary::wall()];
//! let grid = Grid::<f64>::new([4, 16, 1], [0.0; 3], [0.25, 1.0, 1.0 / 16.0], bc)?;
//! let mut flow = FlowStepper::new(&grid, Materials::uniform(1.0, 1.0)?, FlowConfig::default())?;
//! let drive = BodyForce::new([1.0, 0.0, 0.0])?;
//! for _ in 0..400 {
//!     flow.step(1e-2, &drive, None)?;
//! }
//! // The centre-line velocity approaches f / (8 mu) = 0.125.
//! let u = flow.velocity().c[0].at(&grid, 0, 8, 0);
//! assert!((u - 0.125).abs() < 2e-3);
//! # Ok::<(), eulermembrane::Error>(())
//! ```
#![warn(missing_docs)]
// Stencil code indexes several arrays by the same axis number `d`; a range loop says that best.
#![allow(clippy::needless_range_loop)]

pub mod diagnostics;
mod error;
pub mod fluid;
pub mod grid;
pub mod interface;
pub mod io;
pub mod membrane;
pub mod prelude;
mod real;
pub mod simulation;
pub mod tensor;
#[cfg(feature = "testing")]
pub mod testing;

pub use error::{Error, Result, finite, positive};
pub use real::Real;
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
