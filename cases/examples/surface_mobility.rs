//! How fast the smoothed membrane moves under a prescribed surface force, against the Stokes
//! solution of a sharp membrane: the discrete *mobility* of the full Eulerian coupling, and
//! why a capsule needs many cells per radius.
//!
//! A sphere of radius `a = 1` in a periodic box `[-4, 4]^3` of fluid (`rho = 1`, `mu = 100`
//! outside and `lambda mu` inside, `Re << 1`), no elasticity, and one of two `l = 2` surface
//! forces (per unit area, applied as `delta f` by [`Scene::surface_force`]), with
//! `Y = 2 x z / r^2`:
//!
//! - *normal*: `f = g Y e_r`. Stokes: `u_r = (4/35) g a Y / mu` on the surface for `lambda = 1`
//!   (the single-layer potential; Taylor's relaxation time of a drop of equal viscosity,
//!   `tau = 35 mu a / (16 sigma)`, is the same number);
//! - *tangential*: `f = g grad_s Y`. Stokes: `u_t = (1/7) g a grad_s Y / mu` and
//!   `u_r = (6/35) g a Y / mu` for `lambda = 1`.
//!
//! Other viscosity ratios: [`StokesL2::with_viscosity_ratio`] (the red cells' `lambda = 5`:
//! 0.0416, 0.0534 and 0.0707).
//!
//! The flow starts at rest and is stepped (`dt = h^2 rho / mu`, viscous number 1), sampling
//! the projections every 40 steps and extrapolating them to their limit (Aitken), until the
//! extrapolated values change by less than 1e-4 (at most `--steps`). The membrane's
//! velocity is the `delta`-weighted projection of the cell-centred velocity
//! ([`surface_velocity_projection`]): the velocity every membrane field of the method is
//! carried with. Ratios below 1 mean a membrane that responds more slowly than a sharp one.
//!
//! The tangential velocity of a sharp membrane sits on a kink of the velocity profile (the
//! shear-stress jump `g grad_s Y`), while the normal velocity is smooth across it; averaging over
//! a band of width `w` lowers the former by `O(w / a)` with a large constant (the kink's slope is
//! `g / mu` against a surface value of `g a / (7 mu)`). That is the coarse-grid softness of the
//! capsules in shear (`docs/validation/shear_capsule.md`).
//!
//! Flags: `--n LIST` (24,32, about a minute; the table of `docs/validation/surface_mobility.md` is
//! `--n 24,32,48,64`, about 6 minutes; cells per side, `a / h = N / 8`), `--traction LIST`
//! (`smoothed,sharp`: `SurfaceLoad::traction` of each run), `--beta B` (sharpness of the
//! `phi` profile, initial and advected; 1, the paper's), `--lambda L` (inner over outer
//! viscosity, 1), `--steps` (4000), `--out DIR`
//! (`out/surface_mobility`: `mobility.csv`, `mobility.svg`).
//! Prints `RESULT n=... cells_per_radius=... beta=... lambda=... traction=... normal=... tangential=...
//! tangential_normal=... wall_s=...` per N and traction (each the ratio to the Stokes value).
//!
//! Run: `cargo run --release --example surface_mobility`.

use eulermembrane_cases as common;

use common::{Args, BoxResult, num, result};
use eulermembrane::diagnostics::{
    mobility::l2_normal_mode as normal_mode,
    mobility::l2_tangential_mode as tangential_mode,
    mobility::{StokesL2, surface_velocity_projection},
};
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::simulation::{Phase, Scene, Settings, Simulation, SurfaceLoad, Traction};
use eulermembrane_cases::csv::write_columns;
use eulermembrane_cases::plot::Figure;
use std::time::Instant;

const MU: f64 = 100.0;
const HALF: f64 = 4.0;

fn main() {
    common::exit_on_error(run());
}

/// The scene with the surface force `mode` (amplitude `g = 1`).
fn scene(
    n: usize,
    beta: f64,
    lambda: f64,
    traction: Traction,
    mode: fn([f64; 3]) -> [f64; 3],
) -> eulermembrane::Result<Simulation<f64>> {
    let grid = Grid::new([n; 3], [-HALF; 3], [HALF; 3], [[Boundary::Periodic; 2]; 3])?;
    Scene::new(grid, Phase::new(1.0, MU)?)
        .inside(Phase::new(1.0, lambda * MU)?)
        .capsule(Sphere::new([0.0; 3], 1.0)?)
        .effect(SurfaceLoad::new(move |x, _| mode(x)).traction(traction))
        .settings(Settings::default().with_beta(beta))
        .build()
}

/// The limit of a sequence that approaches it geometrically, from its last three terms
/// (Aitken's delta-squared); the last term where the sequence does not (yet) do so.
fn aitken(c: [f64; 3]) -> f64 {
    let (d1, d2) = (c[1] - c[0], c[2] - c[1]);
    let ratio = d2 / d1;
    if d1 != 0.0 && ratio > 0.0 && ratio < 0.95 { c[2] + d2 * ratio / (1.0 - ratio) } else { c[2] }
}

/// Steps the scene with force `force` and returns the limits of the projections on `modes`:
/// sampled every 40 steps and extrapolated by [`aitken`] (the flow settles on the box's
/// viscous time, `(8 a)^2 rho / mu`, which takes more steps as `h` falls), until the estimates
/// change by less than 1e-4 of themselves (at most `max_steps`).
fn settle(
    n: usize,
    beta: f64,
    lambda: f64,
    traction: Traction,
    max_steps: usize,
    force: fn([f64; 3]) -> [f64; 3],
    modes: [fn([f64; 3]) -> [f64; 3]; 2],
) -> BoxResult<[f64; 2]> {
    let mut sim = scene(n, beta, lambda, traction, force)?;
    let mut u = sim.velocity().clone();
    let h = 2.0 * HALF / n as f64;
    let dt = h * h / MU;
    let mut samples: Vec<[f64; 2]> = Vec::new();
    let mut estimate = [f64::NAN; 2];
    for s in 1..=max_steps {
        sim.step(dt)?;
        if s.is_multiple_of(40) || s == max_steps {
            sim.membrane_velocity(0, &mut u)?;
            let delta = sim.delta(0)?;
            samples.push([
                surface_velocity_projection(sim.grid(), &u, delta, modes[0])?,
                surface_velocity_projection(sim.grid(), &u, delta, modes[1])?,
            ]);
            let k = samples.len();
            let next = std::array::from_fn(|i| {
                if k < 3 {
                    samples[k - 1][i]
                } else {
                    aitken([samples[k - 3][i], samples[k - 2][i], samples[k - 1][i]])
                }
            });
            eprintln!(
                "  step {s}: projections {:.5e} {:.5e}, extrapolated {:.5e} {:.5e}",
                samples[k - 1][0],
                samples[k - 1][1],
                next[0],
                next[1]
            );
            let settled =
                k >= 4 && (0..2).all(|i| (next[i] - estimate[i]).abs() <= 1e-4 * next[i].abs().max(1e-30));
            estimate = next;
            if settled {
                break;
            }
        }
    }
    Ok(estimate)
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("surface_mobility.rs"));
    let out = args.out_dir("surface_mobility");
    let ns: Vec<usize> = args.list("n").unwrap_or(vec![24, 32]);
    let beta: f64 = args.get("beta", 1.0);
    let lambda: f64 = args.get("lambda", 1.0);
    let stokes = StokesL2::with_viscosity_ratio(lambda)?;
    let max_steps: usize = args.get("steps", 4000);
    let tractions: Vec<String> = args.list("traction").unwrap_or(vec!["smoothed".into(), "sharp".into()]);
    let tractions: Vec<Traction> =
        tractions.iter().map(|s| Traction::from_name(s)).collect::<Result<_, _>>()?;
    let mut rows: Vec<(Traction, f64, [f64; 3])> = Vec::new();
    for &n in &ns {
        if n < 16 || !n.is_multiple_of(2) {
            return Err(format!("--n {n}: expected even numbers of cells >= 16").into());
        }
        for &traction in &tractions {
            eprintln!(
                "surface_mobility: {n}^3 cells, {} cells per radius, beta = {beta}, {} traction",
                n / 8,
                traction.name()
            );
            let clock = Instant::now();
            let modes = [normal_mode, tangential_mode];
            let [un, _] = settle(n, beta, lambda, traction, max_steps, normal_mode, modes)?;
            let [ur, ut] = settle(n, beta, lambda, traction, max_steps, tangential_mode, modes)?;
            let ratios =
                [un * MU / stokes.normal, ut * MU / stokes.tangential, ur * MU / stokes.tangential_normal];
            result(&[
                ("n", n.to_string()),
                ("cells_per_radius", (n / 8).to_string()),
                ("beta", beta.to_string()),
                ("lambda", lambda.to_string()),
                ("traction", traction.name().to_string()),
                ("normal", num(ratios[0])),
                ("tangential", num(ratios[1])),
                ("tangential_normal", num(ratios[2])),
                ("wall_s", format!("{:.1}", clock.elapsed().as_secs_f64())),
            ]);
            rows.push((traction, n as f64 / 8.0, ratios));
        }
    }
    let column = |t: Traction, k: usize| -> Vec<f64> {
        rows.iter().filter(|r| r.0 == t).map(|r| if k == 3 { r.1 } else { r.2[k] }).collect()
    };
    let cpr = column(tractions[0], 3);
    let mut columns: Vec<(String, Vec<f64>)> = vec![("cells_per_radius".into(), cpr.clone())];
    for &t in &tractions {
        for (k, name) in ["normal", "tangential", "tangential_normal"].iter().enumerate() {
            columns.push((format!("{name}_{}", t.name()), column(t, k)));
        }
    }
    let named: Vec<(&str, &[f64])> = columns.iter().map(|(n, c)| (n.as_str(), c.as_slice())).collect();
    write_columns(out.join("mobility.csv"), &named)?;
    let mut fig = Figure::new(format!(
        "membrane velocity / Stokes value, l = 2 forces, beta = {beta}, lambda = {lambda}"
    ))
    .x_label("cells per radius a/h")
    .y_label("ratio");
    for &t in &tractions {
        let name = t.name();
        fig.line_markers(&cpr, &column(t, 0), &format!("u_r under a normal force, {name}"));
        fig.line_markers(&cpr, &column(t, 1), &format!("u_t under a tangential force, {name}"));
        fig.line_markers(&cpr, &column(t, 2), &format!("u_r under a tangential force, {name}"));
    }
    fig.line(&[cpr[0], cpr[cpr.len() - 1]], &[1.0, 1.0], "sharp membrane (Stokes)");
    fig.save(out.join("mobility.svg"))?;
    eprintln!("wrote {}", out.display());
    Ok(())
}
