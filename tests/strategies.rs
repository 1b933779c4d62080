//! The strategy traits as a downstream crate plugs them in, with the public API only: a user's
//! normal estimator, interface transport, momentum solver and pressure solver, each wrapping the
//! library's default and counting its calls, give the default run bit for bit; a user's solver
//! that fails fails the step and leaves the state as it was.

use eulermembrane::fluid::{
    krylov::KrylovInfo,
    momentum::{Coefficient, KrylovMomentum, MomentumSolver, MomentumSystem},
    projection::{PressureSolver, SpectralPcg},
    stepper::FlowConfig,
};
use eulermembrane::grid::{Field, Grid, VectorField};
use eulermembrane::interface::{
    advect::{AdvectionInfo, AdvectionParams, Advector, InterfaceTransport},
    geometry::{Geometry, NormalEstimator, NormalScheme, PhiRange},
};
use eulermembrane::io::checkpoint::{CheckpointReader, CheckpointWriter};
use eulermembrane::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Calls of each strategy, shared between the test and the boxed strategies.
#[derive(Default)]
struct Calls {
    normals: AtomicUsize,
    transport: AtomicUsize,
    undo: AtomicUsize,
    momentum: AtomicUsize,
    pressure: AtomicUsize,
}

impl Calls {
    fn get(&self) -> [usize; 5] {
        [&self.normals, &self.transport, &self.undo, &self.momentum, &self.pressure]
            .map(|c| c.load(Ordering::Relaxed))
    }
}

struct CountedNormals(Geometry<f64>, Arc<Calls>);

impl NormalEstimator<f64> for CountedNormals {
    fn name(&self) -> &str {
        "counted_normals"
    }
    fn estimate(
        &mut self,
        grid: &Grid<f64>,
        phi: &Field<f64>,
        band: PhiRange<f64>,
        out: &mut [Field<f64>; 3],
    ) -> Result<()> {
        self.1.normals.fetch_add(1, Ordering::Relaxed);
        self.0.estimate(grid, phi, band, out)
    }
}

struct CountedTransport(Advector<f64>, Arc<Calls>);

impl InterfaceTransport<f64> for CountedTransport {
    fn name(&self) -> &str {
        "counted_transport"
    }
    fn advance(
        &mut self,
        grid: &Grid<f64>,
        v: &VectorField<f64>,
        dt: f64,
        phi: &mut Field<f64>,
        kappa: Option<&mut Field<f64>>,
    ) -> Result<AdvectionInfo> {
        self.1.transport.fetch_add(1, Ordering::Relaxed);
        self.0.advance(grid, v, dt, phi, kappa)
    }
    fn undo(&mut self) {
        self.1.undo.fetch_add(1, Ordering::Relaxed);
        self.0.undo()
    }
    fn roll(&mut self, grid: &Grid<f64>, axis: usize, by: isize) -> Result<()> {
        self.0.roll(grid, axis, by)
    }
    fn checkpoint(&self, w: &mut CheckpointWriter, prefix: &str) {
        self.0.checkpoint(w, prefix)
    }
    fn restore(&mut self, r: &CheckpointReader, prefix: &str) -> Result<()> {
        self.0.restore(r, prefix)
    }
}

struct CountedMomentum(KrylovMomentum<f64>, Arc<Calls>);

impl MomentumSolver<f64> for CountedMomentum {
    fn name(&self) -> &str {
        "counted_momentum"
    }
    fn solve(
        &mut self,
        system: &MomentumSystem<'_, f64>,
        b: &VectorField<f64>,
        x: &mut VectorField<f64>,
    ) -> Result<KrylovInfo> {
        self.1.momentum.fetch_add(1, Ordering::Relaxed);
        self.0.solve(system, b, x)
    }
}

/// The default pressure solver, counted; from the call `fail_from` on it refuses to converge.
struct CountedPressure(SpectralPcg<f64>, Arc<Calls>, usize);

impl PressureSolver<f64> for CountedPressure {
    fn name(&self) -> &str {
        "counted_pressure"
    }
    fn solve(
        &mut self,
        grid: &Grid<f64>,
        rho: &Coefficient<f64>,
        b: &mut Field<f64>,
        psi: &mut Field<f64>,
    ) -> Result<KrylovInfo> {
        let n = self.1.pressure.fetch_add(1, Ordering::Relaxed);
        if n >= self.2 {
            psi.fill(f64::NAN); // a failing solver may leave its output in any state
            return Err(Error::NoConvergence {
                solver: "counted_pressure",
                iterations: 0,
                residual: f64::INFINITY,
                tolerance: 1e-8,
            });
        }
        self.0.solve(grid, rho, b, psi)
    }
}

/// A capsule with elasticity and bending (so the transport carries `kappa_R tilde`), a denser
/// and five times more viscous inside (variable density: the PCG pressure path; two
/// viscosities: the blended preconditioner), in a shear flow.
fn scene() -> Scene<f64> {
    let grid = Grid::periodic([16; 3], [0.0; 3], [1.0; 3]).unwrap();
    Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
        .inside(Phase::new(2.0, 5.0).unwrap())
        .capsule(Sphere::new([0.5; 3], 0.25).unwrap())
        .effect(Elasticity::new(NeoHookean::new(1.0).unwrap()))
        .bending(1e-3)
}

/// `scene` with every strategy replaced by its counted wrapper of the default; the pressure
/// solver fails from its call `fail_from` on.
fn counted(calls: &Arc<Calls>, fail_from: usize) -> Simulation<f64> {
    let s = scene();
    let grid = s.grid().clone();
    let config = FlowConfig::default();
    let (c1, c2, c3, c4) = (calls.clone(), calls.clone(), calls.clone(), calls.clone());
    s.normal_estimator(CountedNormals(Geometry::new(&grid, NormalScheme::Atanh4), c1))
        .interface_transport(move |g, carried| {
            let adv = Advector::new(g, AdvectionParams::default(), carried)?;
            Ok(Box::new(CountedTransport(adv, c2.clone())) as Box<dyn InterfaceTransport<f64>>)
        })
        .momentum_solver(CountedMomentum(KrylovMomentum::new(&grid, Default::default(), true).unwrap(), c3))
        .pressure_solver(CountedPressure(SpectralPcg::new(&grid, config.poisson).unwrap(), c4, fail_from))
        .build()
        .unwrap()
}

fn shear(sim: &mut Simulation<f64>) {
    sim.set_velocity(|x| [0.5 * (2.0 * std::f64::consts::PI * x[1]).sin(), 0.0, 0.0]).unwrap();
}

fn assert_same_state(a: &Simulation<f64>, b: &Simulation<f64>) {
    for d in 0..3 {
        assert_eq!(a.velocity().c[d].values(), b.velocity().c[d].values(), "velocity {d}");
    }
    assert_eq!(a.pressure().values(), b.pressure().values(), "pressure");
    assert_eq!(a.phi(0).unwrap().values(), b.phi(0).unwrap().values(), "phi");
    for d in 0..3 {
        assert_eq!(a.normal(0).unwrap()[d].values(), b.normal(0).unwrap()[d].values(), "normal {d}");
    }
}

/// The four user strategies, each wrapping the default, give the default run to the bit, are
/// called once per step (the normals once more, when the scene is built), name themselves in
/// `Simulation::numerics`, and a checkpoint of the user transport's history restores a run that
/// continues bit for bit.
#[test]
fn user_strategies_wrapping_the_defaults_give_the_default_run_bit_for_bit() {
    let steps = 4;
    let mut plain = scene().build().unwrap();
    assert_eq!(
        plain.numerics(),
        "normals=atanh4; transport=mthinc_convolved_curvature; momentum=bicgstab; pressure=spectral_pcg"
    );
    let calls = Arc::new(Calls::default());
    let mut user = counted(&calls, usize::MAX);
    assert_eq!(
        user.numerics(),
        "normals=counted_normals; transport=counted_transport; momentum=counted_momentum; \
         pressure=counted_pressure"
    );
    shear(&mut plain);
    shear(&mut user);
    for _ in 0..steps {
        let (a, b) = (plain.step(2e-3).unwrap(), user.step(2e-3).unwrap());
        assert_eq!(a, b, "step reports");
        assert!(a.flow.poisson_iterations > 0, "variable density: the PCG path");
    }
    assert_same_state(&plain, &user);
    assert_eq!(calls.get(), [1 + steps, steps, 0, steps, steps]);

    // A checkpoint written through the user transport restores a run that continues to the bit.
    let path = std::env::temp_dir().join(format!("eulermembrane_strategies_{}.ckpt", std::process::id()));
    user.checkpoint(&path).unwrap();
    let mut again = counted(&Arc::new(Calls::default()), usize::MAX);
    again.restore(&path).unwrap();
    std::fs::remove_file(&path).ok();
    plain.step(2e-3).unwrap();
    again.step(2e-3).unwrap();
    assert_same_state(&plain, &again);
}

/// A user pressure solver that fails fails the step, naming it, and the step is rolled back
/// through the user transport's `undo`: the state is the one of the default run before it, to
/// the bit.
#[test]
fn a_failing_user_solver_fails_the_step_and_leaves_the_state() {
    let calls = Arc::new(Calls::default());
    let mut user = counted(&calls, 2);
    let mut plain = scene().build().unwrap();
    shear(&mut user);
    shear(&mut plain);
    for sim in [&mut user, &mut plain] {
        sim.step(2e-3).unwrap();
        sim.step(2e-3).unwrap();
    }
    let e = user.step(2e-3).unwrap_err();
    assert!(
        matches!(&e, Error::Step { source, .. }
            if matches!(**source, Error::NoConvergence { solver: "counted_pressure", .. })),
        "{e:?}"
    );
    assert_eq!(calls.get()[2], 1, "the transport's step was undone once");
    assert_same_state(&plain, &user);
    assert_eq!(user.steps(), 2);
}
