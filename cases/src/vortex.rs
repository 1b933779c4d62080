//! The single-vortex advection test of Sec. 3.1 (Table 1), shared by the `single_vortex` and
//! `accuracy_cost` examples: MTHINC advection of `phi` and of the convolved reference curvature
//! `kappa_R tilde` in a time-reversing flow, with the errors (3.1) after one period.
//!
//! An ellipse `(x-0.5)^2/a^2 + (y-0.75)^2/b^2 = 1`, `a = 0.15` (along x), `b = 0.7 a`, in the
//! periodic unit square is advected by the stream function
//! `Psi = (1/pi) sin^2(pi x) S(pi y) cos(pi t / T)`, `T = 1`, with `S = cos^2` as printed in the
//! paper or the classic `S = sin^2`. Face velocities are differences of `Psi` at cell nodes, so
//! the discrete divergence vanishes to round-off. The time step is the largest with
//! `max CFL <= cfl` that divides `T`.

use eulermembrane::Real;
use eulermembrane::grid::{Field, Grid, VectorField};
use eulermembrane::interface::shapes::{Ellipse, Smoothing, smoothed_fields};
use eulermembrane::interface::{
    advect::{AdvectionParams, Advector, Carried},
    geometry::NormalScheme,
    mthinc::CellQuadrature,
};
use std::f64::consts::PI;
use std::time::Instant;

/// One single-vortex run.
#[derive(Clone, Debug)]
pub struct VortexCase {
    /// Cells along x and y.
    pub n: usize,
    /// `S = sin^2` (classic) instead of the paper's `cos^2`.
    pub sin: bool,
    /// Normals of the reconstruction.
    pub normals: NormalScheme,
    /// Quadrature of the cell constraints.
    pub quadrature: CellQuadrature,
    /// MTHINC sharpness `beta` (also of the initial smoothing).
    pub beta: f64,
    /// Largest CFL number.
    pub cfl: f64,
    /// Uniform-cell threshold; the precision's default if none.
    pub tiny: Option<f64>,
}

impl VortexCase {
    /// The paper's settings (Youngs normals, two-point Gauss quadrature, `beta = 1`,
    /// `CFL = 0.25`, `S = cos^2`) at `n`.
    pub fn paper(n: usize) -> Self {
        VortexCase {
            n,
            sin: false,
            normals: NormalScheme::Youngs,
            quadrature: CellQuadrature::Gauss2,
            beta: 1.0,
            cfl: 0.25,
            tiny: None,
        }
    }
}

/// A snapshot: time, `phi`, `kappa_R tilde`.
pub type Snap<T> = (f64, Field<T>, Field<T>);

/// What a run measured.
pub struct VortexRun<T> {
    /// Errors (3.1) of `phi`: L1, L2, Linf.
    pub phi: [f64; 3],
    /// Errors (3.1) of `kappa_R delta_bar = kappa_R tilde * h`: L1, L2, Linf.
    pub kappa: [f64; 3],
    /// Relative change of `sum phi`.
    pub drift: f64,
    /// Smallest `phi` at the end.
    pub min: f64,
    /// Largest `phi` at the end.
    pub max: f64,
    /// Time steps taken.
    pub steps: usize,
    /// Wall-clock seconds of the time loop.
    pub wall_s: f64,
    /// CPU seconds of the time loop (see [`super::cpu_seconds`]).
    pub cpu_s: f64,
    /// The grid.
    pub grid: Grid<T>,
    /// Snapshots at `t = 0, T/2, T` (empty unless asked for).
    pub snaps: Vec<Snap<T>>,
}

/// Errors (3.1): L1, L2, Linf of `(a - b) * scale`.
fn norms<T: Real>(g: &Grid<T>, a: &Field<T>, b: &Field<T>, scale: f64) -> [f64; 3] {
    let (mut l1, mut l2, mut li) = (0.0, 0.0, 0.0f64);
    for (i, j, k) in g.cells() {
        let id = g.idx_u(i, j, k);
        let e = ((a.values()[id] - b.values()[id]).f64() * scale).abs();
        l1 += e;
        l2 += e * e;
        li = li.max(e);
    }
    let m = g.cell_count() as f64;
    [l1 / m, (l2 / m).sqrt(), li]
}

/// Runs `case` for one period in precision `T`, keeping snapshots if `snapshots`, printing
/// progress to stderr unless `quiet`.
pub fn run<T: Real>(
    case: &VortexCase,
    snapshots: bool,
    quiet: bool,
) -> Result<VortexRun<T>, Box<dyn std::error::Error>> {
    let n = case.n;
    let h = 1.0 / n as f64;
    let g = Grid::<T>::periodic([n, n, 1], [T::zero(); 3], [T::one(), T::one(), T::lit(h)])?;
    let a = 0.15;
    let ellipse = Ellipse::new([0.5, 0.75], [a, 0.7 * a])?;
    let smoothing = Smoothing { beta: case.beta, points: 4 };
    let (phi0, kt0) = smoothed_fields(&g, &ellipse, &smoothing)?;
    let (mut phi, mut kt) = (phi0.clone(), kt0.clone());

    // Stream function at nodes (x_i, y_j) = (i h, j h); face velocities are its differences.
    let v0 = VectorField::from_stream_function(&g, |x: [T; 3]| {
        let (x, y) = (x[0].f64(), x[1].f64());
        let s = if case.sin { (PI * y).sin().powi(2) } else { (PI * y).cos().powi(2) };
        T::lit((PI * x).sin().powi(2) * s / PI)
    });
    let umax = v0.c[0].values().iter().chain(v0.c[1].values()).fold(0.0f64, |m, x| m.max(x.f64().abs()));
    let t_end = 1.0;
    let steps = (t_end * umax / (case.cfl * h)).ceil() as usize;
    let dt = t_end / steps as f64;

    let tiny = case.tiny.map_or_else(|| AdvectionParams::<T>::default().tiny, T::lit);
    let params =
        AdvectionParams { beta: T::lit(case.beta), normals: case.normals, quadrature: case.quadrature, tiny };
    let mut adv = Advector::new(&g, params, Carried::PhiAndCurvature)?;
    let mut v = v0.clone();
    let mass0 = phi0.interior_sum(&g).f64();
    let mut snaps = Vec::new();
    if snapshots {
        snaps.push((0.0, phi0.clone(), kt0.clone()));
    }
    let clock = Instant::now();
    let cpu0 = super::cpu_seconds();
    for s in 0..steps {
        let t = s as f64 * dt;
        let c = T::lit((PI * t / t_end).cos());
        for d in 0..2 {
            for (x, y) in v.c[d].values_mut().iter_mut().zip(v0.c[d].values()) {
                *x = c * *y;
            }
        }
        adv.step(&g, &v, T::lit(dt), &mut phi, Some(&mut kt))?;
        if snapshots && 2 * (s + 1) == steps {
            snaps.push((0.5 * t_end, phi.clone(), kt.clone()));
        }
        if !quiet && (s + 1) % (steps / 4).max(1) == 0 {
            eprintln!(
                "n={n} step {}/{steps} t={:.3} dt={dt:.3e} mass_drift={:.2e} ({:.1} s)",
                s + 1,
                (s + 1) as f64 * dt,
                ((phi.interior_sum(&g).f64() - mass0) / mass0).abs(),
                clock.elapsed().as_secs_f64()
            );
        }
    }
    let (wall_s, cpu_s) = (clock.elapsed().as_secs_f64(), super::cpu_seconds() - cpu0);
    if snapshots {
        snaps.push((t_end, phi.clone(), kt.clone()));
    }
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, j, k) in g.cells() {
        let x = phi.values()[g.idx_u(i, j, k)].f64();
        min = min.min(x);
        max = max.max(x);
    }
    Ok(VortexRun {
        phi: norms(&g, &phi, &phi0, 1.0),
        kappa: norms(&g, &kt, &kt0, h),
        drift: ((phi.interior_sum(&g).f64() - mass0) / mass0).abs(),
        min,
        max,
        steps,
        wall_s,
        cpu_s,
        grid: g,
        snaps,
    })
}
