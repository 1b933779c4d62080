//! Sec. 3.3 of the paper: an initially spherical neo-Hookean capsule in simple shear flow,
//! compared with boundary-element results (Ramanujan & Pozrikidis 1998, Pozrikidis 1995/2001,
//! Le 2010) from `shared/reference`. The set-up is in `cases/src/shear.rs`.
//!
//! Prints progress; writes into `--out` the history `history.csv` (t, D, angle, area, volume
//! drift, predictor iterations; written as the run goes, so a failed run leaves it), the plot `deformation.svg` of `D(t)` with the reference curves
//! (like Fig. 10, or Fig. 11 with bending), ParaView snapshots (`shear.pvd`); ends with
//! `RESULT ca=... n=... d_steady=... angle_deg=... d_ref=... rel_err=... wall_s=...`, where
//! `d_steady` is the mean `D` over the last time unit and `d_ref` the published late-time value
//! (NaN where there is none).
//!
//! `--sweep`: every Ca of Fig. 10 (0.0125 ... 0.2) at `--n`, one RESULT line each, a table
//! `sweep.csv` and the plot `sweep.svg` of all histories with the references.
//!
//! Flags: `--ca` (0.05), `--n` (32; cells along x and z, N/2 along y; the radius is N/8
//! cells), `--dt` (half the paper's `0.001 (128/N)^2`, and within the bending rule with
//! `--bending`; see `common::shear`), `--t-end` (6), `--bending` (`E_b'`, 0 for none),
//! `--lambda` (viscosity ratio, 1), `--vtk-every` (1, time units; 0 for none), `--f32`,
//! `--sweep`, `--gs-transport paper|tangential|frame|both` (`Settings::gs_transport`, default
//! `paper`), `--conserve-area` (`Settings::reference_area`),
//! `--bending-form divergence|energy` (`Settings::bending_form`),
//! `--reference DIR`, `--out DIR` (`out/shear_capsule`).
//!
//! Run: `cargo run --release --example shear_capsule` (about a minute on 2 cores; `--n 64` for
//! 8 cells per radius, about 30 minutes).

use eulermembrane_cases as common;

use common::shear::{self, ShearCase, ShearOutcome};
use common::{Args, BoxResult, num, reference_dir, result};
use eulermembrane::membrane::BendingForm;
use eulermembrane::simulation::{GsTransport, ReferenceArea, Settings};
use eulermembrane_cases::csv::{CsvWriter, read_xy};
use eulermembrane_cases::plot::{Figure, LineStyle};
use std::path::Path;

const SWEEP: [f64; 5] = [0.0125, 0.025, 0.05, 0.1, 0.2];

fn main() {
    common::exit_on_error(run());
}

fn run() -> BoxResult<()> {
    let args = Args::parse(include_str!("shear_capsule.rs"));
    let out = args.out_dir("shear_capsule");
    let n: usize = args.get("n", 32);
    let (ca, eb_prime, lambda) = (args.get("ca", 0.05), args.get("bending", 0.0), args.get("lambda", 1.0));
    let base = ShearCase {
        n,
        ca,
        eb_prime,
        lambda,
        dt: args.get("dt", ShearCase::default_dt(n, ca, eb_prime, lambda)),
        t_end: args.get("t-end", 6.0),
    };
    let refdir: Option<std::path::PathBuf> = args.opt("reference");
    if args.flag("sweep") {
        let mut fig = Figure::new(format!("Taylor deformation, N = {n} (Fig. 10)")).x_label("t").y_label("D");
        let mut csv = CsvWriter::create(
            out.join("sweep.csv"),
            &["ca", "n", "d_steady", "angle_deg", "d_ref", "rel_err", "wall_s"],
        )?;
        for ca in SWEEP {
            let case = ShearCase { ca, ..base.clone() };
            eprintln!("shear_capsule: Ca = {ca}, N = {n}, dt = {:.3e}, t_end = {}", case.dt, case.t_end);
            let o = simulate(&args, &case, None)?;
            let (d_ref, rel) = report(&case, &o);
            csv.row(&[ca, n as f64, o.d_steady, o.angle_steady, d_ref, rel, o.wall_s])?;
            let t: Vec<f64> = o.samples.iter().map(|s| s.t).collect();
            fig.line(&t, &o.samples.iter().map(|s| s.d).collect::<Vec<_>>(), &format!("Ca = {ca}"));
            add_references(&mut fig, refdir.clone(), ca, 0.0, true);
        }
        csv.finish()?;
        fig.save(out.join("sweep.svg"))?;
        return Ok(());
    }
    eprintln!(
        "shear_capsule: Ca = {}, E_b' = {}, lambda = {}, grid {} x {} x {}, dt = {:.3e}, t_end = {}",
        base.ca,
        base.eb_prime,
        base.lambda,
        n,
        n / 2,
        n,
        base.dt,
        base.t_end
    );
    let vtk_every: f64 = args.get("vtk-every", 1.0);
    let o = simulate(&args, &base, Some((&out, vtk_every))).map_err(|e| {
        format!("{e}\n(the history up to the failure is in {})", out.join("history.csv").display())
    })?;
    let mut fig =
        Figure::new(format!("Taylor deformation, Ca = {}, E_b' = {}, N = {n}", base.ca, base.eb_prime))
            .x_label("t")
            .y_label("D");
    let t: Vec<f64> = o.samples.iter().map(|s| s.t).collect();
    fig.line(&t, &o.samples.iter().map(|s| s.d).collect::<Vec<_>>(), "present (full Eulerian)");
    add_references(&mut fig, refdir, base.ca, base.eb_prime, false);
    fig.save(out.join("deformation.svg"))?;
    report(&base, &o);
    Ok(())
}

/// Runs one case in the precision the flags ask for.
fn simulate(args: &Args, case: &ShearCase, vtk: Option<(&Path, f64)>) -> BoxResult<ShearOutcome> {
    fn settings<T: eulermembrane::Real>(
        args: &Args,
        bending_form: BendingForm,
        gs_transport: GsTransport,
    ) -> Settings<T> {
        let reference_area =
            if args.flag("conserve-area") { ReferenceArea::Conserved } else { ReferenceArea::Transported };
        Settings { gs_transport, reference_area, bending_form, ..Settings::default() }
    }
    let form = BendingForm::from_name(&args.get("bending-form", "divergence".to_string()))?;
    let transport = GsTransport::from_name(&args.get("gs-transport", "paper".to_string()))?;
    if args.flag("f32") {
        shear::run::<f32>(case, settings(args, form, transport), 0.05, vtk, false)
    } else {
        shear::run::<f64>(case, settings(args, form, transport), 0.05, vtk, false)
    }
}

/// Prints the RESULT line of a run; returns the reference `D` and the relative error (NaN
/// where there is no reference).
fn report(case: &ShearCase, o: &ShearOutcome) -> (f64, f64) {
    let d_ref = if case.lambda == 1.0 {
        shear::reference_d(case.ca, case.eb_prime).unwrap_or(f64::NAN)
    } else {
        f64::NAN
    };
    let rel = (o.d_steady - d_ref) / d_ref;
    result(&[
        ("ca", case.ca.to_string()),
        ("n", case.n.to_string()),
        ("eb_prime", case.eb_prime.to_string()),
        ("d_steady", num(o.d_steady)),
        ("angle_deg", format!("{:.2}", o.angle_steady)),
        ("d_ref", num(d_ref)),
        ("rel_err", num(rel)),
        ("volume_drift", num(o.max_volume_drift)),
        ("steps", o.steps.to_string()),
        ("wall_s", format!("{:.1}", o.wall_s)),
        ("d_ellipsoid", num(o.d_ellipsoid_steady)),
        ("angle_ellipsoid_deg", format!("{:.2}", o.angle_ellipsoid_steady)),
    ]);
    (d_ref, rel)
}

/// Adds the published curves for this Ca (and `E_b'`) found in `shared/reference`; a missing
/// folder is reported and skipped (the plot then shows the present result only).
fn add_references(
    fig: &mut Figure,
    given: Option<std::path::PathBuf>,
    ca: f64,
    eb_prime: f64,
    dashed_only: bool,
) {
    let (sub, files): (&str, Vec<(String, String)>) = if eb_prime > 0.0 {
        (
            "shear_bending",
            vec![
                (format!("pozrikidis_2001_ca_{ca}_eb_{eb_prime}.csv"), "Pozrikidis 2001 (BEM)".into()),
                (format!("le_2010_ca_{ca}_eb_{eb_prime}.csv"), "Le 2010".into()),
            ],
        )
    } else {
        (
            "shear_neo_hookean",
            vec![
                (
                    format!("ramanujan_pozrikidis_1998_ca_{ca}.csv"),
                    format!("Ramanujan & Pozrikidis 1998, Ca = {ca}"),
                ),
                (format!("pozrikidis_1995_ca_{ca}.csv"), format!("Pozrikidis 1995, Ca = {ca}")),
            ],
        )
    };
    let dir = match reference_dir(given, sub) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("note: {e}");
            return;
        }
    };
    for (k, (file, label)) in files.iter().enumerate() {
        let path = dir.join(file);
        if !path.is_file() {
            continue;
        }
        match read_xy(&path) {
            Ok(p) => {
                let (x, y): (Vec<f64>, Vec<f64>) = p.into_iter().unzip();
                let style = if k == 0 || dashed_only { LineStyle::Dashed } else { LineStyle::Dotted };
                fig.line(&x, &y, label).style(style);
            }
            Err(e) => eprintln!("note: {e}"),
        }
    }
}
