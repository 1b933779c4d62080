//! A capsule at rest with a uniform isotropic pre-stretch: the membrane tension `T` must be
//! held by a pressure jump `2 T / r` (Laplace), with no flow. The full solver is run for both
//! laws from rest; after `--steps` steps the jump (mean pressure where `phi > 0.999` minus mean
//! pressure where `phi < 0.001`) is compared with `2 T / r`, `T` the law's equibiaxial tension
//! at the pre-stretch, and the spurious velocity is reported as `max |v| / (T / mu)`.
//!
//! Set-up: a sphere of radius 1 in the periodic box `[-2, 2]^3` (`N/4` cells per radius),
//! `rho = mu = 1`, `E_s = 1`, Skalak `alpha = 1`, pre-stretch `lambda` (1.05).
//!
//! One line per law: `RESULT law=neo_hookean rel_err=... spurious=...` and `RESULT law=skalak
//! ...`; `--out` receives `pressure.csv` (the pressure along the x axis through the centre, both
//! laws) and `pressure.svg`.
//!
//! Flags: `--n` (64: 16 cells per radius), `--lambda` (1.05), `--steps` (40), `--dt` (`h / 4`),
//! `--traction sharp-resampled|sharp|smoothed` (`Elasticity::traction`, the library's default
//! `sharp-resampled`; `smoothed` is the paper's), `--beta B` (1, the MTHINC
//! sharpness of the profile, `Settings::with_beta`), `--out DIR`
//! (`out/inflated_capsule`).
//!
//! Run: `cargo run --release --example inflated_capsule`.

use eulermembrane_cases as common;

use common::{Args, BoxResult, num, result};
use eulermembrane::grid::Grid;
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::{
    law::{NeoHookean, Skalak, SurfaceLaw},
    loading::equibiaxial_tension,
};
use eulermembrane::simulation::{Elasticity, Phase, Scene, Settings, Traction};
use eulermembrane_cases::csv::write_columns;
use eulermembrane_cases::plot::Figure;
use std::time::Instant;

fn main() {
    common::exit_on_error(run());
}

/// What one law's run measured.
struct Outcome {
    jump: f64,
    laplace: f64,
    spurious: f64,
    section: Vec<f64>,
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("inflated_capsule.rs"));
    let out = args.out_dir("inflated_capsule");
    let n: usize = args.get("n", 64);
    let lambda: f64 = args.get("lambda", 1.05);
    let steps: usize = args.get("steps", 40);
    let h = 4.0 / n as f64;
    let dt: f64 = args.get("dt", 0.25 * h);
    eprintln!(
        "inflated_capsule: {n}^3 cells ({} per radius), lambda = {lambda}, {steps} steps of dt = {dt:.3e}",
        n / 4
    );
    let traction = args.traction(Traction::default())?;
    let settings = Settings::default().with_beta(args.get("beta", 1.0));
    let neo = simulate(NeoHookean::new(1.0)?, n, lambda, steps, dt, settings, traction, "neo_hookean")?;
    let skalak = simulate(Skalak::new(1.0, 1.0)?, n, lambda, steps, dt, settings, traction, "skalak")?;
    let x: Vec<f64> = (0..n).map(|i| -2.0 + (i as f64 + 0.5) * h).collect();
    write_columns(
        out.join("pressure.csv"),
        &[("x", &x), ("p_neo_hookean", &neo.section), ("p_skalak", &skalak.section)],
    )?;
    let mut fig = Figure::new(format!("pressure through the centre, lambda = {lambda}, N = {n}"))
        .x_label("x")
        .y_label("p - p(corner)");
    fig.line(&x, &neo.section, &format!("neo-Hookean (2T/r = {:.4})", neo.laplace));
    fig.line(&x, &skalak.section, &format!("Skalak (2T/r = {:.4})", skalak.laplace));
    fig.save(out.join("pressure.svg"))?;
    for (name, o) in [("neo_hookean", &neo), ("skalak", &skalak)] {
        result(&[
            ("law", name.to_string()),
            ("n", n.to_string()),
            ("jump", num(o.jump)),
            ("laplace", num(o.laplace)),
            ("rel_err", num(o.jump / o.laplace - 1.0)),
            ("spurious", num(o.spurious)),
            ("traction", traction.name().to_string()),
        ]);
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn simulate(
    law: impl SurfaceLaw<f64> + Clone + 'static,
    n: usize,
    lambda: f64,
    steps: usize,
    dt: f64,
    settings: Settings<f64>,
    traction: Traction,
    name: &str,
) -> BoxResult<Outcome> {
    let grid = Grid::periodic([n; 3], [-2.0; 3], [2.0; 3])?;
    let tension = equibiaxial_tension(&law, lambda)?;
    let mu = 1.0;
    let mut sim = Scene::new(grid, Phase::new(1.0, mu)?)
        .capsule(Sphere::new([0.0; 3], 1.0)?)
        .effect(Elasticity::new(law).traction(traction))
        .settings(settings)
        .build()?;
    sim.prestretch(0, lambda)?;
    let clock = Instant::now();
    for s in 1..=steps {
        sim.step(dt)?;
        if s % (steps / 4).max(1) == 0 {
            eprintln!("  {name}: step {s}/{steps} ({:.0} s)", clock.elapsed().as_secs_f64());
        }
    }
    let g = sim.grid();
    let (phi, p) = (sim.phi(0)?, sim.pressure());
    let (mut inside, mut outside) = ((0.0, 0usize), (0.0, 0usize));
    for (i, j, k) in g.cells() {
        let idx = g.idx_u(i, j, k);
        if phi.values()[idx] > 0.999 {
            inside = (inside.0 + p.values()[idx], inside.1 + 1);
        } else if phi.values()[idx] < 0.001 {
            outside = (outside.0 + p.values()[idx], outside.1 + 1);
        }
    }
    let jump = inside.0 / inside.1 as f64 - outside.0 / outside.1 as f64;
    let vmax = (0..3)
        .flat_map(|c| g.cells().map(move |(i, j, k)| (c, g.idx_u(i, j, k))))
        .map(|(c, idx)| sim.velocity().c[c].values()[idx].abs())
        .fold(0.0, f64::max);
    let corner = p.values()[g.idx_u(0, n / 2, n / 2)];
    let section = (0..n).map(|i| p.values()[g.idx_u(i, n / 2, n / 2)] - corner).collect();
    Ok(Outcome { jump, laplace: 2.0 * tension, spurious: vmax / (tension / mu), section })
}
