//! The predictor (2.35) solved by the paper's SOR (omega 1.4, relative change 1e-6) and by
//! BiCGStab preconditioned by the FFT Helmholtz solve, at the stiffness of the paper's shear
//! case at N = 128: `mu dt / (rho h^2) = 12.8`. Same grid, same state, same steps.
//!
//! Flags: `--n N` (64), `--steps S` (3), `--krylov-tol TOL` (BiCGStab relative residual, 1e-8).
//!
//! `cargo run --release --example solver_compare [-- --n 64 --steps 3]`
use eulermembrane_cases as common;

use eulermembrane::fluid::{
    krylov::KrylovParams,
    momentum::Materials,
    sor::SorParams,
    stepper::{FlowConfig, FlowStepper, PredictorSolver},
};
use eulermembrane::grid::{Boundary, Grid};
use std::time::Instant;

fn run(n: usize, steps: usize, solver: PredictorSolver) -> (usize, f64, Vec<f64>) {
    // Shear flow box of Sec. 3.3 scaled to n x n/2 x n cells: x in [-4, 4], y in [-2, 2],
    // z in [-4, 4], walls z = -4, 4 moving at -4, +4 (shear rate 1), Re = 0.01 -> mu = 100.
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-4.0, 0.0, 0.0] }, Boundary::Wall { velocity: [4.0, 0.0, 0.0] }];
    let grid = Grid::new([n, n / 2, n], [-4.0, -2.0, -4.0], [4.0, 2.0, 4.0], bc).unwrap();
    let (rho, mu) = (1.0, 100.0);
    let h = grid.h()[0];
    let dt = 12.8 * rho * h * h / mu;
    let config = FlowConfig { predictor: solver, ..Default::default() };
    let mut s = FlowStepper::new(&grid, Materials::uniform(rho, mu).unwrap(), config).unwrap();
    // Linear shear plus a smooth, divergence-free perturbation.
    s.set_velocity(|x| {
        let (a, b) = ((std::f64::consts::PI * x[0] / 4.0), (std::f64::consts::PI * x[2] / 8.0));
        [x[2] + 0.3 * a.sin() * (2.0 * b).sin(), 0.0, 0.3 * 2.0 * a.cos() * (b * 2.0).cos() * 0.25 * 2.0]
    })
    .unwrap();
    let t0 = Instant::now();
    let mut iters = 0;
    for _ in 0..steps {
        iters += s.step(dt, &(), None).unwrap().predictor_iterations;
    }
    let secs = t0.elapsed().as_secs_f64();
    let u: Vec<f64> = s.velocity().c[0].values().to_vec();
    (iters, secs, u)
}

fn main() {
    let args = common::Args::parse(include_str!("solver_compare.rs"));
    let n: usize = args.get("n", 64);
    let steps: usize = args.get("steps", 3);
    let tol: f64 = args.get("krylov-tol", 1e-8);
    println!("grid {n} x {} x {n}, mu dt / (rho h^2) = 12.8, {steps} steps", n / 2);
    let (si, ss, su) = run(n, steps, PredictorSolver::Sor(SorParams::default()));
    println!("SOR      : {si:>6} sweeps     {ss:>8.3} s");
    let kp = KrylovParams { tolerance: tol, ..Default::default() };
    let (ki, ks, ku) = run(n, steps, PredictorSolver::Krylov(kp));
    println!("BiCGStab : {ki:>6} iterations {ks:>8.3} s");
    let diff = su.iter().zip(&ku).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!("max |u_sor - u_krylov| after {steps} steps: {diff:.3e}");
    common::result(&[
        ("sor_iters", format!("{}", si / steps)),
        ("sor_s", format!("{:.4}", ss / steps as f64)),
        ("krylov_iters", format!("{}", ki / steps)),
        ("krylov_s", format!("{:.4}", ks / steps as f64)),
        ("speedup", format!("{:.1}", ss / ks)),
    ]);
}
