//! The capsule in simple shear flow of Sec. 3.3, shared by the `shear_capsule`,
//! `accuracy_cost` and `stability` examples: the scene, a run that records the Taylor
//! deformation `D(t)`, and the published late-time values.
//!
//! Set-up (the paper's box, [`ShearCase::PAPER_BOX`]): `x in [-4, 4]`, `y in [-2, 2]`,
//! `z in [-4, 4]` on `(N, N/2, N)` cells, periodic in x and y, walls `z = -4, 4` moving at
//! `-4, +4` along x (shear rate 1; a larger box keeps `h = 8/N` and the shear rate), a sphere of radius
//! `a = 1` at the origin, `rho = 1`, `Re = rho a^2 / mu = 0.01` so `mu = 100`,
//! `E_s = mu a / Ca` (neo-Hookean), bending `E_b = E_b' a^2 E_s`. The flow starts as the
//! undisturbed shear `u = z`. Time is in units of the inverse shear rate.

use crate::Terms;
use crate::csv::CsvWriter;
use eulermembrane::Real;
use eulermembrane::diagnostics::{
    ellipsoid::ellipsoid_fit, energy::body_force_power, taylor::taylor_deformation,
};
use eulermembrane::grid::{Boundary, Grid, VectorField};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::io::vtk::PvdSeries;
use eulermembrane::membrane::{law::NeoHookean, wrinkling::TensionField};
use eulermembrane::simulation::{
    Phase, Scene, Settings, Simulation,
    timestep::{AdaptiveDt, FixedDt, TimeStepping},
};
use std::path::Path;
use std::time::Instant;

/// Viscosity of the suspending fluid (`Re = 0.01`).
pub const MU: f64 = 100.0;

/// Late-time Taylor deformation of Ramanujan & Pozrikidis (1998), boundary elements, Stokes
/// flow, viscosity ratio 1: `(Ca, D)`.
pub const LATE_TIME_D: [(f64, f64); 4] = [(0.025, 0.150), (0.05, 0.261), (0.1, 0.384), (0.2, 0.500)];

/// Late-time Taylor deformation with bending, Pozrikidis (2001), boundary elements (mean of
/// `cases/reference/shear_bending/pozrikidis_2001_ca_0.05_eb_0.0375.csv` over `t` = 1-1.8;
/// published spread 0.13-0.165): `(Ca, E_b', D)`.
pub const BENDING_LATE_TIME_D: [(f64, f64, f64); 1] = [(0.05, 0.0375, 0.143)];

/// The published late-time `D` at `ca` and reduced bending modulus `eb_prime` (0: none), if
/// there is one.
pub fn reference_d(ca: f64, eb_prime: f64) -> Option<f64> {
    let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-9;
    if eb_prime == 0.0 {
        LATE_TIME_D.iter().find(|(c, _)| close(*c, ca)).map(|&(_, d)| d)
    } else {
        BENDING_LATE_TIME_D.iter().find(|(c, e, _)| close(*c, ca) && close(*e, eb_prime)).map(|&(_, _, d)| d)
    }
}

/// One shear-flow run.
#[derive(Clone, Debug)]
pub struct ShearCase {
    /// Cells along x (and z); `N/2` along y.
    pub n: usize,
    /// Capillary number `mu a / E_s`.
    pub ca: f64,
    /// Reduced bending modulus `E_b / (a^2 E_s)`; none if zero.
    pub eb_prime: f64,
    /// Viscosity inside over viscosity outside.
    pub lambda: f64,
    /// Time step: every step with [`Steps::Fixed`], the largest with [`Steps::Adaptive`].
    pub dt: f64,
    /// End time.
    pub t_end: f64,
    /// How the steps are chosen.
    pub steps: Steps,
    /// The box's lengths along x, y, z in capsule radii, centred on the capsule (the paper's:
    /// [`ShearCase::PAPER_BOX`]); the spacing stays `8 / N`, so a larger box has more cells.
    pub box_radii: [f64; 3],
    /// The membrane law with the modulus `E_s = mu a / Ca`.
    pub law: ShearLaw,
}

/// The membrane of a shear run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShearLaw {
    /// The neo-Hookean law (2.5), as the paper and the boundary-element references.
    #[default]
    NeoHookean,
    /// Its tension-field relaxation ([`TensionField`]): a membrane that wrinkles instead of
    /// carrying compression.
    TensionField,
}

impl ShearLaw {
    /// The name of the `--law` flag and of the RESULT key `law`: `neo_hookean`, `tension_field`.
    pub fn name(self) -> &'static str {
        match self {
            ShearLaw::NeoHookean => "neo_hookean",
            ShearLaw::TensionField => "tension_field",
        }
    }

    /// The law of a [`name`](Self::name).
    pub fn from_name(s: &str) -> Result<Self, String> {
        [ShearLaw::NeoHookean, ShearLaw::TensionField]
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| format!("--law: neo_hookean or tension_field, got {s}"))
    }
}

impl ShearCase {
    /// The box of Sec. 3.3: `8 x 4 x 8` radii, so periodic images 8 radii apart along the flow
    /// and 4 along the vorticity, and walls 4 radii from the centre.
    pub const PAPER_BOX: [f64; 3] = [8.0, 4.0, 8.0];
}

/// How a shear run chooses its steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Steps {
    /// Every step is [`ShearCase::dt`] (the last one lands within `dt / 2` of the end).
    Fixed,
    /// [`AdaptiveDt`] with this Courant target and at most [`ShearCase::dt`], landing on the
    /// end time.
    Adaptive {
        /// The target Courant number `max|v| dt / h`.
        cfl: f64,
    },
}

/// A sample of the history.
#[derive(Clone, Copy, Debug)]
pub struct ShearSample {
    /// Time.
    pub t: f64,
    /// Taylor deformation `D`.
    pub d: f64,
    /// Inclination of the major axis to the flow, degrees.
    pub angle_deg: f64,
    /// Surface area `sum delta h^3` over its initial value.
    pub area_ratio: f64,
    /// Relative volume change since t = 0.
    pub volume_drift: f64,
    /// Predictor iterations of the step.
    pub iterations: usize,
    /// The step that reached this sample (0 at `t` = 0).
    pub dt: f64,
    /// `D = (a - c)/(a + c)` of the ellipsoid of equal volume and inertia (`ellipsoid_fit`).
    pub d_ellipsoid: f64,
    /// Inclination of that ellipsoid's longest axis in the x-z plane, from x towards z, degrees.
    pub angle_ellipsoid_deg: f64,
    /// The membrane's stored energy `E` ([`Simulation::elastic_energy`]).
    pub elastic_energy: f64,
    /// The work `W` the fluid has done on the membrane since `t` = 0: the power
    /// `P = -sum v . F dV` of the membrane force `F` on the fluid ([`Simulation::membrane_force`],
    /// [`body_force_power`]) after each step, integrated by the trapezoid rule over the steps.
    /// Without losses `E(t) - E(0) = W(t)`: the energy identity of the coupling (the membrane
    /// takes from the fluid the power that its traction does on it). NaN with [`Energy::Skip`].
    pub membrane_work: f64,
}

/// Whether a run checks the energy identity of the coupling: the work `W` the fluid does on the
/// membrane, integrated over every step, against the stored energy `E`. It evaluates the
/// membrane force once more per step (about a fifth of a step at 8 cells per radius).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Energy {
    /// Record `E` only (`W` and `energy_leak` NaN).
    Skip,
    /// Record `E` and `W`.
    Identity,
}

/// What a run measured.
#[derive(Clone, Debug)]
pub struct ShearOutcome {
    /// The history.
    pub samples: Vec<ShearSample>,
    /// Mean `D` over the last time unit.
    pub d_steady: f64,
    /// Mean inclination over the last time unit, degrees.
    pub angle_steady: f64,
    /// Mean ellipsoid `D` over the last time unit.
    pub d_ellipsoid_steady: f64,
    /// Mean ellipsoid inclination over the last time unit, degrees.
    pub angle_ellipsoid_steady: f64,
    /// Largest relative volume change.
    pub max_volume_drift: f64,
    /// Wall-clock seconds of the time loop.
    pub wall_s: f64,
    /// CPU seconds of the time loop on the calling thread (see [`super::cpu_seconds`]).
    pub cpu_s: f64,
    /// Steps taken.
    pub steps: usize,
    /// The time reached.
    pub t_end: f64,
    /// The membrane's reference area `s_0` (`Simulation::reference_area`) at the end over its
    /// initial value.
    pub s0_ratio: f64,
    /// The energy the coupling loses over the last time unit, relative:
    /// `(Delta W - Delta E) / (Delta t mean E)`, the work received less the energy stored,
    /// per unit time and per unit of stored energy (positive: energy lost, as a dissipative
    /// scheme would; negative: energy created). NaN without a stored energy.
    pub energy_leak: f64,
    /// Core cells of the re-sampled sharp shell whose crushed `G_s` was re-set over the run
    /// (`StepReport::repaired_cells`, summed).
    pub repaired_cells: usize,
}

impl ShearOutcome {
    /// The largest `|D - D_ref| / D_ref` over the points `(t, D_ref)` of `curve` with `t` in
    /// `times` that the history covers (`D` interpolated linearly); NaN where none is covered.
    pub fn max_curve_err(&self, curve: &[(f64, f64)], times: std::ops::RangeInclusive<f64>) -> f64 {
        let d_at = |t: f64| {
            self.samples.windows(2).find(|w| w[0].t <= t && t <= w[1].t).map(|w| {
                let f = if w[1].t > w[0].t { (t - w[0].t) / (w[1].t - w[0].t) } else { 0.0 };
                w[0].d + f * (w[1].d - w[0].d)
            })
        };
        curve
            .iter()
            .filter(|(t, _)| times.contains(t))
            .filter_map(|&(t, d_ref)| d_at(t).map(|d| (d - d_ref).abs() / d_ref))
            .fold(f64::NAN, f64::max)
    }
}

/// The scene of Sec. 3.3 in precision `T`, with `settings` and the membrane terms' options `terms`.
pub fn build<T: Real>(
    case: &ShearCase,
    settings: Settings<T>,
    terms: Terms,
) -> eulermembrane::Result<Simulation<T>> {
    let n = case.n;
    if n < 16 || !n.is_multiple_of(2) {
        return Err(eulermembrane::Error::invalid("--n", n, "an even number of cells >= 16"));
    }
    let h = 8.0 / n as f64;
    let mut cells = [0usize; 3];
    for (c, &l) in cells.iter_mut().zip(&case.box_radii) {
        let k = (l / h).round();
        if !(l > 0.0 && k >= 4.0 && (k * h - l).abs() < 1e-9 * l) {
            return Err(eulermembrane::Error::invalid(
                "box_radii",
                format!("{:?}", case.box_radii),
                "positive lengths, each a multiple of the spacing 8/N of at least 4 cells",
            ));
        }
        *c = k as usize;
    }
    let half = case.box_radii.map(|l| T::lit(l / 2.0));
    let u = half[2];
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [
        Boundary::Wall { velocity: [-u, T::zero(), T::zero()] },
        Boundary::Wall { velocity: [u, T::zero(), T::zero()] },
    ];
    let grid = Grid::new(cells, half.map(|x| -x), half, bc)?;
    let es = MU / case.ca;
    let mut scene = Scene::new(grid, Phase::new(T::one(), T::lit(MU))?)
        .inside(Phase::new(T::one(), T::lit(MU * case.lambda))?)
        .capsule(Sphere::new([0.0; 3], 1.0)?)
        .settings(settings);
    let law = NeoHookean::new(T::lit(es))?;
    scene = match case.law {
        ShearLaw::NeoHookean => scene.effect(terms.elasticity(law)),
        ShearLaw::TensionField => scene.effect(terms.elasticity(TensionField::new(law))),
    };
    if case.eb_prime > 0.0 {
        scene = scene.effect(terms.bending(T::lit(case.eb_prime * es))?);
    }
    let mut sim = scene.build()?;
    sim.set_velocity(|x| [x[2], T::zero(), T::zero()])?;
    Ok(sim)
}

/// Runs `case` to its end time, measuring `D` every `sample_every` time units, printing
/// progress to stderr every 5 %. With `out = Some((dir, vtk_every))` it writes the history
/// `dir/history.csv` as it goes (flushed with each progress line, so that a run that fails
/// leaves its history so far) and a VTK snapshot every `vtk_every` time units (0: none).
/// `energy` says whether it integrates the membrane's work for the energy identity.
pub fn run<T: Real>(
    case: &ShearCase,
    settings: Settings<T>,
    terms: Terms,
    sample_every: f64,
    out: Option<(&Path, f64)>,
    quiet: bool,
    energy: Energy,
) -> Result<ShearOutcome, Box<dyn std::error::Error>> {
    let mut history = match out {
        Some((dir, _)) => Some(CsvWriter::create(
            dir.join("history.csv"),
            &[
                "t",
                "d",
                "angle_deg",
                "area_ratio",
                "volume_drift",
                "iterations",
                "dt",
                "elastic_energy",
                "membrane_work",
            ],
        )?),
        None => None,
    };
    let mut sim = build(case, settings, terms)?;
    // The expected number of steps (exact for fixed steps; for adaptive ones the progress
    // lines estimate it from the time reached).
    let expected = (case.t_end / case.dt).round().max(1.0) as usize;
    let mut stepping: Box<dyn TimeStepping<T>> = match case.steps {
        Steps::Fixed => Box::new(FixedDt::new(T::lit(case.dt))?),
        Steps::Adaptive { cfl } => Box::new(AdaptiveDt::new(case.dt)?.cfl(cfl)?),
    };
    let until = T::lit(case.t_end);
    let v0 = sim.volume(0)?;
    let a0 = sim.area(0)?;
    let s00 = sim.reference_area(0)?.unwrap_or(f64::NAN);
    // Fixed steps sample every `every` steps (and the last), adaptive ones at the first step
    // past each multiple of `sample_every` (and the last).
    let every = ((sample_every / case.dt).round() as usize).max(1);
    let mut next_sample = sample_every;
    let mut samples = Vec::new();
    let mut pvd = PvdSeries::new();
    let mut next_vtk = 0.0;
    let mut max_drift = 0.0f64;
    let clock = Instant::now();
    let cpu0 = super::cpu_seconds();
    let (mut iterations, mut dt, mut s) = (0, 0.0, 0usize);
    // The membrane force for the energy identity (allocated once), its power on the membrane
    // after the last step, and the work integrated so far.
    let mut force = match energy {
        Energy::Identity => Some(VectorField::zeros(sim.grid())),
        Energy::Skip => None,
    };
    let mut power = |sim: &mut Simulation<T>, dt: f64| -> eulermembrane::Result<f64> {
        let Some(f) = force.as_mut() else { return Ok(f64::NAN) };
        f.c.iter_mut().for_each(|c| c.fill(T::zero()));
        sim.membrane_force(T::lit(dt), f)?;
        Ok(-body_force_power(sim.grid(), sim.flow().velocity(), f)?)
    };
    let (mut p_last, mut work) = (power(&mut sim, case.dt)?, 0.0);
    // The last step's Courant number, and the retries and warnings since the last progress line.
    let (mut courant, mut retries, mut warned) = (0.0, 0usize, None);
    let mut repaired_cells = 0;
    loop {
        let t = sim.time().f64();
        // Whether to sample, and whether this is the last step (fixed steps know it, adaptive
        // ones land on `t_end`).
        let (due, at_end) = match case.steps {
            Steps::Fixed => (s.is_multiple_of(every), t + 0.5 * case.dt >= case.t_end),
            Steps::Adaptive { .. } => {
                (s == 0 || t >= next_sample - 1e-9 * sample_every, t >= case.t_end * (1.0 - 1e-12))
            }
        };
        if due || at_end {
            while next_sample <= t + 1e-9 * sample_every {
                next_sample += sample_every;
            }
            let drift = (sim.volume(0)? - v0).abs() / v0;
            max_drift = max_drift.max(drift);
            let centre = sim.centroid(0)?;
            let td = taylor_deformation(sim.grid(), sim.phi(0)?, centre, 1)?;
            let ef = ellipsoid_fit(sim.grid(), sim.phi(0)?)?;
            let sample = ShearSample {
                t,
                d: td.deformation,
                angle_deg: td.angle_deg,
                area_ratio: sim.area(0)? / a0,
                volume_drift: drift,
                iterations,
                dt,
                d_ellipsoid: ef.deformation(),
                // NaN where the longest axis is not in the x-z plane (the sphere at t = 0).
                angle_ellipsoid_deg: ef.inclination_deg(1).unwrap_or(f64::NAN),
                elastic_energy: sim.elastic_energy(),
                membrane_work: work,
            };
            if let Some(h) = history.as_mut() {
                h.row(&[
                    t,
                    sample.d,
                    sample.angle_deg,
                    sample.area_ratio,
                    drift,
                    iterations as f64,
                    dt,
                    sample.elastic_energy,
                    work,
                ])?;
            }
            samples.push(sample);
        }
        if let Some((dir, every_t)) = out
            && every_t > 0.0
            && t >= next_vtk - 1e-9
        {
            let name = format!("shear_{s:06}.vti");
            sim.write_vti(dir.join(&name))?;
            pvd.push(t, name);
            next_vtk += every_t;
        }
        // Progress against the expected steps (adaptive: extrapolated from the time reached).
        let total = match case.steps {
            Steps::Fixed => expected,
            Steps::Adaptive { .. } if t > 0.0 => ((s as f64) * case.t_end / t).round() as usize,
            Steps::Adaptive { .. } => expected,
        }
        .max(s);
        if !quiet && s > 0 && super::progress_due(s, total) {
            let last = samples.last().expect("sampled at step 0");
            // The last sample may be up to `sample_every` older than the step: say when.
            let extra = format!(
                "D={:.4} angle={:.1} area={:.4} (sampled at t={:.3}) iters={iterations} dt={dt:.2e} \
                 courant={courant:.3} retries={retries}",
                last.d, last.angle_deg, last.area_ratio, last.t
            );
            super::progress(s, total, t, &clock, &extra);
            if let Some((at, w)) = warned.take() {
                eprintln!("  warning (last at t={at:.4}): {w}");
            }
            retries = 0;
        }
        if let Some(h) = history.as_mut()
            && super::progress_due(s, total)
        {
            h.flush()?;
        }
        let Some(report) = stepping.advance(&mut sim, until)? else { break };
        s += 1;
        iterations = report.flow.predictor_iterations;
        dt = report.flow.dt;
        let p = power(&mut sim, dt)?;
        work += 0.5 * (p_last + p) * dt;
        p_last = p;
        courant = report.flow.cfl;
        retries += report.retries;
        repaired_cells += report.repaired_cells;
        if let Some(w) = report.warning {
            warned = Some((sim.time().f64(), w));
        }
    }
    if let Some(h) = history {
        h.finish()?;
    }
    let (wall_s, cpu_s) = (clock.elapsed().as_secs_f64(), super::cpu_seconds() - cpu0);
    if let Some((dir, every_t)) = out
        && every_t > 0.0
    {
        pvd.write(dir.join("shear.pvd"))?;
    }
    let t_end = sim.time().f64();
    let last: Vec<&ShearSample> = samples.iter().filter(|s| s.t >= t_end - 1.0 - 1e-9).collect();
    let mean = |f: fn(&ShearSample) -> f64| last.iter().map(|s| f(s)).sum::<f64>() / last.len() as f64;
    let energy_leak = match (last.first(), last.last()) {
        (Some(a), Some(b)) if b.t > a.t => {
            let (de, dw) = (b.elastic_energy - a.elastic_energy, b.membrane_work - a.membrane_work);
            let e = mean(|s| s.elastic_energy);
            if e > 0.0 { (dw - de) / ((b.t - a.t) * e) } else { f64::NAN }
        }
        _ => f64::NAN,
    };
    Ok(ShearOutcome {
        energy_leak,
        repaired_cells,
        d_steady: mean(|s| s.d),
        angle_steady: mean(|s| s.angle_deg),
        d_ellipsoid_steady: mean(|s| s.d_ellipsoid),
        angle_ellipsoid_steady: mean(|s| s.angle_ellipsoid_deg),
        max_volume_drift: max_drift,
        wall_s,
        cpu_s,
        steps: s,
        t_end,
        s0_ratio: sim.reference_area(0)?.unwrap_or(f64::NAN) / s00,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use eulermembrane::simulation::Settings;

    fn case(box_radii: [f64; 3]) -> ShearCase {
        ShearCase {
            n: 16,
            ca: 0.05,
            eb_prime: 0.0,
            lambda: 1.0,
            dt: 0.01,
            t_end: 0.1,
            steps: Steps::Fixed,
            box_radii,
            law: ShearLaw::NeoHookean,
        }
    }

    #[test]
    fn the_box_keeps_the_spacing_and_the_shear_rate() {
        let paper = build::<f64>(&case(ShearCase::PAPER_BOX), Settings::default(), Terms::default()).unwrap();
        assert_eq!(paper.grid().n(), [16, 8, 16]);
        let tall = build::<f64>(&case([8.0, 8.0, 16.0]), Settings::default(), Terms::default()).unwrap();
        let g = tall.grid();
        assert_eq!(g.n(), [16, 16, 32]);
        assert_eq!((g.h(), g.lower(), g.upper()), ([0.5; 3], [-4.0, -4.0, -8.0], [4.0, 4.0, 8.0]));
        // walls moving at -L_z/2 and +L_z/2: shear rate 1, as in the paper's box
        let [Boundary::Wall { velocity: low }, Boundary::Wall { velocity: high }] = g.bc(2) else {
            panic!("walls along z: {:?}", g.bc(2))
        };
        assert_eq!((low[0], high[0]), (-8.0, 8.0));
    }

    #[test]
    fn a_box_off_the_grid_is_refused() {
        for bad in [[8.0, 4.1, 8.0], [8.0, 0.0, 8.0], [8.0, 1.0, 8.0], [f64::NAN, 4.0, 8.0]] {
            let e = build::<f64>(&case(bad), Settings::default(), Terms::default()).err().expect("refused");
            assert!(e.to_string().contains("box_radii"), "{bad:?}: {e}");
        }
    }
}
