//! The stability suite of issue 7, long versions: the hard cases of `cases/tests/stability.rs` (a
//! capsule of radius 1 in shear flow, `rho = 1`, `mu = 100`, shear rate 1, `E_s = mu a / Ca`:
//! stiff `Ca = 0.0125`, `Ca = 0.2`, strong bending, viscosity ratios 5 and 1/5, a capsule one
//! radius from a wall, two capsules colliding), each searched for its largest stable `dt` with
//! the quasi-implicit and with the fully explicit membrane stress.
//!
//! Modes (`--mode`):
//! - `cases` (default; about an hour on one core at `--n 16`): per case the bracket of the
//!   largest stable `dt` over `t = 4` (`--t-end`) for both couplings, one line
//!   `RESULT case=... dt_quasi=... dt_explicit=... ratio=... limit_quasi=... limit_explicit=...`
//!   each (`limit_*`: how the first unstable `dt` failed);
//! - `sweep`: the membrane-limited time step against `E_s`, `h` and `mu` (shear rate 0.1, so
//!   that advection does not limit), `RESULT case=sweep_... ...` per point, then a least-squares
//!   fit `dt = C mu^a h^b E_s^c` per coupling, `RESULT fit=explicit c=... mu_exp=... ...`. The
//!   bending points (`case=sweep_bending`) compare the bending couplings instead: `dt_quasi` is
//!   the semi-implicit bending's limit, `dt_explicit` the explicit bending's (both with the
//!   quasi-implicit in-plane stress);
//! - `breakup`: `Ca = 0.2, 0.4, ... 6.4` at a fixed `dt` to `t = --t-end` (6): where the method
//!   fails or the capsule breaks up, `RESULT case=breakup ca=... ...` per capillary number;
//! - `long`: `--steps` (10^4) steps of `--dt` (5e-4) of the `Ca = 0.05` capsule (or `--case`)
//!   on a coarse grid (`--n 16`, capsule radius 4 cells), as `cases/tests/stability.rs` runs it,
//!   `RESULT case=long_... steps=... volume_drift=... area_drift=... elastic_max=...`.
//!
//! Flags: `--n N` (16; cells along x of the 4-wide box), `--mode M`, `--t-end T`, `--only CASE`
//! (cases; `in_plane` or `bending` for sweep), `--traction sharp-resampled|sharp|smoothed`
//! (`smoothed`, the paper's, on which docs/stability.md's tables are measured), `--dt DT` (breakup, long), `--steps S` (long), `--case CASE` (long), `--out DIR`
//! (`out/stability`: a CSV per mode).
//!
//! Run: `cargo run --release --example stability -- --mode sweep`.

use eulermembrane_cases as common;
use eulermembrane_cases::stability;

use common::{Args, num, result};
use eulermembrane::simulation::BendingCoupling;
use eulermembrane::simulation::{MembraneCoupling, Traction};
use eulermembrane_cases::csv::CsvWriter;
use stability::{Bracket, Case, Coupling, Search, build, cases, largest_stable_dt, run};
use std::path::Path;
use std::time::Instant;

fn main() {
    common::exit_on_error(start());
}

/// The in-plane couplings compared: quasi-implicit, then explicit (default bending), each with
/// `traction`.
fn in_plane_couplings(traction: Traction) -> [Coupling; 2] {
    let bending = BendingCoupling::default();
    [MembraneCoupling::QuasiImplicit, MembraneCoupling::Explicit].map(|membrane| Coupling {
        membrane,
        bending,
        traction,
    })
}

/// The bending couplings compared: semi-implicit, then explicit (quasi-implicit in-plane with
/// `traction`).
fn bending_couplings(traction: Traction) -> [Coupling; 2] {
    let membrane = MembraneCoupling::QuasiImplicit;
    [BendingCoupling::default(), BendingCoupling::Explicit].map(|bending| Coupling {
        membrane,
        bending,
        traction,
    })
}

/// The quasi-implicit coupling with `traction` (the breakup and long modes).
fn quasi(traction: Traction) -> Coupling {
    in_plane_couplings(traction)[0]
}

type Res = Result<(), Box<dyn std::error::Error>>;

fn start() -> Res {
    let args = Args::parse(include_str!("stability.rs"));
    let out = args.out_dir("stability");
    let n: usize = args.get("n", 16);
    // The tables of docs/stability.md are measured on the paper's smoothed traction.
    let traction = args.traction(Traction::Smoothed)?;
    match args.get("mode", "cases".to_string()).as_str() {
        "cases" => all_cases(n, args.get("t-end", 4.0), args.opt("only"), traction, &out),
        "sweep" => sweep(n, args.opt("only"), traction, &out),
        "breakup" => breakup(n, args.get("dt", 0.01), args.get("t-end", 6.0), traction, &out),
        "long" => {
            let name: String = args.get("case", "coarse".to_string());
            let case = cases().into_iter().find(|c| c.name == name).unwrap_or(Case::shear("coarse", 0.05));
            long(&case, args.get("n", 16), args.get("dt", 5e-4), args.get("steps", 10_000), traction, &out)
        }
        m => Err(format!("--mode {m}: one of cases, sweep, breakup, long").into()),
    }
}

/// The brackets of the two couplings, with one retry a decade lower when even `lo` fails.
fn brackets(case: &Case, n: usize, search: Search, couplings: [Coupling; 2]) -> [Bracket; 2] {
    couplings.map(|coupling| {
        let clock = Instant::now();
        let mut b = largest_stable_dt(case, n, coupling, search);
        if b.stable == 0.0 {
            let lower = Search { lo: search.lo / 16.0, hi: search.lo, ..search };
            b = largest_stable_dt(case, n, coupling, lower);
        }
        eprintln!(
            "  {:<20} {:?}/{:?}: stable {:.3e}, unstable {:.3e} ({}: {}) [{:.0} s]",
            case.name,
            coupling.membrane,
            coupling.bending,
            b.stable,
            b.unstable,
            b.why.0,
            b.why.1,
            clock.elapsed().as_secs_f64()
        );
        b
    })
}

fn all_cases(n: usize, t_end: f64, only: Option<String>, traction: Traction, out: &Path) -> Res {
    let mut csv = CsvWriter::create(
        out.join("cases.csv"),
        &[
            "e_s",
            "dt_quasi",
            "dt_quasi_unstable",
            "dt_explicit",
            "dt_explicit_unstable",
            "ratio",
            "volume_drift",
            "area_drift",
            "max_cfl",
        ],
    )?;
    let search = Search { t_end, min_steps: 50, lo: 2.5e-3, hi: 6.4e-2, iters: 5 };
    for case in cases().into_iter().filter(|c| only.as_ref().is_none_or(|o| o == c.name)) {
        let [q, e] = brackets(&case, n, search, in_plane_couplings(traction));
        let ratio = q.stable / e.stable;
        let s = &q.at_stable;
        csv.row(&[
            case.e_s(),
            q.stable,
            q.unstable,
            e.stable,
            e.unstable,
            ratio,
            s.volume_drift,
            s.area_drift,
            s.max_cfl,
        ])?;
        result(&[
            ("case", case.name.to_string()),
            ("n", n.to_string()),
            ("traction", traction.name().to_string()),
            ("dt_quasi", num(q.stable)),
            ("dt_explicit", num(e.stable)),
            ("ratio", num(ratio)),
            ("limit_quasi", q.why.0.to_string()),
            ("limit_explicit", e.why.0.to_string()),
            ("volume_drift", num(s.volume_drift)),
            ("area_drift", num(s.area_drift)),
            ("cfl", num(s.max_cfl)),
        ]);
    }
    Ok(())
}

/// A centred capsule at shear rate 0.1 (advection far from its limit) with the given moduli.
fn quiet(e_s: f64, mu: f64, lambda: f64, e_b: f64) -> Case {
    let shear = 0.1;
    Case { shear, mu, lambda, ca: mu * shear / e_s, eb_reduced: e_b / e_s, ..Case::shear("sweep", 1.0) }
}

/// One point of the sweep: `(E_s, cells, mu, lambda, E_b)`.
type Point = (f64, usize, f64, f64, f64);

fn sweep(n: usize, only: Option<String>, traction: Traction, out: &Path) -> Res {
    let mut csv = CsvWriter::create(
        out.join("sweep.csv"),
        &["e_s", "h", "mu", "lambda", "e_b", "dt_quasi", "dt_explicit", "ratio"],
    )?;
    // In-plane: E_s at n and mu = 100, then h, then mu, then the viscosity ratio.
    let in_plane: [Point; 10] = [
        (2.5e4, n, 100.0, 1.0, 0.0),
        (1e5, n, 100.0, 1.0, 0.0),
        (4e5, n, 100.0, 1.0, 0.0),
        (1e5, n * 3 / 4, 100.0, 1.0, 0.0),
        (1e5, n * 3 / 2, 100.0, 1.0, 0.0),
        (1e5, n, 25.0, 1.0, 0.0),
        (1e5, n, 400.0, 1.0, 0.0),
        (1e3, n, 1.0, 1.0, 0.0),
        (1e5, n, 100.0, 5.0, 0.0),
        (1e5, n, 100.0, 0.2, 0.0),
    ];
    // Bending (a soft membrane, E_s = 100): E_b at n, then h.
    let bending: [Point; 3] = [
        (100.0, n, 100.0, 1.0, 250.0),
        (100.0, n, 100.0, 1.0, 1000.0),
        (100.0, n * 3 / 2, 100.0, 1.0, 1000.0),
    ];
    let mut rows = Vec::new();
    let points: Vec<Point> = match only.as_deref() {
        Some("in_plane") => in_plane.to_vec(),
        Some("bending") => bending.to_vec(),
        _ => in_plane.into_iter().chain(bending).collect(),
    };
    for (e_s, cells, mu, lambda, e_b) in points {
        let case = quiet(e_s, mu, lambda, e_b);
        let h = 4.0 / cells as f64;
        let mu_mean = 0.5 * mu * (1.0 + lambda);
        let scale = if e_b > 0.0 { mu_mean * h.powi(3) / e_b } else { mu_mean * h / e_s };
        let search = Search { t_end: 0.2, min_steps: 60, lo: scale / 4.0, hi: 1024.0 * scale, iters: 6 };
        // In-plane points compare the in-plane couplings, bending points the bending ones.
        let [q, e] = brackets(
            &case,
            cells,
            search,
            if e_b > 0.0 { bending_couplings(traction) } else { in_plane_couplings(traction) },
        );
        csv.row(&[e_s, h, mu, lambda, e_b, q.stable, e.stable, q.stable / e.stable])?;
        result(&[
            ("case", if e_b > 0.0 { "sweep_bending" } else { "sweep" }.to_string()),
            ("traction", traction.name().to_string()),
            ("e_s", num(e_s)),
            ("e_b", num(e_b)),
            ("h", num(h)),
            ("mu", num(mu)),
            ("lambda", num(lambda)),
            ("dt_quasi", num(q.stable)),
            ("dt_explicit", num(e.stable)),
            ("ratio", num(q.stable / e.stable)),
            ("dt_quasi_over_scale", num(q.stable / scale)),
            ("dt_explicit_over_scale", num(e.stable / scale)),
            ("limit_quasi", q.why.0.to_string()),
            ("limit_explicit", e.why.0.to_string()),
        ]);
        if e_b == 0.0 && lambda == 1.0 && mu > 1.0 {
            rows.push((e_s, h, mu, q.stable, e.stable));
        }
    }
    for (name, pick) in [("quasi_implicit", 3usize), ("explicit", 4)] {
        let data: Vec<([f64; 3], f64)> = rows
            .iter()
            .map(|r| ([r.2, r.1, r.0], [r.0, r.1, r.2, r.3, r.4][pick]))
            .filter(|(_, dt)| *dt > 0.0 && dt.is_finite())
            .collect();
        if data.len() < 4 {
            continue;
        }
        let (c, ex) = fit_power_law(&data);
        result(&[
            ("fit", name.to_string()),
            ("c", num(c)),
            ("mu_exp", num(ex[0])),
            ("h_exp", num(ex[1])),
            ("e_s_exp", num(ex[2])),
        ]);
    }
    Ok(())
}

/// Least squares of `ln dt = ln C + sum_i e_i ln x_i` (normal equations, 4 unknowns).
fn fit_power_law(data: &[([f64; 3], f64)]) -> (f64, [f64; 3]) {
    let mut a = [[0.0; 5]; 4];
    for (x, dt) in data {
        let row = [1.0, x[0].ln(), x[1].ln(), x[2].ln()];
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] += row[i] * row[j];
            }
            a[i][4] += row[i] * dt.ln();
        }
    }
    // Gauss-Jordan with partial pivoting.
    for col in 0..4 {
        let p = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap_or(col);
        a.swap(col, p);
        let d = a[col][col];
        if d.abs() < 1e-300 {
            return (f64::NAN, [f64::NAN; 3]);
        }
        a[col].iter_mut().for_each(|x| *x /= d);
        let pivot = a[col];
        for row in a.iter_mut().enumerate().filter(|(i, _)| *i != col).map(|(_, r)| r) {
            let f = row[col];
            row.iter_mut().zip(pivot).for_each(|(x, p)| *x -= f * p);
        }
    }
    (a[0][4].exp(), [a[1][4], a[2][4], a[3][4]])
}

fn breakup(n: usize, dt: f64, t_end: f64, traction: Traction, out: &Path) -> Res {
    let mut csv = CsvWriter::create(
        out.join("breakup.csv"),
        &["ca", "t_reached", "completed", "max_area_drift", "area_drift", "volume_drift", "max_elastic"],
    )?;
    let steps = (t_end / dt).round() as usize;
    for ca in [0.2, 0.4, 0.8, 1.6, 3.2, 6.4] {
        let case = Case::shear("breakup", ca);
        let mut sim = build(&case, n, quasi(traction))?;
        let clock = Instant::now();
        let o = run(&mut sim, &case, dt, steps, 10);
        let t = o.steps as f64 * dt;
        eprintln!(
            "  Ca = {ca}: t = {t:.2} of {t_end}, area {:+.3}, {:?} [{:.0} s]",
            o.area_drift,
            o.failure,
            clock.elapsed().as_secs_f64()
        );
        let done = o.failure.is_none();
        csv.row(&[
            ca,
            t,
            f64::from(u8::from(done)),
            o.max_area_drift,
            o.area_drift,
            o.volume_drift,
            o.max_elastic,
        ])?;
        result(&[
            ("case", "breakup".to_string()),
            ("ca", num(ca)),
            ("t_reached", num(t)),
            ("failure", o.failure.as_ref().map_or("none", |f| f.0).to_string()),
            ("max_area_drift", num(o.max_area_drift)),
            ("volume_drift", num(o.volume_drift)),
        ]);
    }
    Ok(())
}

fn long(case: &Case, n: usize, dt: f64, steps: usize, traction: Traction, out: &Path) -> Res {
    let mut sim = build(case, n, quasi(traction))?;
    let clock = Instant::now();
    let mut csv =
        CsvWriter::create(out.join("long.csv"), &["step", "volume_drift", "area_drift", "max_elastic"])?;
    let chunk = (steps / 20).max(1);
    let v0 = sim.volume(0)?;
    let a0 = sim.area(0)?;
    let (mut done, mut failure, mut volume_drift, mut area_drift, mut elastic) =
        (0, None, 0.0f64, 0.0, 0.0f64);
    while done < steps {
        let o = run(&mut sim, case, dt, chunk.min(steps - done), chunk);
        done += o.steps;
        volume_drift = volume_drift.max(((sim.volume(0)? - v0) / v0).abs());
        area_drift = (sim.area(0)? - a0) / a0;
        elastic = elastic.max(o.max_elastic);
        csv.row(&[done as f64, volume_drift, area_drift, elastic])?;
        eprintln!(
            "  step {done}/{steps}: volume drift {volume_drift:.2e}, area drift {area_drift:+.3e}, elastic {:.3e} \
             E_s a^2, cfl {:.3} [{:.0} s]",
            o.max_elastic,
            o.max_cfl,
            clock.elapsed().as_secs_f64()
        );
        if o.failure.is_some() {
            failure = o.failure;
            break;
        }
    }
    result(&[
        ("case", format!("long_{}", case.name)),
        ("n", n.to_string()),
        ("steps", done.to_string()),
        ("failure", failure.as_ref().map_or("none", |f: &(&str, String)| f.0).to_string()),
        ("volume_drift", num(volume_drift)),
        ("area_drift", num(area_drift)),
        ("elastic_max", num(elastic)),
        ("wall_s", num(clock.elapsed().as_secs_f64())),
    ]);
    Ok(())
}
