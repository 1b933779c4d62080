//! A sheared suspension: neo-Hookean capsules, spheres of radius `a = 1` at the
//! start, placed at random (`interface::placement`, reproducible from `--seed`) at the volume
//! fraction `--phi` between two walls `z = -L_z/2, +L_z/2` that slide at `-L_z/2, +L_z/2` along x
//! (shear rate 1; periodic in x and y). The fluid is that of Sec. 3.3 (`shear_capsule`):
//! `rho = 1`, `mu = 100` inside and outside (`Re = rho a^2 / mu = 0.01`), the membrane
//! `E_s = mu a / Ca` (neo-Hookean (2.5)); the flow starts as the undisturbed shear `u = z`, and
//! time is in units of the inverse shear rate. The capsules are kept apart by
//! `simulation::contact::Contact` (a disjoining pressure `--contact` times `mu gamma_dot` at zero gap,
//! within `--contact-range` cells).
//!
//! Measured every `--sample-every` time units: the relative effective viscosity `mu_eff / mu`
//! from the walls (`diagnostics::suspension::wall_shear_stress` over `couette_shear_rate`) and
//! from the particle stress (Batchelor 1970: the first moment of the membrane force
//! `Simulation::membrane_force`, `particle_stress` then `shear_rheology`), the normal stress
//! differences `N1`, `N2` over `mu gamma_dot`, the mean Taylor deformation `D` and inclination of
//! the capsules' sections in the flow-gradient plane (`capsule_shapes`), the smallest gap between
//! two membranes in cells (`min_gap_cells`) and the largest relative volume change of any capsule.
//!
//! Prints a progress line every twentieth of the run (time, step, dt, both `mu_eff`, mean `D`,
//! min gap, the last step's predictor iterations and `max|v|`, retried steps, wall time); writes into `--out` the time series `history.csv` (written as the run
//! goes), the plot `viscosity.svg` of `mu_eff / mu` against time (both estimates, with the
//! rigid-sphere dilute value `1 + 2.5 phi` for scale), `capsules.csv` (every capsule's start and
//! end), and ParaView snapshots of all capsules (`suspension.pvd`); ends with
//! `RESULT phi=... phi_target=... ca=... n=... cells_per_radius=... capsules=... mu_eff_wall=...
//! mu_eff_wall_std=... mu_eff_stresslet=... n1=... n2=... d_mean=... incl_deg=... mu_dilute_rigid=...
//! min_gap_cells=... vol_drift_max=... steps=... wall_s=... t_end=... average_from=... failed_at=...
//! repaired=... traction=... contact=... seed=... placement=... box=... storage=...`: the viscosities, `n1`, `n2`, `d_mean` and
//! `incl_deg` averaged over the samples with `t >= --average-from`; `mu_eff_wall_std` the standard
//! deviation of the wall estimate over them; `min_gap_cells` the smallest gap over every step;
//! `failed_at` the time of a step that failed (`none`: the run reached `--t-end`); `repaired` the
//! shell cells whose crushed `G_s` the re-sampled sharp traction re-set
//! (`StepReport::repaired_cells`, summed over the steps of this run).
//!
//! Steps: adaptive (`simulation::timestep::AdaptiveDt`, Courant target `--cfl`), at most `--max-dt` and at
//! most the contact's explicit limit `0.4 mu r / (p0 h)` (the step at which `tests/contact.rs`
//! is stable; `Contact` declares no limit of its own).
//!
//! Flags: `--n` (40: cells along z, the wall-normal axis; the spacing is `L_z / N`, so
//! `N / L_z` cells per radius, 5 by default), `--box LX,LY,LZ` (the box in radii, `8,4,8`: the
//! box of `shear_capsule`; each a multiple of the spacing), `--phi` (0.1; the placed fraction is
//! the nearest whole number of capsules), `--ca` (0.05), `--t-end` (4), `--average-from` (half
//! of `--t-end`), `--seed` (1), `--gap` (2: the smallest gap between two surfaces at the start,
//! in cells), `--wall-distance` (5: the smallest distance from a surface to a wall at the start,
//! in cells; at least 4.5, since a membrane band within two cells of a wall stops the run),
//! `--contact` (50; 0 for none), `--contact-range` (2 cells), `--cfl` (0.3), `--max-dt` (0.05),
//! `--sample-every` (0.05), `--shake S` (0: random sequential addition; `S > 0`: the capsules
//! on a lattice shaken by `S` sweeps of hard-sphere Monte Carlo moves,
//! `placement::Method::ShakenLattice`, for fractions sequential addition does not reach),
//! `--checkpoint-every T` (0: none; the whole state to `checkpoint.bin` in `--out` every `T`
//! time units, the history flushed with it), `--restart FILE` (continues a run from such a file
//! with the same flags and `--out`: the history up to the checkpoint's time is kept, the steps
//! after it are chosen anew, so the run is not bit for bit the uninterrupted one; the smallest
//! gap before the restart is that of the samples),
//! `--room R` (each capsule on a box that follows it,
//! `CapsuleStorage::Boxed { room: R }`; 0, the default, keeps every capsule on the whole grid),
//! `--traction sharp-resampled|sharp|smoothed` (`Elasticity::traction`, default
//! `sharp-resampled`, as `shear_capsule`), `--vtk-every` (1, time units; 0 for none), `--out DIR`
//! (`out/suspension`).
//!
//! Run: `cargo run --release -p eulermembrane-cases --example suspension` (6 capsules,
//! `phi` = 0.098, 5 cells per radius, 40 x 20 x 40 cells: about 3 minutes of CPU). At 4 cells
//! per radius (`--n 32 --gap 1`, about 2.5 minutes) the films close to a third of a cell and the
//! averages are not steady by `t` = 4; see `docs/validation/suspension.md`.

use eulermembrane_cases as common;

use common::csv::CsvWriter;
use common::plot::{Figure, LineStyle};
use common::shear::MU;
use common::{Args, BoxResult, num, result};
use eulermembrane::diagnostics::suspension::{
    ShearFrame, capsule_shapes, couette_shear_rate, particle_stress, wall_shear_stress,
};
use eulermembrane::grid::{Boundary, Field, Grid, VectorField};
use eulermembrane::interface::placement::{Domain, Method, Placed, Placement, Prototype, Target};
use eulermembrane::io::vtk::PvdSeries;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{
    CapsuleStorage, Elasticity, Phase, Scene, Settings, Simulation, Traction,
    contact::{Contact, min_gap_cells},
    timestep::{AdaptiveDt, TimeStepping},
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The capsule radius (the unit of length).
const RADIUS: f64 = 1.0;
/// The shear frame: flow along x, velocity gradient along z (the walls' normal), vorticity y.
const FLOW: usize = 0;
const GRADIENT: usize = 2;
/// The smallest distance from a capsule's surface to a wall that the run survives, in cells: a
/// band cell (`delta h >= 0.01`, 2.6 cells from the surface) must keep two cells
/// (`membrane::band::WALL_CLEARANCE`) from the wall, and `Scene::build` asks for 4.
const MIN_WALL_CELLS: f64 = 4.5;

fn main() {
    common::exit_on_error(run());
}

/// The run's parameters, from the flags, checked.
struct Config {
    n: usize,
    box_radii: [f64; 3],
    phi: f64,
    ca: f64,
    t_end: f64,
    average_from: f64,
    seed: u64,
    gap_cells: f64,
    wall_cells: f64,
    contact: f64,
    contact_range: f64,
    cfl: f64,
    max_dt: f64,
    sample_every: f64,
    vtk_every: f64,
    traction: Traction,
    storage: CapsuleStorage,
    method: Method,
    /// Time between checkpoints (0: none).
    checkpoint_every: f64,
    /// The checkpoint a run continues from.
    restart: Option<PathBuf>,
}

/// `Err` with `msg` unless `ok`.
fn check(ok: bool, msg: impl FnOnce() -> String) -> BoxResult<()> {
    if ok { Ok(()) } else { Err(msg().into()) }
}

impl Config {
    fn from_args(args: &Args) -> BoxResult<Self> {
        let n: usize = args.get("n", 40);
        let box_radii: [f64; 3] = match args.list::<f64>("box") {
            None => [8.0, 4.0, 8.0],
            Some(l) => l
                .try_into()
                .map_err(|l: Vec<f64>| format!("--box: three lengths LX,LY,LZ, got {}", l.len()))?,
        };
        let t_end: f64 = args.get("t-end", 4.0);
        let c = Config {
            n,
            box_radii,
            phi: args.get("phi", 0.1),
            ca: args.get("ca", 0.05),
            t_end,
            average_from: args.get("average-from", 0.5 * t_end),
            seed: args.get("seed", 1),
            gap_cells: args.get("gap", 2.0),
            wall_cells: args.get("wall-distance", 5.0),
            contact: args.get("contact", 50.0),
            contact_range: args.get("contact-range", 2.0),
            cfl: args.get("cfl", AdaptiveDt::DEFAULT_CFL),
            max_dt: args.get("max-dt", 0.05),
            sample_every: args.get("sample-every", 0.05),
            vtk_every: args.get("vtk-every", 1.0),
            // The library's default traction, the re-sampled sharp one: the validated capsule in
            // shear (docs/validation/shear_capsule.md). It holds the membrane's reference area,
            // cuts the coarse-grid overshoot of D of the paper's smoothed traction to a third at
            // 8 cells per radius and keeps a steady state to t = 12, which a suspension sheared
            // for tens of time units needs.
            traction: args.traction(Traction::default())?,
            storage: match args.get("room", 0.0) {
                r if r > 0.0 => CapsuleStorage::Boxed { room: r },
                _ => CapsuleStorage::Whole,
            },
            method: match args.get("shake", 0) {
                0 => Method::SequentialAddition,
                sweeps => Method::ShakenLattice { sweeps },
            },
            checkpoint_every: args.get("checkpoint-every", 0.0),
            restart: args.opt::<String>("restart").map(PathBuf::from),
        };
        check(n >= 16 && n.is_multiple_of(2), || format!("--n {n}: an even number of cells >= 16"))?;
        check(box_radii.iter().all(|l| l.is_finite() && *l > 0.0), || {
            format!("--box {box_radii:?}: three positive lengths in radii")
        })?;
        check(c.phi.is_finite() && c.phi > 0.0 && c.phi <= 0.3, || {
            format!("--phi {}: a volume fraction in (0, 0.3] (random placement jams above)", c.phi)
        })?;
        check(c.ca.is_finite() && c.ca > 0.0, || format!("--ca {}: a capillary number > 0", c.ca))?;
        check(t_end.is_finite() && t_end > 0.0, || format!("--t-end {t_end}: a time > 0"))?;
        check(c.average_from.is_finite() && c.average_from >= 0.0 && c.average_from < t_end, || {
            format!("--average-from {}: a time in [0, --t-end = {t_end})", c.average_from)
        })?;
        check(c.gap_cells.is_finite() && c.gap_cells >= 0.0, || {
            format!("--gap {}: a number of cells >= 0", c.gap_cells)
        })?;
        check(c.wall_cells.is_finite() && c.wall_cells >= MIN_WALL_CELLS, || {
            format!(
                "--wall-distance {}: at least {MIN_WALL_CELLS} cells (a membrane band within two cells \
                 of a wall stops the run)",
                c.wall_cells
            )
        })?;
        check(c.contact.is_finite() && c.contact >= 0.0, || {
            format!("--contact {}: a pressure in units of mu gamma_dot, >= 0 (0: no contact)", c.contact)
        })?;
        check(c.contact_range.is_finite() && c.contact_range > 0.0 && c.contact_range <= 4.0, || {
            format!("--contact-range {}: a number of cells in (0, 4]", c.contact_range)
        })?;
        check(c.cfl.is_finite() && c.cfl > 0.0 && c.cfl <= 1.0, || format!("--cfl {}: in (0, 1]", c.cfl))?;
        check(c.max_dt.is_finite() && c.max_dt > 0.0, || format!("--max-dt {}: a step > 0", c.max_dt))?;
        check(c.sample_every.is_finite() && c.sample_every > 0.0, || {
            format!("--sample-every {}: a time > 0", c.sample_every)
        })?;
        check(c.vtk_every.is_finite() && c.vtk_every >= 0.0, || {
            format!("--vtk-every {}: a time >= 0 (0: no snapshots)", c.vtk_every)
        })?;
        Ok(c)
    }

    /// The grid spacing `L_z / N`.
    fn h(&self) -> f64 {
        self.box_radii[2] * RADIUS / self.n as f64
    }

    /// Capsule radius over the spacing.
    fn cells_per_radius(&self) -> f64 {
        RADIUS / self.h()
    }

    /// The disjoining pressure `p0` of the contact (`--contact` times `mu gamma_dot`).
    fn contact_pressure(&self) -> f64 {
        self.contact * MU
    }

    /// The largest step: `--max-dt`, and the contact's explicit limit `0.4 mu r / (p0 h)`.
    fn step_limit(&self) -> f64 {
        match self.contact > 0.0 {
            true => self.max_dt.min(0.4 * MU * self.contact_range / self.contact_pressure()),
            false => self.max_dt,
        }
    }
}

/// The Couette box: cells, walls sliding at `-L_z/2, +L_z/2` (shear rate 1).
fn grid(cfg: &Config) -> BoxResult<Grid<f64>> {
    let h = cfg.h();
    let mut cells = [0usize; 3];
    for (d, (c, &l)) in cells.iter_mut().zip(&cfg.box_radii).enumerate() {
        let k = (l * RADIUS / h).round();
        check(k >= 4.0 && (k * h - l * RADIUS).abs() < 1e-9 * l, || {
            format!(
                "--box {:?} with --n {}: side {} ({l} radii) is not a whole number of cells of the \
                 spacing L_z / N = {h} (at least 4)",
                cfg.box_radii,
                cfg.n,
                ["x", "y", "z"][d]
            )
        })?;
        *c = k as usize;
    }
    let half = cfg.box_radii.map(|l| 0.5 * l * RADIUS);
    let u = half[2]; // walls at z = -L_z/2, +L_z/2 moving at -L_z/2, +L_z/2: shear rate 1
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[GRADIENT] = [Boundary::Wall { velocity: [-u, 0.0, 0.0] }, Boundary::Wall { velocity: [u, 0.0, 0.0] }];
    Ok(Grid::new(cells, half.map(|x| -x), half, bc)?)
}

/// The capsules' places at the volume fraction, a gap and a wall distance in cells: random
/// sequential addition, or a shaken lattice (`--shake`).
fn place(cfg: &Config, grid: &Grid<f64>) -> BoxResult<Placed> {
    let h = cfg.h();
    Placement::new(Domain::from_grid(grid), Prototype::sphere(RADIUS)?, Target::VolumeFraction(cfg.phi))
        .gap(cfg.gap_cells * h)
        .wall_distance(cfg.wall_cells * h)
        .seed(cfg.seed)
        .method(cfg.method)
        .place()
        .map_err(|e| {
            format!(
                "placing the capsules (--phi {}, --gap {}, --wall-distance {}, --box {:?}, --n {}): {e}",
                cfg.phi, cfg.gap_cells, cfg.wall_cells, cfg.box_radii, cfg.n
            )
            .into()
        })
}

/// The scene: the placed capsules, the neo-Hookean membrane, the contact; at the undisturbed
/// shear.
fn build(cfg: &Config, grid: Grid<f64>, placed: &Placed) -> BoxResult<Simulation<f64>> {
    let settings = Settings { storage: cfg.storage, ..Settings::default() };
    let mut scene = Scene::new(grid, Phase::new(1.0, MU)?).settings(settings);
    for shape in placed.shapes()? {
        scene = scene.capsule(shape);
    }
    scene = scene.effect(Elasticity::new(NeoHookean::new(MU * RADIUS / cfg.ca)?).traction(cfg.traction));
    if cfg.contact > 0.0 {
        scene = scene.effect(Contact::new(cfg.contact_pressure(), cfg.contact_range)?);
    }
    let mut sim = scene.build()?;
    sim.set_velocity(|x| [x[GRADIENT], 0.0, 0.0])?;
    Ok(sim)
}

/// Every capsule's `phi` on the whole grid (a capsule on a box holds it on its box only).
fn phis_on_grid(sim: &Simulation<f64>) -> BoxResult<Vec<Field<f64>>> {
    let g = sim.grid();
    (0..sim.capsule_count())
        .map(|c| {
            let mut f = Field::zeros(g);
            sim.window(c)?.add_to(sim.capsule_grid(c)?, sim.phi(c)?, g, &mut f)?;
            f.fill_ghosts(g);
            Ok(f)
        })
        .collect()
}

/// One sample of the history.
#[derive(Clone, Copy, Debug)]
struct Sample {
    t: f64,
    steps: usize,
    dt: f64,
    /// `mu_eff / mu` from the walls: both walls, the lower, the upper.
    mu_wall: f64,
    mu_wall_lower: f64,
    mu_wall_upper: f64,
    /// `mu_eff / mu` from the particle stress.
    mu_stresslet: f64,
    /// `N1`, `N2` over `mu gamma_dot`.
    n1: f64,
    n2: f64,
    d_mean: f64,
    d_max: f64,
    incl_mean_deg: f64,
    min_gap_cells: f64,
    vol_drift_max: f64,
    /// The largest net membrane force on a capsule over the total `sum |f| dV` (force-free: 0).
    net_force: f64,
    /// Faces with a force near two capsules or more (see `particle_stress`).
    shared_faces: usize,
}

const COLUMNS: [&str; 17] = [
    "t",
    "steps",
    "dt",
    "mu_eff_wall",
    "mu_eff_wall_lower",
    "mu_eff_wall_upper",
    "mu_eff_stresslet",
    "n1",
    "n2",
    "d_mean",
    "d_max",
    "incl_mean_deg",
    "min_gap_cells",
    "vol_drift_max",
    "net_force_rel",
    "shared_faces",
    "capsules",
];

impl Sample {
    /// The sample of a row of `history.csv` (as [`row`](Self::row) wrote it).
    fn from_row(r: &[f64]) -> Self {
        Sample {
            t: r[0],
            steps: r[1] as usize,
            dt: r[2],
            mu_wall: r[3],
            mu_wall_lower: r[4],
            mu_wall_upper: r[5],
            mu_stresslet: r[6],
            n1: r[7],
            n2: r[8],
            d_mean: r[9],
            d_max: r[10],
            incl_mean_deg: r[11],
            min_gap_cells: r[12],
            vol_drift_max: r[13],
            net_force: r[14],
            shared_faces: r[15] as usize,
        }
    }

    fn row(&self, capsules: usize) -> [f64; 17] {
        [
            self.t,
            self.steps as f64,
            self.dt,
            self.mu_wall,
            self.mu_wall_lower,
            self.mu_wall_upper,
            self.mu_stresslet,
            self.n1,
            self.n2,
            self.d_mean,
            self.d_max,
            self.incl_mean_deg,
            self.min_gap_cells,
            self.vol_drift_max,
            self.net_force,
            self.shared_faces as f64,
            capsules as f64,
        ]
    }
}

/// What the sampling needs between samples: the frame, the force field, the initial volumes.
struct Probe {
    frame: ShearFrame,
    rate: f64,
    force: VectorField<f64>,
    v0: Vec<f64>,
}

impl Probe {
    fn new(sim: &Simulation<f64>) -> BoxResult<Self> {
        let frame = ShearFrame::new(FLOW, GRADIENT)?;
        let rate = couette_shear_rate(sim.grid(), frame)?;
        let v0 = (0..sim.capsule_count()).map(|c| sim.volume(c)).collect::<Result<_, _>>()?;
        Ok(Probe { frame, rate, force: VectorField::zeros(sim.grid()), v0 })
    }

    /// Measures the state of `sim` (`dt`: the last step, for `membrane_force`, which does not
    /// depend on it; `steps` taken so far; `min_gap` the present smallest gap in cells).
    fn sample(
        &mut self,
        sim: &mut Simulation<f64>,
        dt: f64,
        steps: usize,
        min_gap: f64,
    ) -> BoxResult<Sample> {
        let k = sim.capsule_count();
        // The walls' view: the mean shear stress on both walls over mu gamma_dot.
        let wall = wall_shear_stress(sim.grid(), sim.velocity(), &sim.flow().materials().mu, self.frame)?;
        let wall_rel = |s: f64| s / (MU * self.rate);
        // The particles' view: the first moment of the membrane force (elasticity and contact)
        // of the present state, Batchelor's stresslet (viscosity ratio 1: no contrast term).
        for c in self.force.c.iter_mut() {
            c.fill(0.0);
        }
        sim.membrane_force(dt, &mut self.force)?;
        let phis = phis_on_grid(sim)?;
        let phis: Vec<&Field<f64>> = phis.iter().collect();
        let stress = particle_stress(sim.grid(), &self.force, &phis, None)?;
        let rheology = stress.shear_rheology(self.frame, MU, self.rate)?;
        let net_force = stress
            .capsules
            .iter()
            .map(|c| c.force.iter().map(|f| f * f).sum::<f64>().sqrt())
            .fold(0.0, f64::max)
            / stress.total_force.max(f64::MIN_POSITIVE);
        let shapes = capsule_shapes(sim.grid(), &phis, self.frame)?;
        let d: Vec<f64> = shapes.iter().map(|s| s.section.deformation).collect();
        let vol_drift_max =
            shapes.iter().zip(&self.v0).map(|(s, v0)| (s.volume - v0).abs() / v0).fold(0.0, f64::max);
        let stress_scale = MU * self.rate;
        Ok(Sample {
            t: sim.time(),
            steps,
            dt,
            mu_wall: wall.viscosity / MU,
            mu_wall_lower: wall_rel(wall.lower),
            mu_wall_upper: wall_rel(wall.upper),
            mu_stresslet: rheology.relative_viscosity,
            n1: rheology.n1 / stress_scale,
            n2: rheology.n2 / stress_scale,
            d_mean: d.iter().sum::<f64>() / k as f64,
            d_max: d.iter().cloned().fold(0.0, f64::max),
            incl_mean_deg: shapes.iter().map(|s| s.inclination_deg).sum::<f64>() / k as f64,
            min_gap_cells: min_gap,
            vol_drift_max,
            net_force,
            shared_faces: stress.shared_faces,
        })
    }
}

/// Mean and standard deviation of `f` over `samples`.
fn mean_std(samples: &[&Sample], f: impl Fn(&Sample) -> f64) -> (f64, f64) {
    let n = samples.len() as f64;
    let mean = samples.iter().map(|s| f(s)).sum::<f64>() / n;
    let var = samples.iter().map(|s| (f(s) - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("suspension.rs"));
    let cfg = Config::from_args(&args)?;
    let out = args.out_dir("suspension");
    let grid = grid(&cfg)?;
    let placed = place(&cfg, &grid)?;
    let [nx, ny, nz] = grid.n();
    let k = placed.len();
    eprintln!(
        "suspension: {k} capsules, phi = {:.4} (asked {}), Ca = {}, grid {nx} x {ny} x {nz} ({:.2} cells per \
         radius), box {:?} radii, {} traction, contact {} mu gamma_dot within {} cells, dt <= {:.3e}, t_end = {}",
        placed.volume_fraction(),
        cfg.phi,
        cfg.ca,
        cfg.cells_per_radius(),
        cfg.box_radii,
        cfg.traction.name(),
        cfg.contact,
        cfg.contact_range,
        cfg.step_limit(),
        cfg.t_end
    );
    let mut sim = build(&cfg, grid, &placed)?;
    let starts: Vec<[f64; 3]> = (0..k).map(|c| sim.centroid(c)).collect::<Result<_, _>>()?;
    let outcome = simulate(&cfg, &mut sim, &out)?;
    let samples = &outcome.samples;

    // The plot: both estimates against time, the rigid-sphere dilute value for scale.
    let phi = placed.volume_fraction();
    let dilute = 1.0 + 2.5 * phi;
    let t: Vec<f64> = samples.iter().map(|s| s.t).collect();
    let mut fig = Figure::new(format!(
        "effective viscosity, {k} capsules, phi = {phi:.3}, Ca = {}, N = {}",
        cfg.ca, cfg.n
    ))
    .x_label("t gamma_dot")
    .y_label("mu_eff / mu");
    fig.line(&t, &samples.iter().map(|s| s.mu_wall).collect::<Vec<_>>(), "walls (wall shear stress)");
    fig.line(&t, &samples.iter().map(|s| s.mu_stresslet).collect::<Vec<_>>(), "particle stress (stresslet)");
    if let (Some(&t0), Some(&t1)) = (t.first(), t.last()) {
        fig.line(&[t0, t1], &[dilute, dilute], "1 + 2.5 phi (rigid spheres, dilute)")
            .style(LineStyle::Dashed);
    }
    fig.save(out.join("viscosity.svg"))?;

    // Every capsule at the start and at the end.
    let mut table = CsvWriter::create(
        out.join("capsules.csv"),
        &["capsule", "x0", "y0", "z0", "x", "y", "z", "d", "incl_deg", "volume_drift"],
    )?;
    let frame = ShearFrame::new(FLOW, GRADIENT)?;
    let phis = phis_on_grid(&sim)?;
    let phis: Vec<&Field<f64>> = phis.iter().collect();
    let shapes = capsule_shapes(sim.grid(), &phis, frame)?;
    for (c, (s, x0)) in shapes.iter().zip(&starts).enumerate() {
        let v0 = outcome.v0[c];
        let x = s.centroid;
        table.row(&[
            c as f64,
            x0[0],
            x0[1],
            x0[2],
            x[0],
            x[1],
            x[2],
            s.section.deformation,
            s.inclination_deg,
            (s.volume - v0).abs() / v0,
        ])?;
    }
    table.finish()?;

    let late: Vec<&Sample> = samples.iter().filter(|s| s.t >= cfg.average_from - 1e-9).collect();
    let (mu_wall, mu_wall_std) = mean_std(&late, |s| s.mu_wall);
    let mean = |f: fn(&Sample) -> f64| mean_std(&late, f).0;
    let vol_drift = samples.iter().map(|s| s.vol_drift_max).fold(0.0, f64::max);
    result(&[
        ("phi", num(phi)),
        ("phi_target", cfg.phi.to_string()),
        ("ca", cfg.ca.to_string()),
        ("n", cfg.n.to_string()),
        ("cells_per_radius", format!("{:.3}", cfg.cells_per_radius())),
        ("capsules", k.to_string()),
        ("mu_eff_wall", num(mu_wall)),
        ("mu_eff_wall_std", num(mu_wall_std)),
        ("mu_eff_stresslet", num(mean(|s| s.mu_stresslet))),
        ("n1", num(mean(|s| s.n1))),
        ("n2", num(mean(|s| s.n2))),
        ("d_mean", num(mean(|s| s.d_mean))),
        ("incl_deg", format!("{:.2}", mean(|s| s.incl_mean_deg))),
        ("mu_dilute_rigid", num(dilute)),
        ("min_gap_cells", num(outcome.min_gap)),
        ("vol_drift_max", num(vol_drift)),
        ("steps", outcome.steps.to_string()),
        ("wall_s", format!("{:.1}", outcome.wall_s)),
        ("t_end", format!("{:.4}", sim.time())),
        ("average_from", cfg.average_from.to_string()),
        ("failed_at", outcome.failed_at.map_or("none".to_string(), |t| format!("{t:.4}"))),
        ("repaired", outcome.repaired.to_string()),
        ("traction", cfg.traction.name().to_string()),
        ("contact", cfg.contact.to_string()),
        ("seed", cfg.seed.to_string()),
        (
            "placement",
            match cfg.method {
                Method::ShakenLattice { sweeps } => format!("shaken_{sweeps}"),
                Method::SequentialAddition => "sequential".into(),
            },
        ),
        ("box", cfg.box_radii.map(|l| l.to_string()).join(",")),
        (
            "storage",
            match cfg.storage {
                CapsuleStorage::Boxed { room } => format!("boxed_room_{room}"),
                CapsuleStorage::Whole => "whole".into(),
            },
        ),
    ]);
    Ok(())
}

/// What the time loop measured.
struct Outcome {
    samples: Vec<Sample>,
    /// Smallest gap over every step, in cells (infinite when no two profiles met).
    min_gap: f64,
    steps: usize,
    wall_s: f64,
    /// The time at which a step failed, if one did (the run stops there).
    failed_at: Option<f64>,
    /// The capsules' initial volumes.
    v0: Vec<f64>,
    /// Shell cells whose crushed `G_s` was re-set (`StepReport::repaired_cells`, summed over
    /// the steps of this run; a restarted run counts from its restart).
    repaired: usize,
}

/// Runs `sim` to `--t-end`: samples, progress lines, the history, the ParaView series.
fn simulate(cfg: &Config, sim: &mut Simulation<f64>, out: &Path) -> BoxResult<Outcome> {
    let k = sim.capsule_count();
    let mut probe = Probe::new(sim)?;
    // A restarted run continues the state of its checkpoint and the history before it.
    let mut samples = Vec::new();
    if let Some(file) = &cfg.restart {
        sim.restore(file)?;
        let table = common::csv::read_columns(out.join("history.csv"))?;
        let columns: Vec<&[f64]> = COLUMNS.iter().filter_map(|c| table.column(c)).collect();
        if columns.len() != COLUMNS.len() {
            return Err(format!(
                "--restart: {} lacks columns of this example",
                out.join("history.csv").display()
            )
            .into());
        }
        let row = |i: usize| columns.iter().map(|c| c[i]).collect::<Vec<f64>>();
        samples =
            (0..table.rows()).map(|i| Sample::from_row(&row(i))).filter(|x| x.t <= sim.time()).collect();
        eprintln!(
            "  restarted from {} at t = {:.4} ({} samples kept)",
            file.display(),
            sim.time(),
            samples.len()
        );
    }
    let mut history = CsvWriter::create(out.join("history.csv"), &COLUMNS)?;
    for x in &samples {
        history.row(&x.row(k))?;
    }
    // On disk at once: a run stopped before its next checkpoint restarts from the same rows.
    history.flush()?;
    let checkpoint = out.join("checkpoint.bin");
    let mut next_checkpoint = sim.time() + cfg.checkpoint_every;
    let max_dt = cfg.step_limit();
    let mut stepping = AdaptiveDt::new(max_dt)?.cfl(cfg.cfl)?;
    let gap_now = |sim: &Simulation<f64>| min_gap_cells(sim).unwrap_or(f64::INFINITY);
    let mut min_gap = samples.iter().map(|x: &Sample| x.min_gap_cells).fold(gap_now(sim), f64::min);
    let t0 = sim.time();
    let after = |every: f64| if t0 > 0.0 && every > 0.0 { ((t0 / every).floor() + 1.0) * every } else { 0.0 };
    let (mut pvd, mut next_vtk, mut next_sample) =
        (PvdSeries::new(), after(cfg.vtk_every), after(cfg.sample_every));
    let first = samples.last().map_or(0, |x: &Sample| x.steps);
    let (mut s, mut dt, mut retries, mut repaired) = (first, 0.0, 0usize, 0usize);
    // The last step's predictor iterations and max|v| (from its Courant number).
    let (mut iterations, mut vmax) = (0usize, 0.0f64);
    let h = cfg.h();
    let mut failed_at = None;
    let mut warned = None;
    let clock = Instant::now();
    let expected = (cfg.t_end / max_dt).ceil() as usize;
    loop {
        let t = sim.time();
        let at_end = t >= cfg.t_end * (1.0 - 1e-12) || failed_at.is_some();
        let gap = gap_now(sim);
        min_gap = min_gap.min(gap);
        if t >= next_sample - 1e-9 * cfg.sample_every || at_end {
            while next_sample <= t + 1e-9 * cfg.sample_every {
                next_sample += cfg.sample_every;
            }
            let sample = probe.sample(sim, if dt > 0.0 { dt } else { max_dt }, s, gap)?;
            history.row(&sample.row(k))?;
            samples.push(sample);
        }
        if cfg.vtk_every > 0.0 && (t >= next_vtk - 1e-9 || at_end) {
            let name = format!("suspension_{s:06}.vti");
            sim.write_vti(out.join(&name))?;
            pvd.push(t, name);
            while next_vtk <= t + 1e-9 {
                next_vtk += cfg.vtk_every;
            }
        }
        // Progress against the steps expected (extrapolated from the time reached).
        let total = if t > 0.0 { ((s as f64) * cfg.t_end / t).round() as usize } else { expected }.max(s);
        if s > 0 && (common::progress_due(s, total) || at_end) {
            let last: &Sample = samples.last().expect("sampled at step 0");
            let extra = format!(
                "dt={dt:.2e} mu_wall={:.4} mu_stresslet={:.4} D={:.4} min_gap={gap:.2} cells \
                 (sampled at t={:.3}) iters={iterations} vmax={vmax:.2} retries={retries}",
                last.mu_wall, last.mu_stresslet, last.d_mean, last.t
            );
            common::progress_line(first, s, total, t, &clock, &extra);
            if let Some((at, w)) = warned.take() {
                eprintln!("  warning (last at t={at:.4}): {w}");
            }
            retries = 0;
            history.flush()?;
        }
        if at_end {
            break;
        }
        if cfg.checkpoint_every > 0.0 && t >= next_checkpoint - 1e-9 {
            sim.checkpoint(&checkpoint)?;
            history.flush()?;
            next_checkpoint += cfg.checkpoint_every;
        }
        match stepping.advance(sim, cfg.t_end) {
            Ok(Some(report)) => {
                s += 1;
                dt = report.flow.dt;
                (iterations, vmax) = (report.flow.predictor_iterations, report.flow.cfl * h / dt);
                retries += report.retries;
                repaired += report.repaired_cells;
                if let Some(w) = report.warning {
                    warned = Some((sim.time(), w));
                }
            }
            Ok(None) => break,
            Err(e) => {
                // Keep what the run reached: the history, the plot and the RESULT line.
                eprintln!("suspension: the step at t = {:.4} failed: {e}", sim.time());
                failed_at = Some(sim.time());
            }
        }
    }
    history.finish()?;
    if cfg.vtk_every > 0.0 {
        pvd.write(out.join("suspension.pvd"))?;
    }
    let wall_s = clock.elapsed().as_secs_f64();
    Ok(Outcome { samples, min_gap, steps: s, wall_s, failed_at, v0: probe.v0, repaired })
}
