//! What accuracy costs: error against CPU time, with the Pareto front, for the single-vortex
//! advection test (Sec. 3.1) and the capsule in shear flow at `Ca = 0.05` (Sec. 3.3).
//! Results and recommendations: `docs/accuracy-cost.md`.
//!
//! Studies (`--study NAME`, repeatable as a comma list; `quick` by default, `all` for every one):
//! - `vortex`: the single vortex at N = 32 ... 256 (`--max-vortex-n`), the paper's Youngs
//!   normals and the library's default `Atanh4`; errors L1 of `phi` and of `kappa_R delta_bar`.
//! - `shear_n`: the shear capsule at N = 16, 24, 32, 48, 64 (up to `--max-n`, default 32),
//!   `dt = 0.256 / N` (0.008 at N = 32: a fixed fraction of the cell size).
//! - `shear_dt`: at N = 24, `dt` 2, 1, 1/2, 1/4 times that; at N = 32, 2 and 1 times.
//! - `precision`: f32 against f64, for the vortex (N = 32 ... 128) and for the shear capsule
//!   at `--study-n` (default 24), with the default Krylov tolerance 1e-8 and with 1e-5.
//! - `solver`: Krylov (BiCGStab) tolerance 1e-3 ... 1e-8 and the paper's SOR (omega 1.4,
//!   tolerance 1e-6), shear capsule at `--study-n`.
//! - `beta_epsilon`: MTHINC `beta` for the vortex (N = 64) and the capsule (also the initial
//!   smoothing's), and the `epsilon` of the `G_s` re-set, capsule at `--study-n`.
//! - `fast`: the capsule at N = 16 ... 96 (up to `--max-n`) with the cheap settings the other
//!   studies found harmless: `dt = 0.512 / N` and Krylov tolerance 1e-3, with `beta = 1` and 2.
//! - `coupling`: the capsule at N = 24, 32, 48, 64, 96, 128 (up to `--max-n`) with the paper's
//!   smoothed membrane traction and the sharp one (`Elasticity::traction`), `dt = 0.256 / N`;
//!   besides the windowed error, `coupling_curve.svg` plots the largest `|D - D_BEM| / D_BEM`
//!   over the reference curve's times in `[0.5, 3]` (the overshoot the window hides).
//! - `quick`: the vortex at N = 32, 64 and the capsule at N = 24, 32 in f64 and at N = 24 in
//!   f32 (about 15 CPU seconds).
//!
//! The shear error is `|<D>_w - <D_ref>_w| / <D_ref>_w`, the means over the window
//! `t in [2, 3]` (runs end at `t = 3`) of the present `D(t)` and of the boundary-element curve of
//! Ramanujan & Pozrikidis (1998) interpolated at the same times (`cases/reference`). Runs to the
//! steady state cost about ten times more; the window is past the overshoot, where the
//! reference is within 1 % of its late-time value 0.261.
//!
//! Cost is the CPU time of each run (user + system, `/proc/thread-self/stat`): every run has a
//! one-thread rayon pool of its own, so the time does not depend on the machine's load; wall
//! time is recorded too. `--jobs J` runs J cases at once (default 1).
//!
//! Writes into `--out` (default `out/accuracy_cost`): `<study>.csv` and `<study>.svg` (error
//! against CPU seconds, log-log, Pareto front dashed), `shear_all.svg` (every shear run),
//! `recommendation.md`, and `runs.log` (one line per finished run, as they finish). Ends with
//! `RESULT best_err=... cpu_s_5pct=... cpu_s_10pct=... cpu_s_20pct=... runs=... failed=...`
//! (NaN where no run reached the target). `--reference DIR`: another folder laid out as
//! `cases/reference`.
//!
//! Run: `cargo run --release --example accuracy_cost -- --study all --jobs 2`.

use eulermembrane_cases as common;

use common::shear::{self, ShearCase, Steps};
use common::vortex::{self, VortexCase};
use common::{Args, BoxResult, Terms, num, reference_dir, result};
use eulermembrane::Real;
use eulermembrane::fluid::{krylov::KrylovParams, sor::SorParams, stepper::PredictorSolver};
use eulermembrane::interface::geometry::NormalScheme;
use eulermembrane::simulation::{Settings, Traction};
use eulermembrane_cases::csv::{CsvWriter, read_xy};
use eulermembrane_cases::plot::{Figure, LineStyle, Scale};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::sync::Mutex;

/// Capillary number of the shear studies.
const CA: f64 = 0.05;
/// Window of the shear error measure; the runs end at its upper end.
const WINDOW: (f64, f64) = (2.0, 3.0);
/// Targets of the recommendation table (relative error of the windowed `D`).
const TARGETS: [f64; 4] = [0.2, 0.1, 0.05, 0.02];
const STUDIES: [&str; 8] =
    ["vortex", "shear_n", "shear_dt", "precision", "solver", "beta_epsilon", "fast", "coupling"];

#[derive(Clone, Copy, Debug, PartialEq)]
enum Precision {
    F32,
    F64,
}

impl Precision {
    fn bits(self) -> f64 {
        match self {
            Precision::F32 => 32.0,
            Precision::F64 => 64.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Solver {
    Krylov(f64),
    Sor(f64),
}

/// One shear-capsule run.
#[derive(Clone, Debug, PartialEq)]
struct ShearJob {
    n: usize,
    dt: f64,
    precision: Precision,
    solver: Solver,
    beta: f64,
    epsilon: f64,
    traction: Traction,
}

impl ShearJob {
    /// The library's defaults at `n`, `dt = 0.256 / n`.
    fn base(n: usize) -> Self {
        ShearJob {
            n,
            dt: 0.256 / n as f64,
            precision: Precision::F64,
            solver: Solver::Krylov(1e-8),
            beta: 1.0,
            epsilon: 0.01,
            traction: Traction::default(),
        }
    }

    fn settings<T: Real>(&self) -> Settings<T> {
        let mut s = Settings::<T>::default();
        s.flow.predictor = match self.solver {
            Solver::Krylov(tolerance) => {
                PredictorSolver::Krylov(KrylovParams { tolerance, ..Default::default() })
            }
            Solver::Sor(tolerance) => PredictorSolver::Sor(SorParams { tolerance, ..Default::default() }),
        };
        s.epsilon = T::lit(self.epsilon);
        s.with_beta(T::lit(self.beta))
    }

    fn terms(&self) -> Terms {
        Terms { traction: self.traction, ..Terms::default() }
    }

    fn describe(&self) -> String {
        let solver = match self.solver {
            Solver::Krylov(t) => format!("Krylov {t:.0e}"),
            Solver::Sor(t) => format!("SOR {t:.0e}"),
        };
        format!(
            "N = {}, dt = {:.4}, {:?}, {solver}, beta = {}, epsilon = {}, {}",
            self.n,
            self.dt,
            self.precision,
            self.beta,
            self.epsilon,
            self.traction.name()
        )
    }
}

/// One single-vortex run.
#[derive(Clone, Debug, PartialEq)]
struct VortexJob {
    n: usize,
    precision: Precision,
    normals: NormalScheme,
    beta: f64,
}

#[derive(Clone, Debug, PartialEq)]
enum Job {
    Shear(ShearJob),
    Vortex(VortexJob),
}

impl Job {
    fn key(&self) -> String {
        format!("{self:?}")
    }

    /// A rough relative cost, to start the longest runs first.
    fn weight(&self) -> f64 {
        match self {
            Job::Shear(s) => {
                (s.n as f64).powi(3) / s.dt * if matches!(s.solver, Solver::Sor(_)) { 10.0 } else { 1.0 }
            }
            Job::Vortex(v) => (v.n as f64).powi(3) * 0.01,
        }
    }
}

/// What a run measured.
#[derive(Clone, Debug, Default)]
struct Measured {
    /// Shear: relative error of the windowed `D`. Vortex: L1 error of `phi`.
    error: f64,
    /// Shear: the windowed `D`. Vortex: L1 error of `kappa_R delta_bar`.
    value: f64,
    /// Shear: largest relative volume change. Vortex: relative mass change.
    drift: f64,
    /// Shear: the largest `|D - D_BEM| / D_BEM` over the reference's times in `[0.5, 3]`.
    curve_error: f64,
    /// Shear: mean predictor iterations (sweeps for SOR) per step.
    iterations: f64,
    steps: usize,
    cpu_s: f64,
    wall_s: f64,
    failure: Option<String>,
}

fn main() {
    common::exit_on_error(run());
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("accuracy_cost.rs"));
    let out = args.out_dir("accuracy_cost");
    let study: String = args.get("study", "quick".to_string());
    let mut names: Vec<&str> = study.split(',').collect();
    if names.contains(&"all") {
        names = STUDIES.to_vec();
    }
    if let Some(bad) = names.iter().find(|s| !STUDIES.contains(s) && **s != "quick") {
        return Err(format!("--study: one of {} or quick or all, not {bad}", STUDIES.join(", ")).into());
    }
    let opts = Opts {
        max_n: args.get("max-n", 32),
        max_vortex_n: args.get("max-vortex-n", 256),
        study_n: args.get("study-n", 24),
    };
    let reference = read_xy(
        reference_dir(args.opt("reference"), "shear_neo_hookean")?
            .join(format!("ramanujan_pozrikidis_1998_ca_{CA}.csv")),
    )?;
    let studies: Vec<(&str, Vec<Job>)> = names.iter().map(|s| (*s, jobs(s, &opts))).collect();
    let mut unique: Vec<Job> = Vec::new();
    for j in studies.iter().flat_map(|(_, j)| j) {
        if !unique.contains(j) {
            unique.push(j.clone());
        }
    }
    unique.sort_by(|a, b| b.weight().total_cmp(&a.weight()));
    let jobs_at_once: usize = args.get("jobs", 1);
    eprintln!("accuracy_cost: {} runs, {} at once, studies {}", unique.len(), jobs_at_once, names.join(","));
    let done = execute(&unique, jobs_at_once.max(1), &reference, &out.join("runs.log"))?;

    let mut shear_points = Vec::new();
    for (name, list) in &studies {
        if *name == "vortex" {
            vortex_table(&out, name, list, &done)?;
            continue;
        }
        let (vortex_jobs, shear_jobs): (Vec<Job>, Vec<Job>) =
            list.iter().cloned().partition(|j| matches!(j, Job::Vortex(_)));
        if !vortex_jobs.is_empty() {
            vortex_table(&out, &format!("{name}_vortex"), &vortex_jobs, &done)?;
        }
        if !shear_jobs.is_empty() {
            shear_table(&out, name, &shear_jobs, &done)?;
        }
        for j in shear_jobs {
            if let Job::Shear(s) = j
                && !shear_points.iter().any(|(k, _): &(ShearJob, Measured)| *k == s)
            {
                let m = done[&Job::Shear(s.clone()).key()].clone();
                shear_points.push((s, m));
            }
        }
    }
    let failed = done.values().filter(|m| m.failure.is_some()).count();
    let mut cheapest = Vec::new();
    if !shear_points.is_empty() {
        let series =
            vec![("every shear run".to_string(), shear_points.iter().map(|(_, m)| m.clone()).collect())];
        plot(
            &out.join("shear_all.svg"),
            "Shear capsule, Ca = 0.05: all runs",
            "relative error of D",
            &series,
        )?;
        cheapest = recommend(&out, &shear_points)?;
    }
    let best = shear_points
        .iter()
        .filter(|(_, m)| m.failure.is_none())
        .map(|(_, m)| m.error)
        .fold(f64::NAN, f64::min);
    let mut pairs = vec![("best_err", num(best))];
    for (t, c) in TARGETS.iter().zip(&cheapest) {
        pairs.push((
            match *t {
                0.2 => "cpu_s_20pct",
                0.1 => "cpu_s_10pct",
                0.05 => "cpu_s_5pct",
                _ => "cpu_s_2pct",
            },
            format!("{c:.1}"),
        ));
    }
    let (runs, failed) = (done.len().to_string(), failed.to_string());
    pairs.push(("runs", runs));
    pairs.push(("failed", failed));
    result(&pairs);
    Ok(())
}

struct Opts {
    max_n: usize,
    max_vortex_n: usize,
    study_n: usize,
}

/// The runs of a study.
fn jobs(study: &str, o: &Opts) -> Vec<Job> {
    let vortex = |n: usize, precision, normals, beta| Job::Vortex(VortexJob { n, precision, normals, beta });
    let youngs = NormalScheme::Youngs;
    let ns = |list: &[usize], max: usize| list.iter().copied().filter(|&n| n <= max).collect::<Vec<_>>();
    let mut v = Vec::new();
    match study {
        "vortex" => {
            for n in ns(&[32, 64, 128, 256], o.max_vortex_n) {
                v.push(vortex(n, Precision::F64, youngs, 1.0));
                v.push(vortex(n, Precision::F64, NormalScheme::Atanh4, 1.0));
            }
        }
        "shear_n" => {
            v.extend(ns(&[16, 24, 32, 48, 64], o.max_n).into_iter().map(|n| Job::Shear(ShearJob::base(n))))
        }
        "shear_dt" => {
            for (n, factors) in [(24, &[2.0, 1.0, 0.5, 0.25][..]), (32, &[2.0, 1.0][..])] {
                let b = ShearJob::base(n);
                for f in factors {
                    v.push(Job::Shear(ShearJob { dt: b.dt * f, ..b.clone() }));
                }
            }
        }
        "precision" => {
            for n in ns(&[32, 64, 128], o.max_vortex_n) {
                for p in [Precision::F64, Precision::F32] {
                    v.push(vortex(n, p, youngs, 1.0));
                }
            }
            for p in [Precision::F64, Precision::F32] {
                for tol in [1e-8, 1e-5] {
                    v.push(Job::Shear(ShearJob {
                        precision: p,
                        solver: Solver::Krylov(tol),
                        ..ShearJob::base(o.study_n)
                    }));
                }
            }
        }
        "solver" => {
            let b = ShearJob::base(o.study_n);
            for tol in [1e-3, 1e-4, 1e-5, 1e-6, 1e-8] {
                v.push(Job::Shear(ShearJob { solver: Solver::Krylov(tol), ..b.clone() }));
            }
            v.push(Job::Shear(ShearJob { solver: Solver::Sor(1e-6), ..b.clone() }));
        }
        "beta_epsilon" => {
            for beta in [0.5, 1.0, 1.5, 2.0, 3.0] {
                v.push(vortex(64, Precision::F64, youngs, beta));
            }
            let b = ShearJob::base(o.study_n);
            for beta in [0.5, 1.0, 2.0] {
                v.push(Job::Shear(ShearJob { beta, ..b.clone() }));
            }
            for epsilon in [1e-3, 1e-2, 1e-1] {
                v.push(Job::Shear(ShearJob { epsilon, ..b.clone() }));
            }
        }
        "coupling" => {
            for traction in [Traction::Smoothed, Traction::Sharp] {
                for n in ns(&[24, 32, 48, 64, 96, 128], o.max_n) {
                    v.push(Job::Shear(ShearJob { traction, ..ShearJob::base(n) }));
                }
            }
        }
        "fast" => {
            for beta in [1.0, 2.0] {
                for n in ns(&[16, 24, 32, 48, 64, 96], o.max_n) {
                    let dt = 0.512 / n as f64;
                    v.push(Job::Shear(ShearJob {
                        dt,
                        solver: Solver::Krylov(1e-3),
                        beta,
                        ..ShearJob::base(n)
                    }));
                }
            }
        }
        _ => {
            for n in [32, 64] {
                v.push(vortex(n, Precision::F64, youngs, 1.0));
            }
            for n in [24, 32] {
                v.push(Job::Shear(ShearJob::base(n)));
            }
            v.push(Job::Shear(ShearJob { precision: Precision::F32, ..ShearJob::base(24) }));
        }
    }
    v
}

/// Runs `jobs`, `at_once` at a time, each on a one-thread rayon pool of its own; appends a line
/// per finished run to `log`.
fn execute(
    jobs: &[Job],
    at_once: usize,
    reference: &[(f64, f64)],
    log: &Path,
) -> BoxResult<HashMap<String, Measured>> {
    let queue = Mutex::new(jobs.iter());
    let done = Mutex::new(HashMap::new());
    let log = Mutex::new(std::fs::File::create(log)?);
    std::thread::scope(|scope| {
        for _ in 0..at_once {
            scope.spawn(|| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
                loop {
                    let Some(job) = queue.lock().expect("queue").next() else { break };
                    eprintln!("start {job:?}");
                    let m = pool.install(|| measure(job, reference));
                    let line = format!(
                        "{} error={:.4e} curve_error={:.4e} value={:.4e} cpu_s={:.1} wall_s={:.1} steps={} iters={:.1} failure={:?}",
                        job.key(),
                        m.error,
                        m.curve_error,
                        m.value,
                        m.cpu_s,
                        m.wall_s,
                        m.steps,
                        m.iterations,
                        m.failure
                    );
                    eprintln!("done  {line}");
                    // A log that cannot be written loses only this record; the tables follow.
                    let _ = writeln!(log.lock().expect("log"), "{line}");
                    done.lock().expect("results").insert(job.key(), m);
                }
            });
        }
    });
    Ok(done.into_inner().expect("results"))
}

fn measure(job: &Job, reference: &[(f64, f64)]) -> Measured {
    match job {
        Job::Shear(s) => match s.precision {
            Precision::F32 => measure_shear::<f32>(s, reference),
            Precision::F64 => measure_shear::<f64>(s, reference),
        },
        Job::Vortex(v) => match v.precision {
            Precision::F32 => measure_vortex::<f32>(v),
            Precision::F64 => measure_vortex::<f64>(v),
        },
    }
}

fn measure_vortex<T: Real>(job: &VortexJob) -> Measured {
    let case = VortexCase { normals: job.normals, beta: job.beta, ..VortexCase::paper(job.n) };
    match vortex::run::<T>(&case, false, true) {
        Ok(r) => Measured {
            error: r.phi[0],
            value: r.kappa[0],
            drift: r.drift,
            steps: r.steps,
            cpu_s: r.cpu_s,
            wall_s: r.wall_s,
            ..Default::default()
        },
        Err(e) => failed(e.to_string()),
    }
}

fn failed(why: String) -> Measured {
    Measured { error: f64::NAN, value: f64::NAN, failure: Some(why), ..Default::default() }
}

/// Linear interpolation in the points `p` (sorted by x), clamped at the ends.
fn interpolate(p: &[(f64, f64)], x: f64) -> f64 {
    let k = p.partition_point(|q| q.0 < x);
    if k == 0 {
        return p[0].1;
    }
    if k == p.len() {
        return p[k - 1].1;
    }
    let ((x0, y0), (x1, y1)) = (p[k - 1], p[k]);
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

fn measure_shear<T: Real>(job: &ShearJob, reference: &[(f64, f64)]) -> Measured {
    let case = ShearCase {
        n: job.n,
        ca: CA,
        eb_prime: 0.0,
        lambda: 1.0,
        dt: job.dt,
        t_end: WINDOW.1,
        steps: Steps::Fixed,
        box_radii: ShearCase::PAPER_BOX,
        law: Default::default(),
    };
    let o =
        match shear::run::<T>(&case, job.settings::<T>(), job.terms(), 0.05, None, true, shear::Energy::Skip)
        {
            Ok(o) => o,
            Err(e) => return failed(e.to_string()),
        };
    let w: Vec<_> = o.samples.iter().filter(|s| s.t >= WINDOW.0 - 1e-9 && s.t <= WINDOW.1 + 1e-9).collect();
    let mean = |f: &dyn Fn(&shear::ShearSample) -> f64| w.iter().map(|s| f(s)).sum::<f64>() / w.len() as f64;
    let d = mean(&|s| s.d);
    let d_ref = mean(&|s| interpolate(reference, s.t));
    let curve_error = o.max_curve_err(reference, 0.5..=WINDOW.1);
    let m = Measured {
        error: (d - d_ref).abs() / d_ref,
        curve_error,
        value: d,
        drift: o.max_volume_drift,
        iterations: mean(&|s| s.iterations as f64),
        steps: o.steps,
        cpu_s: o.cpu_s,
        wall_s: o.wall_s,
        failure: None,
    };
    if d.is_finite() { m } else { Measured { failure: Some("D is not finite".into()), ..m } }
}

/// The points of a study on the Pareto front: cheapest first, each more accurate than every
/// cheaper one.
fn pareto(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points.iter().copied().filter(|(c, e)| *c > 0.0 && *e > 0.0).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

/// Error against CPU seconds, log-log, one marker series each, the Pareto front dashed.
fn plot(path: &Path, title: &str, error: &str, series: &[(String, Vec<Measured>)]) -> BoxResult<()> {
    let mut fig = Figure::new(title)
        .x_label("CPU seconds (one thread)")
        .y_label(error)
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10);
    let mut all = Vec::new();
    for (label, runs) in series {
        let ok: Vec<(f64, f64)> = runs
            .iter()
            .filter(|m| m.failure.is_none() && m.error > 0.0)
            .map(|m| (m.cpu_s.max(0.01), m.error))
            .collect();
        if ok.is_empty() {
            continue;
        }
        let (x, y): (Vec<f64>, Vec<f64>) = ok.iter().copied().unzip();
        fig.markers(&x, &y, label);
        all.extend(ok);
    }
    let front = pareto(&all);
    if !front.is_empty() {
        let (x, y): (Vec<f64>, Vec<f64>) = front.into_iter().unzip();
        fig.line(&x, &y, "Pareto front").style(LineStyle::Dashed);
    }
    fig.save(path)?;
    Ok(())
}

/// Adds `m` to the series named `label`, opening it if new.
fn add_to_series(series: &mut Vec<(String, Vec<Measured>)>, label: String, m: &Measured) {
    match series.iter_mut().find(|(l, _)| *l == label) {
        Some((_, v)) => v.push(m.clone()),
        None => series.push((label, vec![m.clone()])),
    }
}

fn vortex_table(out: &Path, name: &str, list: &[Job], done: &HashMap<String, Measured>) -> BoxResult<()> {
    let mut csv = CsvWriter::create(
        out.join(format!("{name}.csv")),
        &[
            "n",
            "precision_bits",
            "atanh4",
            "beta",
            "l1_phi",
            "l1_kappa",
            "mass_drift",
            "steps",
            "cpu_s",
            "wall_s",
        ],
    )?;
    let mut series: Vec<(String, Vec<Measured>)> = Vec::new();
    println!("\n{name}: single vortex, one period");
    println!(
        "{:>5} {:>4} {:>8} {:>5} {:>10} {:>10} {:>6} {:>8} {:>8}",
        "N", "bits", "normals", "beta", "L1 phi", "L1 kappa", "steps", "cpu_s", "wall_s"
    );
    for j in list {
        let Job::Vortex(v) = j else { continue };
        let m = &done[&j.key()];
        let atanh4 = v.normals == NormalScheme::Atanh4;
        csv.row(&[
            v.n as f64,
            v.precision.bits(),
            if atanh4 { 1.0 } else { 0.0 },
            v.beta,
            m.error,
            m.value,
            m.drift,
            m.steps as f64,
            m.cpu_s,
            m.wall_s,
        ])?;
        println!(
            "{:>5} {:>4} {:>8} {:>5} {:>10.3e} {:>10.3e} {:>6} {:>8.2} {:>8.2}{}",
            v.n,
            v.precision.bits(),
            v.normals.name(),
            v.beta,
            m.error,
            m.value,
            m.steps,
            m.cpu_s,
            m.wall_s,
            m.failure.as_ref().map(|f| format!("  FAILED: {f}")).unwrap_or_default()
        );
        let label = format!("{:?}, {}, beta = {}", v.precision, v.normals.name(), v.beta);
        let label = if name.contains("beta") { format!("beta = {}, N = {}", v.beta, v.n) } else { label };
        add_to_series(&mut series, label, m);
    }
    csv.finish()?;
    plot(&out.join(format!("{name}.svg")), &format!("Single vortex ({name})"), "L1 error of phi", &series)
}

fn shear_table(out: &Path, name: &str, list: &[Job], done: &HashMap<String, Measured>) -> BoxResult<()> {
    let mut csv = CsvWriter::create(
        out.join(format!("{name}.csv")),
        &[
            "n",
            "dt",
            "precision_bits",
            "sor",
            "tolerance",
            "beta",
            "epsilon",
            "d_window",
            "rel_err",
            "max_curve_err",
            "sharp",
            "volume_drift",
            "iterations",
            "steps",
            "cpu_s",
            "wall_s",
            "ok",
        ],
    )?;
    let mut series: Vec<(String, Vec<Measured>)> = Vec::new();
    println!("\n{name}: shear capsule, Ca = {CA}, D averaged over t in [{}, {}]", WINDOW.0, WINDOW.1);
    println!(
        "{:<58} {:>8} {:>8} {:>8} {:>7} {:>8} {:>8}",
        "run", "D", "rel err", "vol drift", "iters", "cpu_s", "wall_s"
    );
    for j in list {
        let Job::Shear(s) = j else { continue };
        let m = &done[&j.key()];
        let (sor, tol) = match s.solver {
            Solver::Krylov(t) => (0.0, t),
            Solver::Sor(t) => (1.0, t),
        };
        csv.row(&[
            s.n as f64,
            s.dt,
            s.precision.bits(),
            sor,
            tol,
            s.beta,
            s.epsilon,
            m.value,
            m.error,
            m.curve_error,
            if s.traction.is_sharp() { 1.0 } else { 0.0 },
            m.drift,
            m.iterations,
            m.steps as f64,
            m.cpu_s,
            m.wall_s,
            if m.failure.is_none() { 1.0 } else { 0.0 },
        ])?;
        println!(
            "{:<58} {:>8.4} {:>8.4} {:>8.1e} {:>7.1} {:>8.1} {:>8.1}{}",
            s.describe(),
            m.value,
            m.error,
            m.drift,
            m.iterations,
            m.cpu_s,
            m.wall_s,
            m.failure.as_ref().map(|f| format!("  FAILED: {f}")).unwrap_or_default()
        );
        let label = match name {
            "shear_dt" => format!("N = {}", s.n),
            "precision" => format!("{:?}, tol {tol:.0e}", s.precision),
            "solver" => (if sor > 0.0 { "SOR" } else { "Krylov" }).to_string(),
            "fast" => format!("dt = 0.512 / N, Krylov 1e-3, beta = {}", s.beta),
            "coupling" => format!("{} traction", s.traction.name()),
            "beta_epsilon" if s.epsilon != 0.01 => "epsilon".to_string(),
            "beta_epsilon" if s.beta != 1.0 => "beta".to_string(),
            _ => "runs".to_string(),
        };
        add_to_series(&mut series, label, m);
    }
    csv.finish()?;
    if name == "coupling" {
        let curve: Vec<(String, Vec<Measured>)> = series
            .iter()
            .map(|(label, runs)| {
                (label.clone(), runs.iter().map(|m| Measured { error: m.curve_error, ..m.clone() }).collect())
            })
            .collect();
        plot(
            &out.join("coupling_curve.svg"),
            &format!("Shear capsule, Ca = {CA}: largest error over the curve, t in [0.5, {}]", WINDOW.1),
            "max |D - D_BEM| / D_BEM",
            &curve,
        )?;
    }
    plot(
        &out.join(format!("{name}.svg")),
        &format!("Shear capsule, Ca = {CA} ({name})"),
        "relative error of D",
        &series,
    )
}

/// The cheapest run reaching each target error; writes `recommendation.md`; returns their CPU
/// seconds (NaN where none did).
fn recommend(out: &Path, points: &[(ShearJob, Measured)]) -> BoxResult<Vec<f64>> {
    let mut md = String::from(
        "| target error of D | cheapest run reaching it | error | CPU s | wall s |\n|---|---|---|---|---|\n",
    );
    let mut costs = Vec::new();
    for t in TARGETS {
        let best = points
            .iter()
            .filter(|(_, m)| m.failure.is_none() && m.error <= t)
            .min_by(|a, b| a.1.cpu_s.total_cmp(&b.1.cpu_s));
        match best {
            Some((j, m)) => {
                let _ = writeln!(
                    md,
                    "| {:.0} % | {} | {:.1} % | {:.1} | {:.1} |",
                    t * 100.0,
                    j.describe(),
                    m.error * 100.0,
                    m.cpu_s,
                    m.wall_s
                );
                costs.push(m.cpu_s);
            }
            None => {
                let _ = writeln!(md, "| {:.0} % | none of these runs | - | - | - |", t * 100.0);
                costs.push(f64::NAN);
            }
        }
    }
    println!("\nRecommendation (shear capsule, Ca = {CA})\n{md}");
    std::fs::write(out.join("recommendation.md"), md)?;
    Ok(costs)
}
