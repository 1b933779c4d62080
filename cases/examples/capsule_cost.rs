//! What a capsule costs per time step, and whether that cost follows the capsule or the box:
//! `K` identical neo-Hookean spheres (radius 1, `--cells-per-radius` 8) placed at random
//! (`interface::placement`, seed 1, two cells apart at least) in a periodic cube of `N` cells
//! (`N / 8` radii wide at 8 cells per radius), in a periodic shear wave `u_x = sin(2 pi z / L)`
//! (`rho = 1`, `mu = 1`, `E_s = mu a / Ca`, Ca = 0.05), stepped at a fixed `dt = 0.3 h`
//! (`eulermembrane_cases::cost`).
//!
//! For every `N` of `--n` and `K` of `--k`, it builds the scene, takes `--warm` steps, then
//! times `--steps` steps (wall clock, and the process's CPU time over the wall time: the cores
//! used). The step time is `t(K) = a + b K`: `b`, a capsule's share, is what each membrane and
//! its box add; `a` is the flow step of a scene with membranes (their implicit terms make the
//! predictor an iterative solve over the whole grid, a cost of the grid that the first capsule
//! switches on; `K = 0`, the flow alone, shows it). With capsule-local boxes
//! (`Settings::storage`, `--room`) `b` should not depend on `N` and the marginal cost
//! `(t(K_2) - t(K_1)) / (K_2 - K_1)` of consecutive `K >= 1` should be the same.
//!
//! Prints one line per run; writes `cost.csv` into `--out`; ends with `RESULT n=... k=...
//! step_s=... iters=... marginal_s=... per_capsule_s=... flow_s=... box_ratio=... k_spread=...
//! storage=... traction=...`: `step_s`, `iters` (mean predictor iterations) and `marginal_s`
//! list the runs in the order of `--n` then `--k` (`marginal_s` against the previous `K >= 1`
//! of the grid; NaN for the first); `per_capsule_s` and `flow_s` the least-squares `b` and `a`
//! over `K >= 1` of each grid; `box_ratio` the largest over the smallest `b` of the grids;
//! `k_spread` the largest over the smallest marginal cost of a grid (worst grid).
//!
//! Flags: `--n` (`64,128`), `--k` (`0,1,4,16`), `--steps` (10), `--warm` (3), `--room` (1.2,
//! `CapsuleStorage::Boxed { room }`; 0 keeps every capsule on the whole grid),
//! `--cells-per-radius` (8), `--traction sharp|smoothed|sharp-resampled` (`Elasticity::traction`, default the
//! library's), `--out DIR` (`out/capsule_cost`).
//!
//! Run: `cargo run --release -p eulermembrane-cases --example capsule_cost` (a few minutes on
//! 2 cores; `--n 32,64 --cells-per-radius 4` in under one). The same measurement runs as the
//! criterion bench `capsule_cost` (`cargo bench -p eulermembrane-cases --bench capsule_cost`).

use eulermembrane_cases as common;

use common::cost::{periodic_capsules, step};
use common::csv::CsvWriter;
use common::{Args, BoxResult, num, result};
use eulermembrane::simulation::{CapsuleStorage, Settings, Traction};
use std::time::Instant;

fn main() {
    common::exit_on_error(run());
}

/// One run: grid, capsules, seconds per step, cores used, set-up, mean predictor iterations.
struct Run {
    n: usize,
    k: usize,
    step_s: f64,
    cores: f64,
    setup_s: f64,
    iters: f64,
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("capsule_cost.rs"));
    let out = args.out_dir("capsule_cost");
    let ns: Vec<usize> = args.list("n").unwrap_or(vec![64, 128]);
    let ks: Vec<usize> = args.list("k").unwrap_or(vec![0, 1, 4, 16]);
    let (steps, warm): (usize, usize) = (args.get("steps", 10), args.get("warm", 3));
    let cpr: f64 = args.get("cells-per-radius", 8.0);
    let room: f64 = args.get("room", 1.2);
    if !(cpr >= 2.0 && cpr.is_finite()) {
        return Err(format!("--cells-per-radius {cpr}: at least 2").into());
    }
    if steps == 0 || ks.is_empty() || ns.is_empty() {
        return Err("--steps, --k and --n: at least one each".into());
    }
    let storage = if room > 0.0 { CapsuleStorage::Boxed { room } } else { CapsuleStorage::Whole };
    let settings = Settings { storage, ..Settings::default() };
    let traction = args.traction(Traction::default())?;
    let mut csv = CsvWriter::create(
        out.join("cost.csv"),
        &["n", "k", "step_s", "cores", "setup_s", "iters", "marginal_s"],
    )?;
    let mut runs: Vec<Run> = Vec::new();
    for &n in &ns {
        for &k in &ks {
            let clock = Instant::now();
            let mut sim = periodic_capsules(n, k, cpr, settings, traction)?;
            let setup_s = clock.elapsed().as_secs_f64();
            let dt = step(cpr);
            for _ in 0..warm {
                sim.step(dt)?;
            }
            let (clock, cpu) = (Instant::now(), common::process_cpu_seconds());
            let mut iters = 0;
            for _ in 0..steps {
                iters += sim.step(dt)?.flow.predictor_iterations;
            }
            let wall = clock.elapsed().as_secs_f64();
            let r = Run {
                n,
                k,
                step_s: wall / steps as f64,
                cores: (common::process_cpu_seconds() - cpu) / wall,
                setup_s,
                iters: iters as f64 / steps as f64,
            };
            let m = marginal(&runs, &r);
            eprintln!(
                "capsule_cost: N = {n}, K = {k}: {:.4} s per step ({:.2} cores, {:.1} predictor iterations), \
                 set-up {:.1} s, marginal {}",
                r.step_s,
                r.cores,
                r.iters,
                r.setup_s,
                m.map_or("-".into(), |s| format!("{s:.4} s per capsule"))
            );
            csv.row(&[n as f64, k as f64, r.step_s, r.cores, r.setup_s, r.iters, m.unwrap_or(f64::NAN)])?;
            runs.push(r);
        }
    }
    csv.finish()?;
    let fits: Vec<(f64, f64)> = ns.iter().map(|&n| fit(&runs, n)).collect();
    let ratio = |v: Vec<f64>| {
        let v: Vec<f64> = v.into_iter().filter(|x| x.is_finite()).collect();
        match v.len() {
            0 | 1 => f64::NAN,
            _ => v.iter().cloned().fold(f64::MIN, f64::max) / v.iter().cloned().fold(f64::MAX, f64::min),
        }
    };
    let box_ratio = ratio(fits.iter().map(|f| f.1).collect());
    let k_spread = ns
        .iter()
        .map(|&n| ratio(runs.iter().filter(|r| r.n == n).filter_map(|r| marginal(&runs, r)).collect()))
        .filter(|x| x.is_finite())
        .fold(f64::NAN, f64::max);
    let list = |f: &dyn Fn(&Run) -> String| runs.iter().map(f).collect::<Vec<_>>().join(",");
    let join = |v: Vec<String>| v.join(",");
    result(&[
        ("n", list(&|r| r.n.to_string())),
        ("k", list(&|r| r.k.to_string())),
        ("step_s", list(&|r| num(r.step_s))),
        ("iters", list(&|r| format!("{:.1}", r.iters))),
        ("marginal_s", list(&|r| marginal(&runs, r).map_or("NaN".into(), num))),
        ("per_capsule_s", join(fits.iter().map(|f| num(f.1)).collect())),
        ("flow_s", join(fits.iter().map(|f| num(f.0)).collect())),
        ("box_ratio", num(box_ratio)),
        ("k_spread", num(k_spread)),
        ("cores", list(&|r| format!("{:.2}", r.cores))),
        ("setup_s", list(&|r| format!("{:.1}", r.setup_s))),
        ("storage", if room > 0.0 { format!("boxed_room_{room}") } else { "whole".into() }),
        ("traction", traction.name().into()),
        ("cells_per_radius", num(cpr)),
    ]);
    Ok(())
}

/// `(t(K) - t(K')) / (K - K')` of `r` against the run of its grid with the next smaller
/// `K' >= 1` (`None` for the first).
fn marginal(runs: &[Run], r: &Run) -> Option<f64> {
    let prev = runs.iter().filter(|p| p.n == r.n && p.k >= 1 && p.k < r.k).max_by_key(|p| p.k)?;
    Some((r.step_s - prev.step_s) / (r.k - prev.k) as f64)
}

/// The least-squares line `t(K) = a + b K` over the runs of grid `n` with `K >= 1`: `(a, b)`
/// (NaN with fewer than two).
fn fit(runs: &[Run], n: usize) -> (f64, f64) {
    let pts: Vec<(f64, f64)> =
        runs.iter().filter(|r| r.n == n && r.k >= 1).map(|r| (r.k as f64, r.step_s)).collect();
    let m = pts.len() as f64;
    if pts.len() < 2 {
        return (f64::NAN, f64::NAN);
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / m, sy / m);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}
