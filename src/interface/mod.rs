//! Interface capturing: geometry from the smoothed VOF function `phi`, MTHINC advection of
//! `phi` and of the convolved reference curvature `kappa_R tilde = delta kappa_R`, and initial
//! shapes, after Sec. 2.2 of the paper.
//!
//! ```text
//! d phi/dt + div(v H) = phi div v                              (2.41)
//! d kt/dt  + div(v G) = kt div v - kt n . grad v . n           (2.44), (2.23)
//! H_ijk = (1 + tanh(beta' (n . x + d))) / 2,  G_ijk = c |grad H_ijk|   (2.42), (2.45)
//! n = grad phi / |grad phi|,  delta = |grad phi|,  kappa = -P . grad n . P   (2.24), (2.26), (2.9)
//! ```
//!
//! - [`geometry`]: normals (several constructions, [`NormalScheme`](geometry::NormalScheme); the [`NormalEstimator`](geometry::NormalEstimator)
//!   strategy), delta, projector,
//!   curvature; per cell and per field. Its docs state the sign conventions of the crate.
//! - [`mthinc`]: the reconstruction of one cell (2.42)-(2.43) and its face averages (2.48).
//! - [`convolved`]: the convolved-curvature profile (2.45)-(2.47) and the stretching term.
//! - [`advect`]: the [`Advector`](advect::Advector), one AB2 step of both fields (2.29)-(2.30), the default
//!   [`InterfaceTransport`](advect::InterfaceTransport).
//! - [`shapes`]: smoothed `phi` and `kappa_R tilde` of spheres, ellipsoids, circles, ellipses,
//!   the biconcave red-cell shape and any signed-distance function.
//!
//! A typical step of a coupled solver:
//!
//! ```
//! use eulermembrane::grid::{Grid, VectorField};
//! use eulermembrane::interface::{advect::AdvectionParams, advect::Advector, advect::Carried, shapes};
//! let g = Grid::<f64>::periodic([16, 16, 16], [0.0; 3], [1.0; 3]).unwrap();
//! let sphere = shapes::Sphere::new([0.5; 3], 0.25).unwrap();
//! let smooth = shapes::Smoothing::default();
//! let mut phi = shapes::smoothed_phi(&g, &sphere, &smooth).unwrap();
//! let mut kt = shapes::convolved_curvature(&g, &sphere, &smooth).unwrap();
//! let mut v = VectorField::from_fn(&g, |_| [1.0, 0.5, 0.0]);
//! v.fill_ghosts(&g);
//! let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
//! let before = phi.interior_sum(&g);
//! adv.step(&g, &v, 0.01, &mut phi, Some(&mut kt)).unwrap();
//! assert!((phi.interior_sum(&g) - before).abs() < 1e-12 * before);
//! ```

pub mod advect;
pub mod convolved;
pub mod geometry;
pub mod mthinc;
pub mod placement;
pub mod shapes;
