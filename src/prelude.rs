//! The names most programs need, in one import:
//!
//! ```
//! use eulermembrane::prelude::*;
//!
//! let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
//! let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
//!     .capsule(Sphere::new([0.5; 3], 0.25)?)
//!     .effect(Elasticity::new(NeoHookean::new(1.0)?))
//!     .build()?;
//! sim.step(1e-3)?;
//! # Ok::<(), eulermembrane::Error>(())
//! ```

pub use crate::fluid::{
    forcing::{BodyForce, Forcing},
    momentum::{ImplicitTerm, Materials, MomentumSolver},
    projection::PressureSolver,
    stepper::{FlowConfig, FlowStepper, ViscousScheme},
};
pub use crate::grid::{Boundary, Field, Grid, SymField, VectorField};
pub use crate::interface::shapes::{Biconcave, Circle, Ellipse, Ellipsoid, Shape, Sphere};
pub use crate::interface::{advect::InterfaceTransport, geometry::NormalEstimator};
pub use crate::membrane::law::{NeoHookean, Skalak, SurfaceLaw};
pub use crate::simulation::observer::{Checkpoints, Every, Observer, Progress, VtkSeries};
pub use crate::simulation::{
    Bending, BendingCoupling, Elasticity, GsTransport, MembraneCoupling, Phase, Scene, Settings, Simulation,
    StepReport, StepWarning, SurfaceLoad, Traction,
    effect::{Effect, StepState},
    timestep::{AdaptiveDt, FixedDt, TimeStepping},
};
pub use crate::{Error, Real, Result};
