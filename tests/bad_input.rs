//! Bad input and faults: every public constructor and setter refuses invalid values with an
//! [`Error`] (never a panic), valid neighbours are accepted, a NaN appearing during a step is
//! reported with the step, the field and the cell and leaves the state as it was, and a failed
//! checkpoint write leaves the previous checkpoint intact.

use eulermembrane::diagnostics::{
    area::{AreaTracker, area_from_delta},
    energy::{EnergyBudget, EnergyState},
    modes::{ModeWeight, surface_modes},
    profile::{ProfileAxes, Span, streamwise_profile},
    taylor::{fit_ellipse, section_contour},
    volume::{centroid, volume},
};
use eulermembrane::fluid::{
    krylov::KrylovParams,
    momentum::{Coefficient, Materials},
    sor::SorParams,
    spectral::{Location, SpectralSolver},
    stepper::{FlowConfig, FlowStepper, PredictorSolver},
};
use eulermembrane::grid::{Boundary, Field, Grid, VectorField};
use eulermembrane::interface::shapes::{
    Biconcave, Circle, Ellipse, Ellipsoid, SignedDistanceFn, Smoothing, Sphere,
};
use eulermembrane::interface::{
    self,
    advect::{AdvectionParams, Advector, Carried},
    geometry::{Geometry, NormalScheme},
};
use eulermembrane::io::checkpoint::{CheckpointReader, CheckpointWriter};
use eulermembrane::io::vtk::VtiWriter;
use eulermembrane::membrane::{
    self,
    bending::BendingStress,
    law::{NeoHookean, Skalak},
};
use eulermembrane::simulation::{
    Bending, Elasticity, Phase, Scene, Settings, Simulation, StepWarning, Traction,
    effect::{Effect, Setup, StepState},
    timestep::{AdaptiveDt, TimeStepping},
};
use eulermembrane::{Error, Result};
use proptest::prelude::*;
use std::f64::consts::TAU;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// Runs `f`, failing the test if it panics.
fn no_panic<R>(what: &str, f: impl FnOnce() -> R) -> R {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(_) => panic!("{what} panicked"),
    }
}

/// Runs `f`, which must return an error (and not panic); returns the error.
fn refused<T>(what: &str, f: impl FnOnce() -> Result<T>) -> Error {
    match no_panic(what, f) {
        Ok(_) => panic!("{what} accepted an invalid input"),
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.is_empty(), "{what}: empty message");
            e
        }
    }
}

/// The name of an [`Error::InvalidParameter`] (panics on another variant).
fn param_name(e: &Error) -> &'static str {
    match e {
        Error::InvalidParameter { name, .. } => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

/// Non-finite numbers.
fn non_finite() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]
}

/// Numbers that are not finite and `> 0`.
fn not_positive() -> impl Strategy<Value = f64> {
    prop_oneof![non_finite(), -1e300..=0.0f64, Just(-0.0), Just(-f64::MIN_POSITIVE)]
}

/// Finite numbers `> 0`.
fn positive() -> impl Strategy<Value = f64> {
    prop_oneof![1e-6..1e6f64, Just(f64::MIN_POSITIVE), Just(1e300)]
}

/// Numbers outside `(0, 1)`.
fn not_unit_open() -> impl Strategy<Value = f64> {
    prop_oneof![non_finite(), -1e3..=0.0f64, 1.0..1e3f64]
}

fn box16() -> Grid<f64> {
    Grid::periodic([16; 3], [0.0; 3], [1.0; 3]).unwrap()
}

fn small() -> Grid<f64> {
    Grid::periodic([8; 3], [0.0; 3], [1.0; 3]).unwrap()
}

fn fluid() -> Phase<f64> {
    Phase::new(1.0, 1.0).unwrap()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("em_bad_input_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn grid_refuses_bad_cells_boxes_and_walls(
        few in 2usize..4,
        axis in 0usize..3,
        bad in non_finite(),
        len in -10.0..=0.0f64,
        normal_speed in prop_oneof![non_finite(), 1e-9..1e3f64, -1e3..-1e-9f64],
        huge in prop_oneof![Just(usize::MAX), Just(usize::MAX - 6), (1usize << 53)..usize::MAX],
    ) {
        let grid = |cells: [usize; 3], lower: [f64; 3], upper: [f64; 3], bc| {
            no_panic("Grid::new", || Grid::<f64>::new(cells, lower, upper, bc))
        };
        let per = [[Boundary::Periodic; 2]; 3];
        let mut cells = [8; 3];
        cells[axis] = few;
        let e = refused("Grid::new", || grid(cells, [0.0; 3], [1.0; 3], per));
        prop_assert_eq!(param_name(&e), ["cells[0]", "cells[1]", "cells[2]"][axis]);
        // One cell is allowed on a periodic axis only.
        cells[axis] = 1;
        prop_assert!(grid(cells, [0.0; 3], [1.0; 3], per).is_ok());
        let mut walls = per;
        walls[axis] = [Boundary::wall(); 2];
        refused("Grid::new", || grid(cells, [0.0; 3], [1.0; 3], walls));
        cells[axis] = 0;
        refused("Grid::new", || grid(cells, [0.0; 3], [1.0; 3], per));
        // Boxes.
        let mut lower = [0.0; 3];
        lower[axis] = bad;
        refused("Grid::new", || grid([8; 3], lower, [1.0; 3], per));
        let mut upper = [1.0; 3];
        upper[axis] = bad;
        refused("Grid::new", || grid([8; 3], [0.0; 3], upper, per));
        upper[axis] = len;
        refused("Grid::new", || grid([8; 3], [0.0; 3], upper, per));
        // A box so small that the spacing underflows to zero.
        upper[axis] = f64::from_bits(1);
        refused("Grid::new", || grid([8; 3], [0.0; 3], upper, per));
        // A wall with a normal velocity, or a non-finite one; a periodic side paired with a wall.
        let mut v = [0.0; 3];
        v[axis] = normal_speed;
        walls[axis] = [Boundary::Wall { velocity: v }, Boundary::wall()];
        refused("Grid::new", || grid([8; 3], [0.0; 3], [1.0; 3], walls));
        walls[axis] = [Boundary::Periodic, Boundary::wall()];
        refused("Grid::new", || grid([8; 3], [0.0; 3], [1.0; 3], walls));
        // So many cells that the storage cannot be addressed.
        let mut cells = [8; 3];
        cells[axis] = huge;
        refused("Grid::new", || grid(cells, [0.0; 3], [1.0; 3], per));
        cells = [huge.min(1 << 21); 3];
        refused("Grid::new", || grid(cells, [0.0; 3], [1.0; 3], per));
        // A tangential wall velocity is fine.
        let mut v = [1.0; 3];
        v[axis] = 0.0;
        walls[axis] = [Boundary::Wall { velocity: v }, Boundary::wall()];
        prop_assert!(grid([8; 3], [0.0; 3], [1.0; 3], walls).is_ok());
    }

    #[test]
    fn materials_laws_and_moduli_must_be_finite_and_positive(bad in not_positive(), good in positive()) {
        prop_assert_eq!(param_name(&refused("Phase::new", || Phase::new(bad, good))), "rho");
        prop_assert_eq!(param_name(&refused("Phase::new", || Phase::new(good, bad))), "mu");
        prop_assert!(Phase::new(good, good).is_ok());
        refused("Materials::uniform", || Materials::uniform(bad, good));
        refused("Materials::uniform", || Materials::uniform(good, bad));
        prop_assert_eq!(param_name(&refused("NeoHookean::new", || NeoHookean::new(bad))), "es");
        prop_assert!(NeoHookean::new(good).is_ok());
        prop_assert_eq!(param_name(&refused("Skalak::new", || Skalak::new(bad, 1.0))), "es");
        prop_assert!(Skalak::new(good, 0.0).is_ok());
        let g = small();
        prop_assert_eq!(param_name(&refused("BendingStress::new", || BendingStress::new(&g, bad))), "eb");
        prop_assert!(BendingStress::new(&g, good).is_ok());
        refused("AreaTracker::new", || AreaTracker::new(bad));
        prop_assert!(AreaTracker::new(good).is_ok());
        // Material fields: a non-positive value, or a field of another grid.
        let mut f = Field::zeros(&g);
        f.fill(good);
        f.values_mut()[g.idx_u(3, 4, 5)] = bad;
        let m = Materials { rho: Coefficient::Field(f), mu: Coefficient::Uniform(1.0) };
        refused("FlowStepper::new", || FlowStepper::new(&g, m, FlowConfig::default()));
        let other = Field::zeros(&box16());
        let m = Materials { rho: Coefficient::Uniform(1.0), mu: Coefficient::Field(other.clone()) };
        refused("FlowStepper::new", || FlowStepper::new(&g, m, FlowConfig::default()));
        let mut s = FlowStepper::new(&g, Materials::uniform(1.0, 1.0).unwrap(), FlowConfig::default()).unwrap();
        let m = Materials { rho: Coefficient::Field(other.clone()), mu: Coefficient::Uniform(1.0) };
        refused("FlowStepper::set_materials", || s.set_materials(m));
        prop_assert_eq!(s.materials(), &Materials::uniform(1.0, 1.0).unwrap());
        refused("Materials::mixture", || Materials::mixture(&g, &other, (1.0, 1.0), (2.0, 2.0)));
        refused("Materials::mixture", || Materials::mixture(&g, &Field::zeros(&g), (bad, 1.0), (2.0, 2.0)));
        prop_assert!(Materials::mixture(&g, &Field::zeros(&g), (good, 1.0), (2.0, good)).is_ok());
    }

    #[test]
    fn skalak_alpha_must_be_finite_and_non_negative(
        alpha in prop_oneof![non_finite(), -1e6..-1e-12f64],
        good in prop_oneof![Just(0.0), 1e-6..1e6f64],
    ) {
        prop_assert_eq!(param_name(&refused("Skalak::new", || Skalak::new(1.0, alpha))), "alpha");
        prop_assert!(Skalak::new(1.0, good).is_ok());
    }

    #[test]
    fn shapes_need_finite_centres_and_positive_sizes(
        bad in not_positive(),
        nf in non_finite(),
        good in positive(),
        d in 0usize..3,
        axis in 3usize..1000,
        dim in prop_oneof![0usize..2, 4usize..100],
    ) {
        let mut c = [0.5; 3];
        c[d] = nf;
        refused("Sphere::new", || Sphere::new(c, 0.25));
        refused("Sphere::new", || Sphere::new([0.5; 3], bad));
        prop_assert!(Sphere::new([0.5; 3], good).is_ok());
        refused("Circle::new", || Circle::new([c[d], 0.5], 0.25));
        refused("Circle::new", || Circle::new([0.5; 2], bad));
        let mut axes = [0.3; 3];
        axes[d] = bad;
        refused("Ellipsoid::new", || Ellipsoid::new([0.5; 3], axes));
        refused("Ellipsoid::new", || Ellipsoid::new(c, [0.3; 3]));
        refused("Ellipse::new", || Ellipse::new([0.5; 2], [axes[d], 0.2]));
        refused("Biconcave::new", || Biconcave::new([0.5; 3], bad));
        refused("Biconcave::new", || Biconcave::new(c, 0.3));
        refused("Biconcave::with_coefficients", || {
            Biconcave::with_coefficients([0.5; 3], 0.3, axis, [0.35, 2.003, -1.123])
        });
        let mut coef = [0.35, 2.003, -1.123];
        coef[d] = nf;
        refused("Biconcave::with_coefficients", || Biconcave::with_coefficients([0.5; 3], 0.3, 0, coef));
        // Zero thickness somewhere on [0, 1].
        refused("Biconcave::with_coefficients", || {
            Biconcave::with_coefficients([0.5; 3], 0.3, 0, [-good, 0.0, 0.0])
        });
        let sd = |x: [f64; 3]| 0.25 - x[0].hypot(x[1]);
        refused("SignedDistanceFn::new", || SignedDistanceFn::new(dim, sd));
        refused("SignedDistanceFn::with_step", || SignedDistanceFn::new(2, sd).unwrap().with_step(bad));
        refused("SignedDistanceFn::with_center", || SignedDistanceFn::new(3, sd).unwrap().with_center(c));
        prop_assert!(SignedDistanceFn::new(2, sd).unwrap().with_step(1e-4).unwrap().with_center([0.0; 3]).is_ok());
    }

    #[test]
    fn thresholds_and_sharpness_outside_their_ranges(
        eps in not_unit_open(),
        ok_eps in 1e-6..0.999f64,
        beta in prop_oneof![non_finite(), -10.0..=0.0f64, 10.0001..1e6f64],
        tiny in prop_oneof![non_finite(), -1.0..-1e-300f64, 0.5..10.0f64],
        lo in -1.0..2.0f64,
        width in prop_oneof![-1.0..=0.0f64, non_finite()],
    ) {
        let g = small();
        prop_assert_eq!(param_name(&refused("membrane::band::Band::new", || membrane::band::Band::new(&g, eps))), "epsilon");
        prop_assert!(membrane::band::Band::new(&g, ok_eps).is_ok());
        refused("interface::geometry::PhiRange::new", || interface::geometry::PhiRange::new(lo, lo + width));
        refused("interface::geometry::PhiRange::new", || interface::geometry::PhiRange::new(-lo.abs() - 1e-3, 0.5));
        refused("interface::geometry::PhiRange::new", || interface::geometry::PhiRange::new(0.5, 1.0 + lo.abs() + 1e-3));
        prop_assert!(interface::geometry::PhiRange::new(0.0, 1.0).is_ok());
        let params = AdvectionParams { beta, ..AdvectionParams::default() };
        refused("Advector::new", || Advector::new(&g, params, Carried::PhiAndCurvature));
        let params = AdvectionParams { tiny, ..AdvectionParams::default() };
        refused("Advector::new", || Advector::new(&g, params, Carried::Phi));
        let params = AdvectionParams { normals: NormalScheme::Deconvolved, ..AdvectionParams::default() };
        refused("Advector::new", || Advector::new(&g, params, Carried::Phi));
        let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
        let (n, mut rhs) = (g.len(), vec![0.0; g.len()]);
        refused("Advector::restore_history", || adv.restore_history(beta.min(0.0), &rhs, &rhs));
        refused("Advector::restore_history", || adv.restore_history(1e-3, &rhs[..n - 1], &rhs));
        rhs[n / 2] = tiny.max(0.5) * f64::INFINITY;
        refused("Advector::restore_history", || adv.restore_history(1e-3, &vec![0.0; n], &rhs));
        prop_assert!(adv.history().is_none());
        refused("Geometry::with_beta", || Geometry::new(&g, NormalScheme::Atanh4).with_beta(beta));
        refused("NormalScheme::from_name", || NormalScheme::from_name("sideways"));
    }

    #[test]
    fn solver_settings_outside_their_ranges(
        tol in prop_oneof![non_finite(), -1.0..=0.0f64, 1.0..10.0f64],
        omega in prop_oneof![non_finite(), -1.0..=0.0f64, 2.0..10.0f64],
        axis in 3usize..1000,
    ) {
        let g = small();
        let m = || Materials::uniform(1.0, 1.0).unwrap();
        let k = KrylovParams { tolerance: tol, max_iterations: 10 };
        let cfg = FlowConfig { predictor: PredictorSolver::Krylov(k), ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        let cfg = FlowConfig { poisson: k, ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        let k = KrylovParams { tolerance: 1e-8, max_iterations: 0 };
        let cfg = FlowConfig { predictor: PredictorSolver::Krylov(k), ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        let s = SorParams { omega, ..SorParams::default() };
        let cfg = FlowConfig { predictor: PredictorSolver::Sor(s), ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        let s = SorParams { tolerance: tol.min(0.0), ..SorParams::default() };
        let cfg = FlowConfig { predictor: PredictorSolver::Sor(s), ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        let s = SorParams { max_sweeps: 0, ..SorParams::default() };
        let cfg = FlowConfig { predictor: PredictorSolver::Sor(s), ..FlowConfig::default() };
        refused("FlowStepper::new", || FlowStepper::new(&g, m(), cfg));
        refused("SpectralSolver::new", || SpectralSolver::new(&g, Location::Velocity(axis)));
        // Two wall axes: the direct solvers refuse.
        let w = [[Boundary::wall(); 2], [Boundary::wall(); 2], [Boundary::Periodic; 2]];
        let gw = Grid::new([8; 3], [0.0; 3], [1.0; 3], w).unwrap();
        refused("FlowStepper::new", || FlowStepper::new(&gw, m(), FlowConfig::default()));
    }

    #[test]
    fn non_finite_initial_fields_are_refused_and_change_nothing(
        nf in non_finite(),
        cell in (0usize..8, 0usize..8, 0usize..8),
        comp in 0usize..3,
    ) {
        let g = small();
        let at = move |x: [f64; 3]| {
            let h = 1.0 / 8.0;
            (x[0] / h) as usize == cell.0 && (x[1] / h - 0.5).round() as usize == cell.1
                && (x[2] / h - 0.5).round() as usize == cell.2
        };
        let mut s = FlowStepper::new(&g, Materials::uniform(1.0, 1.0).unwrap(), FlowConfig::default()).unwrap();
        s.set_velocity(|x| [x[1], 0.0, 0.0]).unwrap();
        let before = s.velocity().clone();
        let e = refused("FlowStepper::set_velocity", || {
            s.set_velocity(|x| {
                let mut v = [x[1], 0.0, 0.0];
                if at(x) {
                    v[comp] = nf;
                }
                v
            })
        });
        prop_assert!(matches!(e, Error::NonFinite { .. }), "{}", e);
        prop_assert_eq!(s.velocity(), &before);
        let e = refused("FlowStepper::set_pressure", || s.set_pressure(|_| nf));
        prop_assert!(matches!(e, Error::NonFinite { field: "pressure", cell: [0, 0, 0] }), "{}", e);
        prop_assert!(s.pressure().values().iter().all(|&p| p == 0.0));
    }

    #[test]
    fn scenes_refuse_bad_effects_and_settings(
        bad in not_positive(),
        nf in non_finite(),
        eps in not_unit_open(),
        d in 0usize..3,
        points in prop_oneof![Just(0usize), 17usize..1000],
    ) {
        let scene = || Scene::new(box16(), fluid()).capsule(Sphere::new([0.5; 3], 0.25).unwrap());
        let build = |s: Scene<f64>| no_panic("Scene::build", || s.build().map(|_| ()));
        prop_assert_eq!(param_name(&refused("Scene::bending", || build(scene().bending(bad)))), "eb");
        let mut f = [0.0; 3];
        f[d] = nf;
        refused("Scene::body_force", || build(scene().body_force(f)));
        // Phases given as struct literals bypass Phase::new: build checks them.
        refused("Scene::new", || build(Scene::new(box16(), Phase { rho: bad, mu: 1.0 })));
        refused("Scene::inside", || build(scene().inside(Phase { rho: 1.0, mu: bad })));
        let s = Settings { epsilon: eps, ..Settings::default() };
        prop_assert_eq!(param_name(&refused("Scene::settings", || build(scene().settings(s)))), "epsilon");
        let s = Settings { smoothing: Smoothing { beta: bad, ..Smoothing::default() }, ..Settings::default() };
        refused("Scene::settings", || build(scene().settings(s)));
        let s = Settings { smoothing: Smoothing { points, ..Smoothing::default() }, ..Settings::default() };
        refused("Scene::settings", || build(scene().settings(s)));
        let mut s = Settings::default();
        s.advection.beta = bad;
        refused("Scene::settings", || build(scene().settings(s)));
        s = Settings::default();
        s.flow.poisson.tolerance = bad;
        refused("Scene::settings", || build(scene().settings(s)));
        // A capsule outside the box, through a wall; a 2D capsule on a 3D grid.
        let w = [[Boundary::Periodic; 2], [Boundary::Periodic; 2], [Boundary::wall(); 2]];
        let gw = Grid::new([16; 3], [0.0; 3], [1.0; 3], w).unwrap();
        let near_wall = Scene::new(gw, fluid()).capsule(Sphere::new([0.5, 0.5, 0.9], 0.25).unwrap());
        refused("Scene::capsule", || build(near_wall));
        refused("Scene::capsule", || build(scene().capsule(Circle::new([0.5; 2], 0.2).unwrap())));
        // The valid neighbour.
        prop_assert!(build(scene().bending(1e-3).elasticity(NeoHookean::new(1.0).unwrap())).is_ok());
    }
}

proptest! {
    // Each case builds a simulation: fewer cases.
    #![proptest_config(ProptestConfig::with_cases(8))]

    #[test]
    fn simulation_setters_refuse_bad_values_and_keep_the_state(
        bad in not_positive(),
        c in 1usize..100,
        nf in non_finite(),
    ) {
        let g = Grid::periodic([12; 3], [0.0; 3], [1.0; 3]).unwrap();
        let mut sim = Scene::new(g, fluid())
            .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
            .elasticity(NeoHookean::new(1.0).unwrap())
            .build()
            .unwrap();
        let time = sim.time();
        prop_assert_eq!(param_name(&refused("Simulation::step", || sim.step(bad))), "dt");
        prop_assert_eq!(param_name(&refused("Simulation::prestretch", || sim.prestretch(0, bad))), "lambda");
        refused("Simulation::prestretch", || sim.prestretch(c, 1.1));
        refused("Simulation::phi", || sim.phi(c).map(|_| ()));
        refused("Simulation::set_velocity", || sim.set_velocity(|_| [nf, 0.0, 0.0]));
        prop_assert_eq!(sim.time(), time);
        prop_assert_eq!(sim.steps(), 0);
        prop_assert!(sim.velocity().c.iter().all(|f| f.values().iter().all(|&x| x == 0.0)));
        prop_assert!(sim.prestretch(0, 1.05).is_ok());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn diagnostics_refuse_fields_of_another_grid_and_bad_points(
        nf in non_finite(),
        n_max in 65usize..10_000,
        axis in 3usize..1000,
        outside in prop_oneof![-1e3..-1e-3f64, 1.001..1e3f64],
    ) {
        let g = small();
        let other = Field::zeros(&box16());
        refused("volume", || volume(&g, &other));
        refused("centroid", || centroid(&g, &other));
        refused("area_from_delta", || area_from_delta(&g, &other));
        refused("AreaTracker::from_delta", || AreaTracker::from_delta(&g, &other));
        let delta = Field::zeros(&g);
        refused("surface_modes", || surface_modes(&g, &delta, [0.5; 3], n_max, ModeWeight::Area));
        refused("surface_modes", || surface_modes(&g, &delta, [nf, 0.5, 0.5], 4, ModeWeight::Area));
        refused("surface_modes", || surface_modes(&g, &other, [0.5; 3], 4, ModeWeight::Radius));
        refused("section_contour", || section_contour(&g, &delta, [0.5; 3], axis, 0.5));
        refused("section_contour", || section_contour(&g, &delta, [0.5; 3], 2, nf));
        let v = VectorField::zeros(&g);
        let axes = ProfileAxes { streamwise: 0, wall_normal: 1 };
        refused("streamwise_profile", || streamwise_profile(&g, &v, axes, &[outside], Span::Average));
        refused("streamwise_profile", || streamwise_profile(&g, &v, axes, &[nf], Span::Average));
        let same = ProfileAxes { streamwise: axis % 3, wall_normal: axis % 3 };
        refused("streamwise_profile", || streamwise_profile(&g, &v, same, &[0.5], Span::Average));
        refused("streamwise_profile", || streamwise_profile(&g, &VectorField::zeros(&box16()), axes, &[0.5], Span::Average));
        prop_assert!(streamwise_profile(&g, &v, axes, &[0.5], Span::Average).is_ok());
    }

    #[test]
    fn random_bytes_are_never_a_checkpoint(bytes in proptest::collection::vec(any::<u8>(), 0..512), cut in 0usize..10_000) {
        refused("CheckpointReader::from_bytes", || CheckpointReader::from_bytes(&bytes, "random"));
        // A valid header followed by garbage, and a cut valid file.
        let mut w = CheckpointWriter::new();
        w.array("a", &[1.0f64, 2.0]).number("n", 3.0);
        let good = w.to_bytes();
        let mut b = good[..16].to_vec();
        b.extend_from_slice(&bytes);
        refused("CheckpointReader::from_bytes", || CheckpointReader::from_bytes(&b, "random"));
        let cut = cut % good.len();
        refused("CheckpointReader::from_bytes", || CheckpointReader::from_bytes(&good[..cut], "cut"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn loadings_budgets_and_fits_refuse_non_finite_values(
        bad in not_positive(),
        nf in non_finite(),
        k in 0usize..5,
        dt in not_positive(),
    ) {
        let law = NeoHookean::new(1.0).unwrap();
        prop_assert_eq!(param_name(&refused("uniaxial_tension", || membrane::loading::uniaxial_tension(&law, bad))), "lambda1");
        prop_assert_eq!(param_name(&refused("equibiaxial_tension", || membrane::loading::equibiaxial_tension(&law, bad))), "lambda");
        refused("equibiaxial_stretch", || membrane::loading::equibiaxial_stretch(&law, nf));
        let mut budget = EnergyBudget::new();
        let ok = EnergyState { time: 0.0, kinetic: 1.0, elastic: 0.0, dissipation_rate: 0.0, body_power: 0.0, integrals: None };
        budget.record(ok).unwrap();
        let mut vals = [1.0, 1.0, 0.0, 0.0, 0.0];
        vals[k] = nf;
        let st = EnergyState { time: vals[0], kinetic: vals[1], elastic: vals[2], dissipation_rate: vals[3], body_power: vals[4], integrals: None };
        refused("EnergyBudget::record", || budget.record(st));
        refused("EnergyBudget::record", || budget.record(ok));
        prop_assert_eq!(budget.samples().len(), 1);
        let mut pts: Vec<[f64; 2]> =
            (0..12).map(|i| { let t = i as f64 * std::f64::consts::FRAC_PI_6; [2.0 * t.cos(), t.sin()] }).collect();
        prop_assert!(fit_ellipse(&pts).is_ok());
        pts[k][k % 2] = nf;
        refused("fit_ellipse", || fit_ellipse(&pts));
        let g = small();
        let delta = Field::zeros(&g);
        let normals = [Field::zeros(&g), Field::zeros(&g), Field::zeros(&g)];
        let mut area = AreaTracker::new(1.0).unwrap();
        refused("AreaTracker::step", || area.step(&g, &delta, &normals, &VectorField::zeros(&g), dt));
        prop_assert_eq!(area.steps(), 0);
    }

    #[test]
    fn snapshots_refuse_fields_of_another_grid(n in prop_oneof![4usize..8, 9usize..12]) {
        let dir = temp_dir("vti");
        let g = small();
        let other = Grid::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let mut w = VtiWriter::new(&g);
        no_panic("VtiWriter::scalar", || w.scalar("phi", &Field::zeros(&other)).vector("v", &VectorField::zeros(&other)));
        prop_assert_eq!(param_name(&refused("VtiWriter::write", || w.write(dir.join("a.vti")))), "VtiWriter field");
        prop_assert!(!dir.join("a.vti").exists());
        let mut w = VtiWriter::new(&g);
        w.scalar("phi", &Field::zeros(&g));
        prop_assert!(w.write(dir.join("b.vti")).is_ok());
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn a_shape_with_a_nan_distance_is_refused_by_build() {
    let nan_inside = SignedDistanceFn::new(3, |x: [f64; 3]| {
        let d = 0.25 - ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
        if x[0] > 0.7 { f64::NAN } else { d }
    })
    .unwrap()
    .with_center([0.5; 3])
    .unwrap();
    let e = refused("Scene::build", || Scene::new(box16(), fluid()).capsule(nan_inside).build().map(|_| ()));
    assert!(e.to_string().contains("phi") || e.to_string().contains("non-finite"), "{e}");
}

/// A scene whose surface force turns NaN at `t >= t_bad` in the cells with `x > 0.6`.
fn poisoned_scene(t_bad: f64) -> Simulation<f64> {
    let mut sim = Scene::new(box16(), fluid())
        .inside(Phase::new(1.0, 2.0).unwrap())
        .capsule(Sphere::new([0.5; 3], 0.25).unwrap())
        // The smoothed traction keeps the NaN in the load's component (`force.v`); a sharp
        // one spreads it through the membrane map into every component.
        .effect(Elasticity::new(Skalak::new(1.0, 1.0).unwrap()).traction(Traction::Smoothed))
        .bending(1e-3)
        .surface_force(move |x, t| {
            if t >= t_bad && x[0] > 0.6 { [0.0, f64::NAN, 0.0] } else { [0.0, 0.0, -(x[2] - 0.5).signum()] }
        })
        .build()
        .unwrap();
    sim.set_velocity(|x| [0.1 * (TAU * x[1]).sin(), 0.0, 0.05 * (TAU * x[0]).cos()]).unwrap();
    sim
}

/// Bit patterns of everything a step changes.
fn snapshot(sim: &Simulation<f64>) -> Vec<u64> {
    let mut s = vec![sim.time().to_bits(), sim.steps() as u64];
    let mut add = |f: &Field<f64>| s.extend(f.values().iter().map(|x| x.to_bits()));
    for d in 0..3 {
        add(&sim.velocity().c[d]);
    }
    add(sim.pressure());
    add(sim.phi(0).unwrap());
    add(sim.kappa_r_tilde(0).unwrap().unwrap());
    for c in &sim.gs(0).unwrap().unwrap().c {
        add(c);
    }
    add(sim.delta(0).unwrap());
    for m in [&sim.flow().materials().rho, &sim.flow().materials().mu] {
        if let Coefficient::Field(f) = m {
            add(f);
        }
    }
    s
}

#[test]
fn a_nan_during_a_step_is_reported_with_step_field_and_cell_and_rolled_back() {
    let dt = 2e-3;
    let mut sim = poisoned_scene(2.5 * dt);
    for _ in 0..3 {
        sim.step(dt).unwrap();
    }
    let before = snapshot(&sim);
    let e = sim.step(dt).unwrap_err();
    let Error::Step { step, time, dt: tried, source } = &e else { panic!("expected Error::Step, got {e:?}") };
    assert_eq!((*step, *tried), (4, dt));
    assert_eq!(*time, sim.time());
    let Error::NonFinite { field, cell } = **source else { panic!("expected NonFinite, got {source:?}") };
    assert_eq!(field, "force.v", "{e}");
    let x = sim.grid().cell_center(cell[0] as isize + 3, cell[1] as isize + 3, cell[2] as isize + 3);
    assert!(x[0] > 0.5, "cell {cell:?} at {x:?} is not where the force is NaN");
    let msg = e.to_string();
    assert!(msg.contains("step 4") && msg.contains("force.v") && msg.contains(&format!("{cell:?}")), "{msg}");
    assert_eq!(std::error::Error::source(&e).map(|s| s.to_string()), Some(source.to_string()));
    let after = snapshot(&sim);
    let n = sim.grid().len();
    let diff: Vec<usize> = (0..after.len())
        .filter(|&i| after[i] != before[i])
        .map(|i| if i < 2 { i } else { 2 + (i - 2) / n })
        .collect();
    assert!(
        after == before,
        "the failed step changed the state: {:?}",
        diff.iter().collect::<std::collections::BTreeSet<_>>()
    );
    // It fails again the same way: nothing was half-committed.
    assert_eq!(sim.step(dt).unwrap_err(), e);
    assert!(snapshot(&sim) == before);
}

/// Writes `sim`'s checkpoint to `path`, and returns the bytes.
fn checkpoint_bytes(sim: &Simulation<f64>, path: &Path) -> Vec<u8> {
    sim.checkpoint(path).unwrap();
    std::fs::read(path).unwrap()
}

fn small_sim() -> Simulation<f64> {
    let g = Grid::periodic([12; 3], [0.0; 3], [1.0; 3]).unwrap();
    let mut sim = Scene::new(g, fluid())
        .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
        .effect(Elasticity::new(NeoHookean::new(1.0).unwrap()).traction(Traction::Smoothed))
        .build()
        .unwrap();
    sim.set_velocity(|x| [0.1 * (TAU * x[1]).sin(), 0.0, 0.0]).unwrap();
    sim
}

#[test]
fn a_failed_checkpoint_leaves_the_previous_one_intact() {
    let dir = temp_dir("ckpt");
    let path = dir.join("state.ckpt");
    let mut sim = small_sim();
    sim.step(1e-3).unwrap();
    let old = checkpoint_bytes(&sim, &path);
    sim.step(1e-3).unwrap();

    // The target is a folder: refused, nothing written.
    let folder = dir.join("folder.ckpt");
    std::fs::create_dir_all(folder.join("inside")).unwrap();
    match sim.checkpoint(&folder) {
        Err(Error::Io { path, .. }) => assert!(path.ends_with("folder.ckpt"), "{path}"),
        other => panic!("expected Error::Io, got {other:?}"),
    }
    assert!(folder.join("inside").is_dir());
    // A parent that is a regular file (fails even for root).
    let under_file = path.join("nested.ckpt");
    assert!(matches!(sim.checkpoint(&under_file), Err(Error::Io { .. })));
    assert_eq!(std::fs::read(&path).unwrap(), old, "the previous checkpoint changed");

    // A folder without write permission (not a restriction for root: then skipped).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let locked = dir.join("locked");
        std::fs::create_dir_all(&locked).unwrap();
        let target = locked.join("state.ckpt");
        checkpoint_bytes(&sim, &target);
        let kept = std::fs::read(&target).unwrap();
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
        if std::fs::write(locked.join("probe"), b"x").is_err() {
            sim.step(1e-3).unwrap();
            match sim.checkpoint(&target) {
                Err(Error::Io { path, .. }) => assert!(path.ends_with("state.ckpt"), "{path}"),
                other => panic!("expected Error::Io, got {other:?}"),
            }
            assert_eq!(std::fs::read(&target).unwrap(), kept, "the locked checkpoint changed");
        }
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::fs::remove_dir_all(&locked).unwrap();
    }
    // No temporary files are left behind.
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    assert_eq!(names, ["folder.ckpt", "state.ckpt"]);

    // The old checkpoint still restores, to the state after one step.
    let mut back = small_sim();
    back.restore(&path).unwrap();
    assert_eq!(back.steps(), 1);
    // And a successful overwrite replaces it.
    let new = checkpoint_bytes(&sim, &path);
    assert_ne!(new, old);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_truncated_or_corrupted_checkpoint_is_refused_and_changes_nothing() {
    let dir = temp_dir("corrupt");
    let path = dir.join("state.ckpt");
    let mut sim = small_sim();
    sim.step(1e-3).unwrap();
    let good = checkpoint_bytes(&sim, &path);
    let mut target = small_sim();
    let before = (target.time(), target.velocity().clone(), target.phi(0).unwrap().clone());
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated", good[..good.len() / 2].to_vec()),
        ("one byte short", good[..good.len() - 1].to_vec()),
        ("bit flip", {
            let mut b = good.clone();
            b[good.len() / 3] ^= 0x10;
            b
        }),
        ("empty", Vec::new()),
    ];
    for (what, bytes) in cases {
        std::fs::write(&path, &bytes).unwrap();
        match target.restore(&path) {
            Err(Error::Io { path: p, message }) => {
                assert!(p.ends_with("state.ckpt"), "{what}: {p}");
                assert!(message.contains("not a checkpoint"), "{what}: {message}");
            }
            other => panic!("{what}: expected Error::Io, got {other:?}"),
        }
        assert_eq!(target.time(), before.0, "{what}");
        assert!(target.velocity() == &before.1 && target.phi(0).unwrap() == &before.2, "{what}");
    }
    std::fs::write(&path, &good).unwrap();
    target.restore(&path).unwrap();
    assert_eq!(target.steps(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

/// A user effect with the time-step limit that `limit` holds (as `f64` bits; `u64::MAX`: none),
/// which the test may change after the build.
struct Limited(std::sync::Arc<std::sync::atomic::AtomicU64>);

impl Effect<f64> for Limited {
    fn name(&self) -> &str {
        "limited"
    }
    fn dt_limit(&self, _: &Setup<'_, f64>) -> Option<f64> {
        let bits = self.0.load(std::sync::atomic::Ordering::Relaxed);
        (bits != u64::MAX).then(|| f64::from_bits(bits))
    }
    fn add_force(
        &self,
        _: &StepState<'_, f64>,
        _: &VectorField<f64>,
        _: &mut VectorField<f64>,
    ) -> Result<()> {
        Ok(())
    }
}

/// An effect's limit that is not finite and `> 0` is refused by `build`, by a step (which then
/// changes nothing) and by `AdaptiveDt`, each naming `dt_limit` and the effect.
#[test]
fn an_effects_invalid_dt_limit_is_refused_naming_the_effect() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicU64, Ordering};
    let names_the_effect = |e: &Error| match e {
        Error::InvalidParameter { name: "dt_limit", value, .. } => value.contains("`limited`"),
        _ => false,
    };
    let scene = |limit: &Arc<AtomicU64>| {
        Scene::new(small(), fluid())
            .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
            .effect(Limited(limit.clone()))
    };
    for bad in [f64::NAN, 0.0, -1.0, f64::INFINITY] {
        let e = refused("Scene::build", || scene(&Arc::new(AtomicU64::new(bad.to_bits()))).build());
        assert!(names_the_effect(&e), "{bad}: {e}");
        assert!(e.to_string().contains("limited"), "{e}");
    }
    // A limit that turns bad during the run: the step fails and leaves the state as it was...
    let limit = Arc::new(AtomicU64::new(1.0f64.to_bits()));
    let mut sim = scene(&limit).build().unwrap();
    sim.step(1e-3).unwrap();
    limit.store(0.0f64.to_bits(), Ordering::Relaxed);
    let e = refused("Simulation::step", || sim.step(1e-3));
    match &e {
        Error::Step { source, .. } => assert!(names_the_effect(source), "{e}"),
        other => panic!("expected Error::Step, got {other:?}"),
    }
    assert_eq!(sim.steps(), 1);
    // ...and AdaptiveDt names the effect instead of a step of 0.
    let mut stepping = AdaptiveDt::new(0.01).unwrap();
    let e = refused("AdaptiveDt::advance", || stepping.advance(&mut sim, 1.0));
    assert!(names_the_effect(&e), "{e}");
    // No limit is fine.
    limit.store(u64::MAX, Ordering::Relaxed);
    assert_eq!(sim.membrane_dt_limit(), f64::INFINITY);
    sim.step(1e-3).unwrap();
}

/// Two elasticities or two bendings on one capsule would add their forces: `build` refuses
/// them, naming the effect and the capsule; one per capsule is fine.
#[test]
fn two_elasticities_or_bendings_on_one_capsule_are_refused() {
    let nh = || NeoHookean::new(1.0).unwrap();
    let two = || {
        Scene::new(box16(), fluid())
            .capsule(Sphere::new([0.3, 0.5, 0.5], 0.15).unwrap())
            .capsule(Sphere::new([0.7, 0.5, 0.5], 0.15).unwrap())
    };
    let e = refused("Scene::build", || two().elasticity(nh()).elasticity(nh()).build());
    assert_eq!(param_name(&e), "elasticity");
    assert!(e.to_string().contains("capsule 0"), "{e}");
    let e = refused("Scene::build", || {
        two().elasticity(nh()).effect(Elasticity::new(Skalak::new(1.0, 2.0).unwrap()).only([1])).build()
    });
    assert_eq!(param_name(&e), "elasticity");
    assert!(e.to_string().contains("capsule 1"), "{e}");
    let e =
        refused("Scene::build", || two().bending(1e-3).effect(Bending::new(2e-3).unwrap().only([1])).build());
    assert_eq!(param_name(&e), "bending");
    assert!(e.to_string().contains("capsule 1"), "{e}");
    // A law and a modulus per capsule.
    two()
        .effect(Elasticity::new(nh()).only([0]))
        .effect(Elasticity::new(Skalak::new(1.0, 2.0).unwrap()).only([1]))
        .effect(Bending::new(1e-3).unwrap().only([0]))
        .effect(Bending::new(2e-3).unwrap().only([1]))
        .build()
        .unwrap();
}

/// The entries of a checkpoint file (its format: `io::checkpoint`).
fn checkpoint_entries(bytes: &[u8]) -> Vec<(String, Vec<f64>)> {
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let (count, mut at) = (word(8), 16);
    (0..count)
        .map(|_| {
            let len = word(at);
            let name = String::from_utf8(bytes[at + 8..at + 8 + len].to_vec()).unwrap();
            at += 8 + len;
            let n = word(at);
            let values = (0..n).map(|k| f64::from_bits(word(at + 8 + 8 * k) as u64)).collect();
            at += 8 + 8 * n;
            (name, values)
        })
        .collect()
}

/// The traction is part of the physics a checkpoint records: a smoothed-traction checkpoint is
/// refused by a sharp-traction scene, with both physics lines in the message; so is a
/// checkpoint that predates the record, saying so.
#[test]
fn a_checkpoint_of_another_traction_is_refused_showing_both_physics() {
    let dir = temp_dir("traction");
    let path = dir.join("state.ckpt");
    let mut sim = small_sim();
    sim.step(1e-3).unwrap();
    let bytes = checkpoint_bytes(&sim, &path);
    let sharp = || {
        Scene::new(Grid::periodic([12; 3], [0.0; 3], [1.0; 3]).unwrap(), fluid())
            .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
            .effect(Elasticity::new(NeoHookean::new(1.0).unwrap()).traction(Traction::Sharp))
            .build()
            .unwrap()
    };
    let mut target = sharp();
    let e = refused("Simulation::restore", || target.restore(&path));
    assert_eq!(param_name(&e), "checkpoint physics");
    let msg = e.to_string();
    assert!(msg.contains("traction=smoothed") && msg.contains("traction=sharp"), "{msg}");
    assert_eq!(target.steps(), 0);
    // A checkpoint written before the traction was recorded.
    let mut w = CheckpointWriter::new();
    for (name, values) in checkpoint_entries(&bytes) {
        match name.as_str() {
            "physics" => w.text("physics", &sim.physics().replace("; traction=smoothed", "")),
            _ => w.array(&name, &values),
        };
    }
    w.save(&path).unwrap();
    let e = refused("Simulation::restore", || small_sim().restore(&path));
    assert_eq!(param_name(&e), "checkpoint physics");
    assert!(e.to_string().contains("before checkpoints recorded the traction"), "{e}");
    // The same file with the traction restores.
    std::fs::write(&path, &bytes).unwrap();
    small_sim().restore(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
}

/// A step whose Courant number exceeds 1 is taken, and its report says so.
#[test]
fn a_step_above_a_courant_number_of_one_is_reported() {
    let mut sim = small_sim();
    sim.set_velocity(|_| [1.0, 0.0, 0.0]).unwrap();
    // h = 1/12: a Courant number of 0.3, then 1.56.
    let r = sim.step(0.3 / 12.0).unwrap();
    assert_eq!(r.warning, None);
    let r = sim.step(1.56 / 12.0).unwrap();
    match r.warning {
        Some(w @ StepWarning::CourantAboveOne { cfl }) => {
            assert!(cfl > 1.0 && cfl == r.flow.cfl, "{cfl}");
            assert!(w.to_string().contains("Courant number"), "{w}");
        }
        other => panic!("expected CourantAboveOne, got {other:?}"),
    }
}
