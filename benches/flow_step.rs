//! One flow step (predictor + projection) on a 64^3 shear box, with the preconditioned Krylov
//! solver and with the paper's SOR, at a moderate viscous number `mu dt / (rho h^2) = 0.8`
//! (SOR at the paper's stiffness is compared in the `solver_compare` example).
use criterion::{Criterion, criterion_group, criterion_main};
use eulermembrane::fluid::{
    momentum::Materials,
    sor::SorParams,
    stepper::{FlowConfig, FlowStepper, PredictorSolver},
};
use eulermembrane::grid::{Boundary, Grid};

fn stepper(n: usize, solver: PredictorSolver) -> (FlowStepper<f64>, f64) {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::new([n, n, n], [0.0; 3], [1.0; 3], bc).unwrap();
    let mu = 1.0;
    let h = 1.0 / n as f64;
    let dt = 0.8 * h * h / mu;
    let config = FlowConfig { predictor: solver, ..Default::default() };
    let mut s = FlowStepper::new(&grid, Materials::uniform(1.0, mu).unwrap(), config).unwrap();
    s.set_velocity(|x| [2.0 * x[2] - 1.0 + 0.1 * (6.0 * x[1]).sin(), 0.1 * (6.0 * x[0]).sin(), 0.0]).unwrap();
    s.step(dt, &(), None).unwrap();
    (s, dt)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("flow_step_64cubed");
    g.sample_size(10);
    let (mut k, dt) = stepper(64, PredictorSolver::default());
    g.bench_function("krylov", |b| b.iter(|| k.step(dt, &(), None).unwrap()));
    let (mut s, dt) = stepper(64, PredictorSolver::Sor(SorParams::default()));
    g.bench_function("sor", |b| b.iter(|| s.step(dt, &(), None).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
