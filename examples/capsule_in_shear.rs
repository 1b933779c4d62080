//! # A capsule in simple shear flow
//!
//! An initially spherical capsule with a neo-Hookean membrane (2.5) sits midway between two
//! walls that slide in opposite directions. The shear flow stretches it into an ellipsoid
//! inclined to the flow while its membrane tank-treads around the inside. This is Sec. 3.3 of
//! the paper (Ii et al. 2012), written directly against the library in about a hundred lines
//! of code; `cases/examples/shear_capsule.rs` is the full reproduction (reference curves,
//! plots, flags).
//!
//! Run: `cargo run --release --example capsule_in_shear` (no arguments; 35 s on one core,
//! measured while another job used the other).
//!
//! It prints a progress line every time unit (to stderr): the time, the Taylor deformation
//! `D = (L - B)/(L + B)` of the capsule's section in the plane of shear, its inclination, the
//! steps taken, the mean step size and the volume drift. Then, on stdout, one line
//!
//! ```text
//! RESULT ca=0.025 n=48 d=... d_theory=0.15625 rel_err=... d_min=... d_max=... drift=... volume_drift=... steps=... wall_s=...
//! ```
//!
//! and it checks `D` against the small-deformation theory of Barthès-Biesel (1980) and
//! Barthès-Biesel & Rallison (1981): for a neo-Hookean membrane `D = 25 Ca / 4`, with
//! `Ca = mu gamma a / E_s` and `E_s = 3 G_s` the modulus of (2.5). At `Ca = 0.025` that is
//! 0.156 (the boundary-element value of Ramanujan & Pozrikidis 1998 is 0.150).
//!
//! What to expect (measured): `D` rises to 0.158 by `t = 2`, then swings slowly down to 0.138
//! at `t = 4`; its mean over `t` in `[2, 4]`, the `d` of the RESULT line, is 0.1490, 4.6 % below
//! the theory (`d_min=1.3784e-1 d_max=1.5816e-1`). `D` is settled to within that swing, not to a
//! constant: `drift`, the change of the mean from the first to the second half of the window,
//! is -7.6 % (a slow swing with about half the tank-treading period, which the sharp membrane
//! shows on every grid, docs/validation/shear_capsule.md). The run
//! fails (returns an error) if `|d / d_theory - 1|` exceeds 10 %. The grid is small, 6 cells
//! per radius (finer grids: docs/validation/shear_capsule.md).

use eulermembrane::diagnostics::taylor::taylor_deformation;
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{Elasticity, Phase, Scene, timestep::AdaptiveDt};
use std::time::Instant;

/// Capillary number `Ca = mu gamma a / E_s`: viscous stress over membrane stiffness.
const CA: f64 = 0.025;
/// Cells along x and z (N/2 along y); the box is 8 radii long, so the radius is `N / 8` cells.
const N: usize = 48;
/// `D` is averaged over `t` in `[T_SETTLED, T_END]` (in units of `1 / gamma`).
const T_SETTLED: f64 = 2.0;
const T_END: f64 = 4.0;
/// `D` is measured every `SAMPLE` time units.
const SAMPLE: f64 = 0.1;
/// The largest `|D / D_theory - 1|` accepted (this grid gives -2.4 %, and `D` swings by about
/// +-6 % around its mean in the averaging window).
const TOLERANCE: f64 = 0.10;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // --- The box and the walls -----------------------------------------------------------
    // The paper's box in units of the capsule radius a = 1: [-4, 4] x [-2, 2] x [-4, 4],
    // periodic along x (the flow) and y (the vorticity), walls at z = -4 and z = +4 moving at
    // -4 and +4 along x: a shear rate gamma = 1, so the time unit is 1 / gamma.
    let radius = 1.0;
    let half = [4.0, 2.0, 4.0];
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] =
        [Boundary::Wall { velocity: [-half[2], 0.0, 0.0] }, Boundary::Wall { velocity: [half[2], 0.0, 0.0] }];
    let grid = Grid::<f64>::new([N, N / 2, N], half.map(|x| -x), half, bc)?;

    // --- The fluids and the membrane -------------------------------------------------------
    // The same fluid inside and out (viscosity ratio 1), density 1 and viscosity 100: the
    // Reynolds number rho gamma a^2 / mu = 0.01, nearly Stokes flow as in the theory. The
    // membrane modulus follows from Ca: E_s = mu gamma a / Ca (`NeoHookean::new` takes the E_s
    // of (2.5), three times the shear modulus G_s).
    let mu = 100.0;
    let es = mu * radius / CA;

    // The library's defaults. The elasticity's traction, `Traction::SharpResampled`, makes the
    // membrane move and pull as one surface (the closest point on phi = 1/2, whose `G_s` the
    // whole shell carries) instead of the paper's stack of layers across the smoothed shell
    // (`.traction(Traction::Smoothed)`). On a grid this coarse the paper's traction overshoots:
    // with it this run gives D = 0.206 over t in [1, 3], still falling at t = 6 (0.177), 13-32 %
    // above the theory (measured; the two are compared in docs/validation/shear_capsule.md).
    let elasticity = Elasticity::new(NeoHookean::new(es)?);

    // A scene is a description: the box and outer fluid, one capsule (its initial shape is its
    // unstressed reference shape), the in-plane elasticity of its membrane; the grid-wide
    // numerical settings stay the defaults (`Scene::settings` would replace them). `build`
    // checks it and allocates only what it needs (no bending here: no curvature fields).
    let mut sim = Scene::new(grid, Phase::new(1.0, mu)?) // rho, mu
        .capsule(Sphere::new([0.0; 3], radius)?)
        .effect(elasticity)
        .build()?;
    // Start from the undisturbed shear u = gamma z instead of from rest.
    sim.set_velocity(|x| [x[2], 0.0, 0.0])?;

    // --- Time stepping ---------------------------------------------------------------------
    // Adaptive steps: each step is the largest that keeps the Courant number at its default
    // target (0.3) and within the membrane's stability limit, at most 0.05; a step that fails
    // is taken again smaller. Here the walls' speed sets the step: 0.3 h / 4 = 0.0125.
    let mut stepping = AdaptiveDt::new(0.05)?;
    let v0 = sim.volume(0)?;
    let clock = Instant::now();
    eprintln!("capsule_in_shear: Ca = {CA}, grid {N} x {} x {N}, {} cells per radius", N / 2, N / 8);

    // Advance to each sample time in turn (adaptive steps land on it exactly) and measure D on
    // the section y = y_c through the centroid (normal to axis 1): the least-squares ellipse
    // through the phi = 1/2 contour, as in Sec. 3.3.1.
    let mut settled = Vec::new(); // D at the samples in [T_SETTLED, T_END]
    let (mut warned, mut retries) = (0, 0);
    let samples = (T_END / SAMPLE).round() as usize;
    for k in 1..=samples {
        let summary = sim.run_with(k as f64 * SAMPLE, &mut stepping, &mut [])?;
        warned += summary.warned_steps;
        retries += summary.retries;
        let t = sim.time();
        let taylor = taylor_deformation(sim.grid(), sim.phi(0)?, sim.centroid(0)?, 1)?;
        if t >= T_SETTLED - 1e-9 {
            settled.push(taylor.deformation);
        }
        // A progress line every time unit.
        if k % (1.0 / SAMPLE).round() as usize == 0 {
            eprintln!(
                "t = {t:.1}  D = {:.4}  angle = {:.1} deg  steps = {}  mean dt = {:.2e}  \
                 volume drift = {:.1e}  ({:.0} s)",
                taylor.deformation,
                taylor.angle_deg,
                sim.steps(),
                t / sim.steps() as f64,
                (sim.volume(0)? - v0).abs() / v0,
                clock.elapsed().as_secs_f64()
            );
        }
    }
    if warned > 0 || retries > 0 {
        eprintln!("note: {warned} steps carried a warning, {retries} steps were retried smaller");
    }

    // --- The result --------------------------------------------------------------------------
    // D: the mean over the settled window; its spread (min, max) and `drift`, the mean of the
    // window's second half minus that of its first half over the mean, say how settled it is.
    let mean = |d: &[f64]| d.iter().sum::<f64>() / d.len() as f64;
    let d = mean(&settled);
    let (first, second) = settled.split_at(settled.len() / 2);
    let drift = (mean(second) - mean(first)) / d;
    let d_min = settled.iter().copied().fold(f64::INFINITY, f64::min);
    let d_max = settled.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let d_theory = 25.0 * CA / 4.0; // Barthès-Biesel (1980), neo-Hookean, Ca = mu gamma a / E_s
    let rel_err = d / d_theory - 1.0;
    let volume_drift = (sim.volume(0)? - v0).abs() / v0; // the VOF transport conserves volume
    println!(
        "RESULT ca={CA} n={N} d={d:.4e} d_theory={d_theory:.5} rel_err={rel_err:.4e} d_min={d_min:.4e} \
         d_max={d_max:.4e} drift={drift:.3e} volume_drift={volume_drift:.2e} steps={} wall_s={:.1}",
        sim.steps(),
        clock.elapsed().as_secs_f64()
    );
    if rel_err.abs() > TOLERANCE {
        return Err(format!(
            "D = {d:.4} is {:.1} % from the small-deformation theory 25 Ca / 4 = {d_theory:.4} \
             (tolerance {:.0} %)",
            100.0 * rel_err,
            100.0 * TOLERANCE
        )
        .into());
    }
    Ok(())
}
