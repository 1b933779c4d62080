//! Sec. 3.4 of the paper: biconcave red blood cells (Skalak law, bending) in pressure-driven
//! channel flow. Domain `[0, 0.5]^3`, walls `y = 0, 0.5`, periodic x and z, `rho = 1`,
//! `mu = 0.25` inside and `0.05` outside, `E_s = 0.05`, `E_b = 5e-5`, pressure gradient `-1`
//! (a body force `+1` along x), `dt = 0.001`. The cells' axis is along the flow (x).
//!
//! `--case single` (default): one cell, `a = 0.17`, at the centre, for each `alpha` of
//! `--alpha` (2,10,40) to `--t-end` (2): the surface area by (3.7) and by `sum delta h^3`
//! (`area_alpha*.csv`, `area.svg` like Fig. 12), the x-z section at `y = 0.25` at the end
//! (`sections.svg`, Fig. 13); a line per alpha `RESULT alpha=... max_area_change=...
//! max_area_change_delta=... volume_drift=... failed_at=... wall_s=... traction=...
//! gs_transport=... epsilon=...` (largest `|s/s0 - 1|` of the
//! (3.7) area and of `sum delta h^3`; the time of a failed step, if one failed: the run of that
//! alpha then stops and the next alpha runs).
//!
//! `--case two1` / `--case two2`: two cells at (3.8) / (3.9), `alpha = 40`, to `--t-end`
//! (default 7.5 for these cases): x-z sections at `y = 0.25` (Fig. 16, `_sections.svg`) and
//! x-y sections at `z = 0.25` (`_sections_xy.svg`: across the walls, where the flow varies and
//! the parachute forms), the mean streamwise velocity `u(y)` across the channel (averaged over x
//! and z) with and without cells (Fig. 17, `_profile.csv`), and the parachute signature in the
//! x-y plane through each cell's centroid: `rear_concavity` (how far the centre of the trailing
//! face lies ahead of that face at `+-0.6 a` from the axis) and `front_convexity` (the same for
//! the leading face). The biconcave cell starts with `rear_concavity = -front_convexity > 0`; a
//! parachute has both positive. `rear_concavity_span` is the first, measured along z instead
//! (the flow does not vary along z):
//! `RESULT case=... n=... t=... rear_concavity=... front_convexity=... rear_concavity_span=...
//! volume_drift=... peak_gs_normal=... peak_gs_trace=... failed_at=... wall_s=... traction=...
//! gs_transport=... epsilon=...`
//! (`t` the time reached; a failed step ends the run there, and the figures show the last good
//! state; `peak_gs_normal` and `peak_gs_trace` the largest `|G_s n|` and `tr G_s` over the
//! membranes and the steps, `diagnostics::tangency::gs_tangency`: the first is 0 with `--gs-transport tangential`,
//! and its growth on the rim next to the walls is what precedes the failure of the paper's
//! transport). The progress lines print the signature and both as the run goes, with the centre
//! of the cell where `|G_s n|` is largest and `phi` there (which layer of the band it is).
//!
//! `--case many`: `--cells` cells (8) of `a = 0.06` on a lattice, periodic x and y (walls
//! in z), `mu = 0.5 / 0.1`, `E_s = 0.1`, `alpha = 10`, `E_b = 5e-6`, `dt = 0.00025` (Sec. 3.4.3),
//! an opt-in long run; works at reduced `--n`. Each cell keeps its fields on a box that follows
//! it (`Settings::storage`, `--room R`: `CapsuleStorage::Boxed { room: R }`, 1.2 by default for
//! `many`; `--room 0` keeps every cell on the whole grid, the default of the other cases).
//!
//! `--case replot --files A.csv,B.csv,...`: redraws `area.svg` (Fig. 12) from `area_alpha*.csv`
//! files written by `--case single` runs, e.g. one process per alpha run side by side.
//!
//! Flags: `--n` (32; the paper uses 64, 128 for `many`), `--dt`, `--t-end`, `--alpha LIST`,
//! `--case`, `--cells`, `--bending-form divergence|energy` (`Bending::form`, default
//! the paper's `divergence`), `--gs-transport paper|tangential|frame|both`
//! (`Settings::gs_transport`, default `paper`), `--bending-coupling semi-implicit|explicit`
//! (`Bending::coupling`, default semi-implicit; the paper's and the figures of
//! `docs/validation/red_cells.md` are explicit; `--bending-alpha`, 1),
//! `--traction smoothed|sharp|sharp-resampled` (`Elasticity::traction`, default the paper's `smoothed`; the key
//! `traction` of the `single` and `two` RESULT lines), `--epsilon E` (`Settings::epsilon`, the
//! band `delta h >= E` outside which `G_s` is re-set to `P`; 0.01, the paper's range being
//! 0.01-0.1), `--vtk-every` (0.5; 0 none), `--out DIR` (`out/rbc_channel`).
//!
//! Long runs (`two1`, `two2`): `--progress-every T` prints a progress line every `T` time units
//! (default: every twentieth of the run); `--checkpoint-every T` writes the whole state to
//! `CASE_checkpoint.bin` in `--out` every `T` time units (0, the default: never), and
//! `--restart FILE` continues a run from such a file, bit for bit as if it had not stopped
//! (`Simulation::checkpoint`, `Simulation::restore`); give the same flags as the first run. A
//! restarted run draws its sections from `t = 0` and from the times it reaches itself, its
//! `volume_drift` covers its own steps (against the initial volumes), and its `.pvd` series lists
//! only its own snapshots (the `.vti` files of the first run stay in `--out`).
//!
//! Run: `cargo run --release --example rbc_channel -- --n 32`.

use eulermembrane_cases as common;

use common::{Args, BoxResult, Terms, num, result};
use eulermembrane::diagnostics::{
    area::AreaTracker,
    profile::{ProfileAxes, Span, streamwise_profile},
    tangency::gs_tangency,
};
use eulermembrane::grid::{Boundary, Field, Grid};
use eulermembrane::interface::shapes::Biconcave;
use eulermembrane::io::vtk::PvdSeries;
use eulermembrane::membrane::{bending::BendingForm, law::Skalak};
use eulermembrane::simulation::{
    BendingCoupling, CapsuleStorage, GsTransport, MembraneCoupling, Phase, Scene, Settings, Simulation,
    Traction,
};
use eulermembrane_cases::csv::{CsvWriter, read_columns, write_columns};
use eulermembrane_cases::plot::{Figure, LineStyle, contour_segments};
use std::path::{Path, PathBuf};
use std::time::Instant;

const L: f64 = 0.5;

fn main() {
    common::exit_on_error(run());
}

/// The physical parameters of a scene.
struct Params {
    mu_in: f64,
    mu_out: f64,
    es: f64,
    eb: f64,
    alpha: f64,
    radius: f64,
    wall_axis: usize,
    /// The numerical options of the command line.
    numerics: Numerics,
}

/// The numerical options a run may change (`--bending-form`, `--gs-transport`,
/// `--bending-coupling`, `--traction`): `Bending::form`, [`Settings::gs_transport`],
/// `Bending::coupling` and `Elasticity::traction`; the paper's scheme by default, but for the
/// library's semi-implicit bending.
#[derive(Clone, Copy)]
struct Numerics {
    /// The options of the elasticity and the bending.
    terms: Terms,
    gs_transport: GsTransport,
    /// `Settings::epsilon`, the band of `delta h >= epsilon`.
    epsilon: f64,
    /// `Settings::storage`: where each cell keeps its fields.
    storage: CapsuleStorage,
}

impl Numerics {
    /// The RESULT keys of the choices a run's figures depend on most: `traction`,
    /// `gs_transport` and `epsilon`.
    fn keys(&self) -> [(&'static str, String); 3] {
        [
            ("traction", self.terms.traction.name().to_string()),
            ("gs_transport", self.gs_transport.name().to_string()),
            ("epsilon", self.epsilon.to_string()),
        ]
    }
}

const PAPER: Params = Params {
    mu_in: 0.25,
    mu_out: 0.05,
    es: 0.05,
    eb: 5e-5,
    alpha: 40.0,
    radius: 0.17,
    wall_axis: 1,
    numerics: Numerics {
        terms: Terms {
            traction: Traction::Smoothed,
            coupling: MembraneCoupling::QuasiImplicit,
            bending_form: BendingForm::Divergence,
            bending_coupling: BendingCoupling::SemiImplicit { alpha: 1.0 },
        },
        gs_transport: GsTransport::Paper,
        epsilon: 0.01,
        storage: CapsuleStorage::Whole,
    },
};

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("rbc_channel.rs"));
    let out = args.out_dir("rbc_channel");
    let n: usize = args.get("n", 32);
    let case: String = args.get("case", "single".to_string());
    let vtk_every: f64 = args.get("vtk-every", 0.5);
    let form: String = args.get("bending-form", "divergence".to_string());
    let numerics = Numerics {
        terms: Terms {
            traction: args.traction(Traction::Smoothed)?,
            bending_form: BendingForm::from_name(&form)?,
            bending_coupling: args.bending_coupling()?,
            ..PAPER.numerics.terms
        },
        gs_transport: GsTransport::from_name(&args.get("gs-transport", "paper".to_string()))?,
        epsilon: args.get("epsilon", PAPER.numerics.epsilon),
        storage: match args.get("room", if case == "many" { 1.2 } else { 0.0 }) {
            r if r > 0.0 => CapsuleStorage::Boxed { room: r },
            _ => CapsuleStorage::Whole,
        },
    };
    match case.as_str() {
        "single" => {
            let alphas: Vec<f64> = args.list("alpha").unwrap_or(vec![2.0, 10.0, 40.0]);
            single(n, args.get("dt", 0.001), args.get("t-end", 2.0), &alphas, numerics, &out)
        }
        "two1" | "two2" => {
            let z = if case == "two1" { [0.25, 0.25] } else { [0.23, 0.27] };
            let centres = vec![[0.125, 0.25, z[0]], [0.375, 0.25, z[1]]];
            let run = LongRun {
                vtk_every,
                checkpoint_every: args.get("checkpoint-every", 0.0),
                progress_every: args.get("progress-every", 0.0),
                restart: args.opt::<String>("restart").map(PathBuf::from),
            };
            two(n, args.get("dt", 0.001), args.get("t-end", 7.5), &case, &centres, numerics, &run, &out)
        }
        "many" => {
            let cells = args.get("cells", 8);
            many(n, args.get("dt", 0.00025), args.get("t-end", 5.0), cells, numerics, vtk_every, &out)
        }
        "replot" => replot(&args.get("files", String::new()), &out),
        other => Err(format!("--case {other}: expected single, two1, two2, many or replot").into()),
    }
}

/// A channel scene with the cells at `centres`.
fn scene(n: usize, p: &Params, centres: &[[f64; 3]]) -> eulermembrane::Result<Simulation<f64>> {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[p.wall_axis] = [Boundary::wall(), Boundary::wall()];
    let grid = Grid::new([n; 3], [0.0; 3], [L; 3], bc)?;
    let mut s = Scene::new(grid, Phase::new(1.0, p.mu_out)?).inside(Phase::new(1.0, p.mu_in)?);
    for &c in centres {
        s = s.capsule(Biconcave::new(c, p.radius)?);
    }
    // The body force first: the forces are summed in the order the effects are added.
    let terms = p.numerics.terms;
    s.body_force([1.0, 0.0, 0.0])
        .effect(terms.elasticity(Skalak::new(p.es, p.alpha)?))
        .effect(terms.bending(p.eb)?)
        .settings(Settings {
            gs_transport: p.numerics.gs_transport,
            epsilon: p.numerics.epsilon,
            storage: p.numerics.storage,
            ..Settings::default()
        })
        .build()
}

/// One cell's area history in Fig. 12: by (3.7), solid, and by `sum delta h^3`, dashed.
fn area_lines(fig: &mut Figure, label: &str, t: &[f64], s37: &[f64], sdelta: &[f64]) {
    fig.line(t, s37, &format!("{label}, (3.7)"));
    fig.line(t, sdelta, &format!("{label}, sum delta h^3")).style(LineStyle::Dashed);
}

/// The area histories of Fig. 12 from the `area_alpha*.csv` files in the comma-separated
/// list `files`, in one plot (`area.svg` in `out`).
fn replot(files: &str, out: &Path) -> BoxResult<()> {
    let paths: Vec<&str> = files.split(',').map(str::trim).filter(|f| !f.is_empty()).collect();
    if paths.is_empty() {
        return Err("--case replot needs --files A.csv,B.csv,... (area_alpha*.csv of --case single)".into());
    }
    let mut fig = Figure::new("surface area by (3.7) (Fig. 12)").x_label("t").y_label("s / s0");
    for path in paths {
        let table = read_columns(path)?;
        let stem = Path::new(path).file_stem().and_then(|s| s.to_str()).unwrap_or(path);
        let label = stem.strip_prefix("area_alpha").map_or(stem.to_string(), |a| format!("alpha = {a}"));
        let column = |name: &str| table.column(name).ok_or(format!("{path}: no column {name}"));
        area_lines(&mut fig, &label, column("t")?, column("area_37")?, column("area_delta")?);
    }
    fig.save(out.join("area.svg"))?;
    eprintln!("rbc_channel replot: wrote {}", out.join("area.svg").display());
    Ok(())
}

fn single(n: usize, dt: f64, t_end: f64, alphas: &[f64], numerics: Numerics, out: &Path) -> BoxResult<()> {
    let steps = (t_end / dt).round() as usize;
    let mut fig =
        Figure::new(format!("surface area by (3.7), N = {n} (Fig. 12)")).x_label("t").y_label("s / s0");
    let mut sections = Figure::new(format!("x-z section at y = 0.25, t = {t_end} (Fig. 13)"))
        .x_label("x")
        .y_label("z")
        .equal_aspect(true);
    let mut lines = Vec::new();
    for &alpha in alphas {
        let p = Params { alpha, numerics, ..PAPER };
        let mut sim = scene(n, &p, &[[0.25; 3]])?;
        eprintln!("rbc_channel single: alpha = {alpha}, {n}^3 cells, {steps} steps of dt = {dt}");
        let g = sim.grid().clone();
        let mut tracker = AreaTracker::from_delta(&g, sim.delta(0)?)?;
        let (a0, v0) = (sim.area(0)?, sim.volume(0)?);
        let mut csv = CsvWriter::create(
            out.join(format!("area_alpha{alpha}.csv")),
            &["t", "area_37", "area_delta", "volume_drift"],
        )?;
        let (mut t, mut s37, mut sdelta) = (vec![0.0], vec![1.0], vec![1.0]);
        let (mut max_change, mut max_change_delta, mut max_drift) = (0.0f64, 0.0f64, 0.0f64);
        csv.row(&[0.0, 1.0, 1.0, 0.0])?;
        let clock = Instant::now();
        let mut failed = None;
        for s in 1..=steps {
            let t_before = sim.time();
            let stepped = tracker
                .step(&g, sim.delta(0)?, sim.normal(0)?, sim.velocity(), dt)
                .and_then(|_| sim.step(dt));
            if let Err(e) = stepped {
                eprintln!("  alpha = {alpha}: the step at t = {t_before:.3} failed: {e}");
                failed = Some(t_before);
                break;
            }
            let rel = tracker.relative();
            let drift = (sim.volume(0)? - v0).abs() / v0;
            let rel_delta = sim.area(0)? / a0;
            max_change = max_change.max((rel - 1.0).abs());
            max_change_delta = max_change_delta.max((rel_delta - 1.0).abs());
            max_drift = max_drift.max(drift);
            t.push(sim.time());
            s37.push(rel);
            sdelta.push(rel_delta);
            csv.row(&[sim.time(), rel, rel_delta, drift])?;
            if common::progress_due(s, steps) {
                csv.flush()?; // a long run that fails still leaves its curve so far
            }
            common::progress(s, steps, sim.time(), &clock, &format!("s/s0={rel:.4} delta={rel_delta:.4}"));
        }
        csv.finish()?;
        area_lines(&mut fig, &format!("alpha = {alpha}"), &t, &s37, &sdelta);
        sections.segments(section(&g, sim.phi(0)?, 1, 0.25), &format!("alpha = {alpha}"));
        let mut line = vec![
            ("alpha", alpha.to_string()),
            ("n", n.to_string()),
            ("max_area_change", num(max_change)),
            ("max_area_change_delta", num(max_change_delta)),
            ("volume_drift", num(max_drift)),
            ("failed_at", failed.map_or("none".to_string(), |t| format!("{t:.3}"))),
            ("wall_s", format!("{:.1}", clock.elapsed().as_secs_f64())),
        ];
        line.extend(numerics.keys());
        lines.push(line);
    }
    fig.save(out.join("area.svg"))?;
    sections.save(out.join("sections.svg"))?;
    for l in &lines {
        result(l);
    }
    Ok(())
}

/// The `phi = 1/2` contour in the plane through `at` normal to `axis` (1: the x-z plane, 2:
/// the x-y plane), in that plane's coordinates (x first).
fn section(g: &Grid<f64>, phi: &Field<f64>, axis: usize, at: f64) -> Vec<[(f64, f64); 2]> {
    let [nx, ny, nz] = g.n();
    let h = g.h();
    let (q, nq) = if axis == 1 { (2, nz) } else { (1, ny) };
    let layer = ((at / h[axis]) as usize).min(g.n()[axis] - 1);
    let vals: Vec<f64> = (0..nq)
        .flat_map(|b| (0..nx).map(move |i| (i, b)))
        .map(|(i, b)| {
            let mut ijk = [i, 0, 0];
            ijk[q] = b;
            ijk[axis] = layer;
            phi.values()[g.idx_u(ijk[0], ijk[1], ijk[2])]
        })
        .collect();
    contour_segments(nx, nq, 0.5 * h[0], 0.5 * h[q], h[0], h[q], &vals, 0.5)
}

/// The streamwise position (x) where a line along x, through `centre` moved by `offset` along
/// `axis`, leaves the cell `phi >= 1/2`, walking from the centre upstream (`dir = -1`, the
/// trailing face) or downstream (`dir = 1`, the leading face); periodic in x, relative to the
/// cell of the centre, so that positions of one cell compare.
fn face_x(
    g: &Grid<f64>,
    phi: &Field<f64>,
    centre: [f64; 3],
    axis: usize,
    offset: f64,
    dir: isize,
) -> Option<f64> {
    let (h, n) = (g.h(), g.n());
    let mut ijk = [0usize; 3];
    for d in 1..3 {
        let x = centre[d] + if d == axis { offset } else { 0.0 };
        ijk[d] = ((x / h[d]).max(0.0) as usize).min(n[d] - 1);
    }
    let ic = (centre[0] / h[0]) as isize;
    let line = |i: isize| phi.values()[g.idx_u(i.rem_euclid(n[0] as isize) as usize, ijk[1], ijk[2])];
    let mut prev = line(ic);
    for s in 1..(n[0] as isize / 2) {
        let cur = line(ic + dir * s);
        if prev >= 0.5 && cur < 0.5 {
            let steps = (s - 1) as f64 + (prev - 0.5) / (prev - cur);
            return Some(h[0] * (ic as f64 + 0.5 + dir as f64 * steps));
        }
        prev = cur;
    }
    None
}

/// The parachute signature of one cell in the plane of the flow (x) and `axis`:
/// `[rear_concavity, front_convexity]`, how far the centre of the trailing face lies ahead of
/// that face at `+-0.6 a` from the axis (mean of the two sides), and how far the centre of the
/// leading face lies ahead of the leading face there. A biconcave cell at rest has
/// `rear_concavity = -front_convexity > 0` (both faces dimpled); a parachute has both positive
/// (concave rear, convex front).
fn face_shape(g: &Grid<f64>, phi: &Field<f64>, centre: [f64; 3], a: f64, axis: usize) -> [f64; 2] {
    let lead = |dir: isize| -> Option<f64> {
        let side = |o: f64| face_x(g, phi, centre, axis, o, dir);
        Some(side(0.0)? - 0.5 * (side(0.6 * a)? + side(-0.6 * a)?))
    };
    [lead(-1).unwrap_or(f64::NAN), lead(1).unwrap_or(f64::NAN)]
}

/// Output and restart options of a long run: `--vtk-every`, `--checkpoint-every`,
/// `--progress-every`, `--restart`.
struct LongRun {
    vtk_every: f64,
    checkpoint_every: f64,
    progress_every: f64,
    restart: Option<PathBuf>,
}

/// The first multiple of `every` at or after `t` (0 when `every` is not positive).
fn next_multiple(t: f64, every: f64) -> f64 {
    if every > 0.0 { (t / every - 1e-9).ceil() * every } else { 0.0 }
}

#[allow(clippy::too_many_arguments)]
fn two(
    n: usize,
    dt: f64,
    t_end: f64,
    case: &str,
    centres: &[[f64; 3]],
    numerics: Numerics,
    run: &LongRun,
    out: &Path,
) -> BoxResult<()> {
    let p = Params { numerics, ..PAPER };
    let mut sim = scene(n, &p, centres)?;
    let steps = (t_end / dt).round() as usize;
    eprintln!("rbc_channel {case}: {n}^3 cells, {steps} steps of dt = {dt}");
    let g = sim.grid().clone();
    let v0: Vec<f64> = (0..centres.len()).map(|c| sim.volume(c)).collect::<Result<_, _>>()?;
    let phis = |sim: &Simulation<f64>| -> eulermembrane::Result<Vec<Field<f64>>> {
        (0..centres.len()).map(|c| sim.phi(c).cloned()).collect()
    };
    // The sections start from the initial shapes, also when the run continues a checkpoint.
    let mut snaps: Vec<(f64, Vec<Field<f64>>)> = vec![(0.0, phis(&sim)?)];
    if let Some(file) = &run.restart {
        sim.restore(file)?;
        eprintln!("  restarted from {} at t = {:.4}", file.display(), sim.time());
    }
    let first = (sim.time() / dt).round() as usize;
    let t0 = sim.time();
    let checkpoint = out.join(format!("{case}_checkpoint.bin"));
    let mut pvd = PvdSeries::new();
    let mut next_vtk = next_multiple(t0, run.vtk_every);
    let mut next_checkpoint = t0 + run.checkpoint_every;
    let mut next_progress = next_multiple(t0, run.progress_every).max(run.progress_every);
    let clock = Instant::now();
    let mut max_drift = 0.0f64;
    let snap_every = t_end / 3.0;
    let mut next_snap = next_multiple(t0, snap_every).max(snap_every);
    // The parachute signature of every cell in the wall-normal plane (where the flow varies)
    // and in the spanwise one: [rear, front] per cell, see `face_shape`.
    let span_axis = 3 - p.wall_axis;
    let shapes = |sim: &Simulation<f64>, axis: usize| -> eulermembrane::Result<Vec<[f64; 2]>> {
        (0..centres.len())
            .map(|c| Ok(face_shape(&g, sim.phi(c)?, sim.centroid(c)?, p.radius, axis)))
            .collect()
    };
    let list = |v: &[[f64; 2]], which: usize| v.iter().map(|f| num(f[which])).collect::<Vec<_>>().join(",");
    // How far G_s has left the tangent plane, worst cell over both cells: [max |G_s n|, max tr G_s]
    // and the centre of the cell with the largest |G_s n| and its phi.
    let eps = sim.settings().epsilon;
    let tangency = |sim: &Simulation<f64>| -> eulermembrane::Result<([f64; 2], [f64; 4])> {
        let (mut worst, mut at) = ([0.0f64; 2], [f64::NAN; 4]);
        for c in 0..centres.len() {
            let Some(gs) = sim.gs(c)? else { continue };
            let t = gs_tangency(&g, sim.delta(c)?, sim.normal(c)?, gs, eps)?;
            if t.max_normal > worst[0] {
                let [i, j, k] = t.max_normal_at.map(|i| i as isize);
                let xc = g.cell_center(i, j, k);
                let ph = sim.phi(c)?.at(&g, i, j, k);
                at = [xc[0], xc[1], xc[2], ph];
            }
            worst = [worst[0].max(t.max_normal), worst[1].max(t.max_trace)];
        }
        Ok((worst, at))
    };
    let mut peak_gs = [0.0f64; 2];
    let mut failed = None;
    for s in first..=steps {
        if s > first {
            let t_before = sim.time();
            if let Err(e) = sim.step(dt) {
                // Keep what the run reached: the figures below are drawn at the last good step.
                eprintln!("  {case}: the step at t = {t_before:.3} failed: {e}");
                failed = Some(t_before);
                snaps.push((t_before, phis(&sim)?));
                break;
            }
            let (gs_now, gs_at) = tangency(&sim)?;
            peak_gs = [peak_gs[0].max(gs_now[0]), peak_gs[1].max(gs_now[1])];
            let due = if run.progress_every > 0.0 {
                sim.time() >= next_progress - 1e-9 || s == steps
            } else {
                common::progress_due(s, steps)
            };
            if due {
                next_progress += run.progress_every;
                let f = shapes(&sim, p.wall_axis)?;
                let short = |w: usize| f.iter().map(|f| format!("{:.4}", f[w])).collect::<Vec<_>>().join(",");
                let x1 = sim.centroid(0)?[0];
                let line = format!(
                    "x1={x1:.3} rear_concavity={} front_convexity={} gs_normal={:.3} at ({:.3},{:.3},{:.3}) phi={:.3} \
                     gs_trace={:.3}",
                    short(0),
                    short(1),
                    gs_now[0],
                    gs_at[0],
                    gs_at[1],
                    gs_at[2],
                    gs_at[3],
                    gs_now[1]
                );
                common::progress_line(first, s, steps, sim.time(), &clock, &line);
            }
            if run.checkpoint_every > 0.0 && sim.time() >= next_checkpoint - 1e-9 {
                sim.checkpoint(&checkpoint)?;
                next_checkpoint += run.checkpoint_every;
            }
        }
        let t = sim.time();
        for (c, v) in v0.iter().enumerate() {
            max_drift = max_drift.max((sim.volume(c)? - v).abs() / v);
        }
        if run.vtk_every > 0.0 && t >= next_vtk - 1e-9 {
            let name = format!("{case}_{s:06}.vti");
            sim.write_vti(out.join(&name))?;
            pvd.push(t, name);
            next_vtk += run.vtk_every;
        }
        if (s > first || first > 0) && (t >= next_snap - 1e-9 || s == steps) {
            snaps.push((t, phis(&sim)?));
            next_snap += snap_every;
        }
    }
    if run.vtk_every > 0.0 {
        pvd.write(out.join(format!("{case}.pvd")))?;
    }
    // Fig. 16: x-z sections at y = 0.25 (the paper's plane, parallel to the walls), and x-y
    // sections at z = 0.25 (across the walls: the plane where the parachute forms).
    for (axis, name, title) in [
        (1, "sections", "x-z sections at y = 0.25 (Fig. 16)"),
        (2, "sections_xy", "x-y sections at z = 0.25"),
    ] {
        let mut fig = Figure::new(format!("{case}: {title}, N = {n}"))
            .x_label("x")
            .y_label(if axis == 1 { "z" } else { "y" })
            .equal_aspect(true);
        for (t, phis) in &snaps {
            for phi in phis {
                fig.segments(section(&g, phi, axis, 0.25), &format!("t = {t:.2}"));
            }
        }
        fig.save(out.join(format!("{case}_{name}.svg")))?;
    }
    // Fig. 17: the mean streamwise velocity across the channel, averaged along x and the span,
    // with the cells and without them (Poiseuille: u = y (L - y) / (2 mu), pressure gradient 1).
    let y: Vec<f64> = (0..=2 * n).map(|j| j as f64 * L / (2 * n) as f64).collect();
    let with = streamwise_profile(&g, sim.velocity(), ProfileAxes::default(), &y, Span::Average)?;
    let without: Vec<f64> = y.iter().map(|y| y * (L - y) / (2.0 * p.mu_out)).collect();
    write_columns(
        out.join(format!("{case}_profile.csv")),
        &[("y", &y), ("u_with_cells", &with), ("u_without", &without)],
    )?;
    let mut pf =
        Figure::new(format!("mean streamwise velocity across the channel, t = {:.2} (Fig. 17)", sim.time()))
            .x_label("y")
            .y_label("u");
    pf.line(&y, &with, case);
    pf.line(&y, &without, "without cells");
    pf.save(out.join(format!("{case}_profile.svg")))?;
    let (wall, span) = (shapes(&sim, p.wall_axis)?, shapes(&sim, span_axis)?);
    let mut line = vec![
        ("case", case.to_string()),
        ("n", n.to_string()),
        ("t", format!("{:.3}", sim.time())),
        ("rear_concavity", list(&wall, 0)),
        ("front_convexity", list(&wall, 1)),
        ("rear_concavity_span", list(&span, 0)),
        ("volume_drift", num(max_drift)),
        ("peak_gs_normal", num(peak_gs[0])),
        ("peak_gs_trace", num(peak_gs[1])),
        ("failed_at", failed.map_or("none".to_string(), |t| format!("{t:.3}"))),
        ("wall_s", format!("{:.1}", clock.elapsed().as_secs_f64())),
    ];
    line.extend(p.numerics.keys());
    result(&line);
    Ok(())
}

fn many(
    n: usize,
    dt: f64,
    t_end: f64,
    cells: usize,
    numerics: Numerics,
    vtk_every: f64,
    out: &Path,
) -> BoxResult<()> {
    let p = Params {
        mu_in: 0.5,
        mu_out: 0.1,
        es: 0.1,
        eb: 5e-6,
        alpha: 10.0,
        radius: 0.06,
        wall_axis: 2,
        numerics,
    };
    // A lattice of cells away from the walls, two per row along x, staggered.
    let per = (cells as f64).sqrt().ceil() as usize;
    let centres: Vec<[f64; 3]> = (0..cells)
        .map(|c| {
            let (a, b) = (c % per, c / per);
            let s = L / per as f64;
            [(a as f64 + 0.5) * s, (b as f64 + 0.5) * s, 0.25 + if (a + b) % 2 == 0 { 0.06 } else { -0.06 }]
        })
        .collect();
    let setup = Instant::now();
    let mut sim = scene(n, &p, &centres)?;
    let setup_s = setup.elapsed().as_secs_f64();
    let steps = (t_end / dt).round() as usize;
    let boxes: Vec<String> =
        (0..cells).map(|c| Ok(format!("{:?}", sim.window(c)?.size()))).collect::<BoxResult<_>>()?;
    eprintln!(
        "rbc_channel many: {cells} cells, {n}^3, {steps} steps of dt = {dt}; set-up {setup_s:.1} s; boxes {}",
        boxes.join(" ")
    );
    let v0: Vec<f64> = (0..cells).map(|c| sim.volume(c)).collect::<Result<_, _>>()?;
    let (mut pvd, mut next_vtk) = (PvdSeries::new(), 0.0);
    let clock = Instant::now();
    for s in 0..=steps {
        if s > 0 {
            sim.step(dt)?;
            common::progress(s, steps, sim.time(), &clock, "");
        }
        if vtk_every > 0.0 && sim.time() >= next_vtk - 1e-9 {
            let name = format!("many_{s:06}.vti");
            sim.write_vti(out.join(&name))?;
            pvd.push(sim.time(), name);
            next_vtk += vtk_every;
        }
    }
    if vtk_every > 0.0 {
        pvd.write(out.join("many.pvd"))?;
    }
    let drift = (0..cells)
        .map(|c| sim.volume(c).map(|v| (v - v0[c]).abs() / v0[c]))
        .collect::<Result<Vec<_>, _>>()?;
    result(&[
        ("case", "many".into()),
        ("cells", cells.to_string()),
        ("n", n.to_string()),
        ("volume_drift", num(drift.iter().cloned().fold(0.0, f64::max))),
        ("setup_s", format!("{setup_s:.1}")),
        ("steps", steps.to_string()),
        ("wall_s", format!("{:.1}", clock.elapsed().as_secs_f64())),
        (
            "storage",
            match p.numerics.storage {
                CapsuleStorage::Boxed { room } => format!("boxed_room_{room}"),
                CapsuleStorage::Whole => "whole".into(),
            },
        ),
    ]);
    Ok(())
}
