//! Validation flows shared by the examples (`taylor_green`, `channel_flow`,
//! `two_layer_couette`) and `tests/flow.rs`: each runs the public API and returns measured errors.

use eulermembrane::fluid::{
    forcing::BodyForce,
    momentum::Materials,
    stepper::{FlowConfig, FlowStepper, PredictorSolver},
};
use eulermembrane::grid::{Boundary, Field, Grid};
use std::f64::consts::PI;

/// RMS and max error of the two in-plane components of a 2D Taylor-Green vortex at `t_end`, on
/// an `n x n` periodic box `[0, 2 pi]^2`, `mu = 0.1`, `rho = 1`, `dt = 0.25 h`.
pub fn taylor_green(n: usize, t_end: f64, solver: PredictorSolver) -> (f64, f64) {
    taylor_green_snapshot(n, t_end, solver, None)
}

/// As [`taylor_green`], writing the final velocity and pressure to `vti` (ParaView) if given.
pub fn taylor_green_snapshot(
    n: usize,
    t_end: f64,
    solver: PredictorSolver,
    vti: Option<&std::path::Path>,
) -> (f64, f64) {
    let l = 2.0 * PI;
    let h = l / n as f64;
    let grid = Grid::periodic([n, n, 1], [0.0; 3], [l, l, h]).unwrap();
    let (rho, mu) = (1.0, 0.1);
    let config = FlowConfig { predictor: solver, ..Default::default() };
    let mut s = FlowStepper::new(&grid, Materials::uniform(rho, mu).unwrap(), config).unwrap();
    let nu = mu / rho;
    let exact = |x: [f64; 3], t: f64| {
        let e = (-2.0 * nu * t).exp();
        [x[0].sin() * x[1].cos() * e, -x[0].cos() * x[1].sin() * e, 0.0]
    };
    s.set_velocity(|x| exact(x, 0.0)).unwrap();
    s.set_pressure(|x| 0.25 * rho * ((2.0 * x[0]).cos() + (2.0 * x[1]).cos())).unwrap();
    let steps = (t_end / (0.25 * h)).ceil() as usize;
    let dt = t_end / steps as f64;
    for _ in 0..steps {
        s.step(dt, &(), None).unwrap();
    }
    if let Some(path) = vti {
        let mut w = eulermembrane::io::vtk::VtiWriter::new(&grid);
        w.vector("velocity", s.velocity()).scalar("pressure", s.pressure());
        w.write(path).unwrap_or_else(|e| eprintln!("warning: {e}"));
    }
    let v = s.velocity();
    let (mut sum, mut max, mut count) = (0.0, 0.0f64, 0.0);
    for d in 0..2 {
        for (i, j, k) in grid.cells() {
            let x = grid.face_center(d, i as isize, j as isize, k as isize);
            let e = v.c[d].values()[grid.idx_u(i, j, k)] - exact(x, t_end)[d];
            sum += e * e;
            max = max.max(e.abs());
            count += 1.0;
        }
    }
    ((sum / count).sqrt(), max)
}

/// A channel periodic in x (and z), walls at y = 0 and y = 1, `n` cells across.
fn channel_grid(n: usize, top_velocity: f64) -> Grid<f64> {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [top_velocity, 0.0, 0.0] }];
    let h = 1.0 / n as f64;
    Grid::new([4, n, 1], [0.0; 3], [4.0 * h, 1.0, h], bc).unwrap()
}

/// Streamwise velocity profile u(y_j) at the cell centres of column i = 0.
pub fn profile(s: &FlowStepper<f64>) -> Vec<(f64, f64)> {
    let g = s.grid();
    (0..g.n()[1])
        .map(|j| (g.cell_center(0, j as isize, 0)[1], s.velocity().c[0].values()[g.idx_u(0, j, 0)]))
        .collect()
}

/// Start-up plane Poiseuille flow (force density `f`, `mu`, `rho = 1`, walls at rest) run to
/// `t_end` with `dt`; returns the profile.
pub fn poiseuille(n: usize, mu: f64, f: f64, dt: f64, t_end: f64) -> Vec<(f64, f64)> {
    let grid = channel_grid(n, 0.0);
    let mut s = FlowStepper::new(&grid, Materials::uniform(1.0, mu).unwrap(), FlowConfig::default()).unwrap();
    let force = BodyForce::new([f, 0.0, 0.0]).unwrap();
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        s.step(dt, &force, None).unwrap();
    }
    profile(&s)
}

/// Series solution of start-up Poiseuille flow in a channel of unit height:
/// `u = f/(2 mu) y (1 - y) - sum_k 4 f / (mu (k pi)^3) sin(k pi y) exp(-mu (k pi)^2 t)`, odd k.
pub fn poiseuille_exact(y: f64, t: f64, mu: f64, f: f64) -> f64 {
    let mut u = f / (2.0 * mu) * y * (1.0 - y);
    let mut k = 1;
    while k < 2001 {
        let kp = k as f64 * PI;
        u -= 4.0 * f / (mu * kp.powi(3)) * (kp * y).sin() * (-mu * kp * kp * t).exp();
        k += 2;
    }
    u
}

/// Start-up Couette flow (top wall at `u_top`, `mu`, `rho = 1`) run to `t_end` with `dt`.
pub fn couette(n: usize, mu: f64, u_top: f64, dt: f64, t_end: f64) -> Vec<(f64, f64)> {
    let grid = channel_grid(n, u_top);
    let mut s = FlowStepper::new(&grid, Materials::uniform(1.0, mu).unwrap(), FlowConfig::default()).unwrap();
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        s.step(dt, &(), None).unwrap();
    }
    profile(&s)
}

/// Series solution of start-up Couette flow: `u = U y + sum_k 2U (-1)^k / (k pi) sin(k pi y)
/// exp(-mu (k pi)^2 t)`.
pub fn couette_exact(y: f64, t: f64, mu: f64, u_top: f64) -> f64 {
    let mut u = u_top * y;
    for k in 1..4000 {
        let kp = k as f64 * PI;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        u += 2.0 * u_top * sign / kp * (kp * y).sin() * (-mu * kp * kp * t).exp();
    }
    u
}

/// Max of |u - exact| over the profile, relative to max |exact|.
pub fn rel_max_err(profile: &[(f64, f64)], exact: impl Fn(f64) -> f64) -> f64 {
    let emax = profile.iter().map(|&(y, _)| exact(y).abs()).fold(0.0, f64::max);
    profile.iter().map(|&(y, u)| (u - exact(y)).abs()).fold(0.0, f64::max) / emax
}

/// Steady two-layer Couette flow: walls at y = 0 (rest) and y = 1 (velocity 1), viscosity
/// `mu1` below the plane y = `y_i` and `mu2` above, smoothed by the tanh profile of the VOF
/// function (width `beta = 1` cell) and mixed as in (2.25). Returns the steady profile.
pub fn two_layer_couette(n: usize, mu1: f64, mu2: f64, y_i: f64) -> Vec<(f64, f64)> {
    let grid = channel_grid(n, 1.0);
    let h = 1.0 / n as f64;
    // Cell average of H = (1 + tanh((y_i - y)/h))/2 across the cell: exact integral of tanh.
    let phi = Field::from_cell_fn(&grid, |x| {
        let (a, b) = ((y_i - (x[1] - 0.5 * h)) / h, (y_i - (x[1] + 0.5 * h)) / h);
        0.5 + 0.5 * (a.cosh().ln() - b.cosh().ln())
    });
    let materials = Materials::mixture(&grid, &phi, (1.0, mu1), (1.0, mu2)).unwrap();
    let mut s = FlowStepper::new(&grid, materials, FlowConfig::default()).unwrap();
    // Large implicit steps reach the steady state quickly (Crank-Nicolson is unconditionally
    // stable); stop when the profile no longer changes.
    let dt = 0.05;
    let mut last = profile(&s);
    for _ in 0..20000 {
        s.step(dt, &(), None).unwrap();
        let now = profile(&s);
        let change = now.iter().zip(&last).map(|(a, b)| (a.1 - b.1).abs()).fold(0.0, f64::max);
        last = now;
        if change < 1e-13 {
            break;
        }
    }
    last
}

/// Exact piecewise-linear steady profile of two-layer Couette flow (shear stress continuous).
pub fn two_layer_exact(y: f64, mu1: f64, mu2: f64, y_i: f64) -> f64 {
    // tau = mu1 a1 = mu2 a2; a1 y_i + a2 (1 - y_i) = 1.
    let tau = 1.0 / (y_i / mu1 + (1.0 - y_i) / mu2);
    if y < y_i { tau / mu1 * y } else { tau / mu1 * y_i + tau / mu2 * (y - y_i) }
}
