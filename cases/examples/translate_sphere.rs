//! A 3D check of the interface advection: a sphere carried diagonally by the uniform velocity
//! `(1, 1, 1)` through the periodic unit box for one period (`T = 1`), after which the exact
//! solution is the initial field. Reports the volume drift (conservation), the L1 error (3.1)
//! of `phi` and of `kappa_R delta_bar = kappa_R tilde * dx`, the range of `phi`, and the cost.
//!
//! Flags: `--n N` (cells per side, default 64), `--radius R` (default 0.25, i.e. 16 cells at
//! N = 64), `--cfl C` (summed Courant number `(|u| + |v| + |w|) dt / h`, default 0.25;
//! AB2 is unstable above about 0.5), `--normals youngs|central_phi|atanh2|atanh4` (default: the
//! library's), `--no-curvature` (advect `phi` only), `--out DIR` (default `out/translate_sphere`,
//! receives `history.csv`).
//!
//! Run: `cargo run --release --example translate_sphere -- --n 64`.

use eulermembrane::grid::{Field, Grid, VectorField};
use eulermembrane::interface::shapes::{Smoothing, Sphere, smoothed_fields};
use eulermembrane::interface::{
    advect::{AdvectionParams, Advector, Carried},
    geometry::NormalScheme,
};
use std::io::Write as _;

use eulermembrane_cases as common;

fn main() {
    common::exit_on_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = common::Args::parse(include_str!("translate_sphere.rs"));
    let n: usize = args.get("n", 64);
    let radius: f64 = args.get("radius", 0.25);
    let cfl: f64 = args.get("cfl", 0.25);
    let normals = match args.opt::<String>("normals") {
        Some(name) => NormalScheme::from_name(&name)?,
        None => AdvectionParams::<f64>::default().normals,
    };
    let curvature = !args.flag("no-curvature");
    let out = args.out_dir("translate_sphere");
    if !(cfl > 0.0 && cfl <= 1.0) {
        return Err(format!("--cfl {cfl}: in (0, 1]").into());
    }
    let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3])?;
    let sphere = Sphere::new([0.5; 3], radius)?;
    let (phi0, kt0) = smoothed_fields(&g, &sphere, &Smoothing::default())?;
    let (mut phi, mut kt) = (phi0.clone(), kt0.clone());
    let mut v = VectorField::from_fn(&g, |_| [1.0, 1.0, 1.0]);
    v.fill_ghosts(&g);
    let h = g.h()[0];
    // Summed Courant number (|u| + |v| + |w|) dt / h = cfl: AB2 needs it below about 1/2.
    let steps = (3.0 / (cfl * h)).ceil() as usize;
    let dt = 1.0 / steps as f64;
    let params = AdvectionParams { normals, ..Default::default() };
    let mut adv = Advector::new(&g, params, if curvature { Carried::PhiAndCurvature } else { Carried::Phi })?;
    let mass0 = phi0.interior_sum(&g);
    let mut csv = std::io::BufWriter::new(std::fs::File::create(out.join("history.csv"))?);
    writeln!(csv, "step,t,volume_drift,profile_cells")?;
    let t0 = std::time::Instant::now();
    let mut band = 0;
    for s in 0..steps {
        let info = if curvature {
            adv.step(&g, &v, dt, &mut phi, Some(&mut kt))?
        } else {
            adv.step(&g, &v, dt, &mut phi, None)?
        };
        band = info.profile_cells;
        let drift = (phi.interior_sum(&g) - mass0) / mass0;
        writeln!(csv, "{},{},{:e},{}", s + 1, (s + 1) as f64 * dt, drift, band)?;
        if (s + 1) % (steps / 4).max(1) == 0 {
            eprintln!(
                "step {}/{steps} t={:.3} dt={dt:.3e} volume_drift={drift:.2e} profile_cells={band} \
                 ({:.1} s)",
                s + 1,
                (s + 1) as f64 * dt,
                t0.elapsed().as_secs_f64()
            );
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let l1 = |a: &Field<f64>, b: &Field<f64>, scale: f64| {
        g.cells()
            .map(|(i, j, k)| {
                let id = g.idx_u(i, j, k);
                ((a.values()[id] - b.values()[id]) * scale).abs()
            })
            .sum::<f64>()
            / g.cell_count() as f64
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, j, k) in g.cells() {
        let x = phi.values()[g.idx_u(i, j, k)];
        lo = lo.min(x);
        hi = hi.max(x);
    }
    let drift = ((phi.interior_sum(&g) - mass0) / mass0).abs();
    let per_step = secs / steps as f64;
    println!(
        "RESULT n={n} steps={steps} l1_phi={:.3e} l1_kappa={:.3e} volume_drift={drift:.2e} \
         phi_min={lo:.3e} phi_max={hi:.12} profile_cells={band} ms_per_step={:.2} \
         cell_steps_per_s={:.3e}",
        l1(&phi, &phi0, 1.0),
        if curvature { l1(&kt, &kt0, h) } else { 0.0 },
        per_step * 1e3,
        g.cell_count() as f64 / per_step
    );
    Ok(())
}
