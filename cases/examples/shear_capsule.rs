//! Sec. 3.3 of the paper: an initially spherical neo-Hookean capsule in simple shear flow,
//! compared with boundary-element results (Ramanujan & Pozrikidis 1998, Pozrikidis 1995/2001,
//! Le 2010) from `cases/reference`. The set-up is in `cases/src/shear.rs`.
//!
//! Prints progress (D, angle, area, predictor iterations, dt, the step's Courant number, the
//! retried steps since the last line and the last `StepWarning`, e.g. a sudden growth of
//! `max|v|`); writes into `--out` the history `history.csv` (t, D, angle, area, volume
//! drift, predictor iterations, dt, the membrane's stored energy `E` and the work `W` the fluid
//! has done on it; written as the run goes, so a failed run leaves it), the plot
//! `deformation.svg` of `D(t)` with the reference curves (like Fig. 10, or Fig. 11 with bending),
//! `energy.svg` of `E(t)` and `W(t)` (the energy identity),
//! ParaView snapshots (`shear.pvd`); ends with `RESULT ca=... n=... eb_prime=...
//! max_curve_err=... d_steady=... angle_deg=... d_ref=... rel_err=... steps=... wall_s=...
//! mean_dt=... t_end=... s0_ratio=...`. The headline, `max_curve_err`, is the largest
//! `|D - D_BEM| / D_BEM` over the times of the Ramanujan & Pozrikidis (1998) curve in `[0.5, 4]`
//! (NaN without it): the error along the whole transient, which a late mean can hide.
//! `d_steady` is the mean `D` over the last time unit and `rel_err` its error against `d_ref`,
//! the published late-time value (NaN where there is none); `t_end` the time reached,
//! `s0_ratio` the membrane's reference area at the end over its initial value; `late_change`
//! the mean `D` over the last time unit against that over `t` in `[6, 7]` (runs to `t` >= 8;
//! NaN otherwise); `energy_leak` the energy identity over the last time unit,
//! `(Delta W - Delta E) / (Delta t mean E)`: the work received less the energy stored, per unit
//! time and stored energy (0 for a coupling that conserves energy; > 0 lost, < 0 created);
//! `repaired` the shell cells whose crushed `G_s` the re-sampled sharp traction re-set over the
//! run (`StepReport::repaired_cells`); `traction`, `law` and `box` say how it ran.
//!
//! Steps: adaptive by default (`simulation::timestep::AdaptiveDt`: Courant target `--cfl`, the membrane
//! and bending limits, at most `--max-dt`); `--dt DT` takes fixed steps of `DT` instead (the
//! paper's is `0.001 (128/N)^2`; with `--bending` keep within the bending rule
//! `simulation::stability::bending_dt_limit`).
//!
//! `--sweep`: every Ca of Fig. 10 (0.0125 ... 0.2) at `--n`, one RESULT line each, a table
//! `sweep.csv` and the plot `sweep.svg` of all histories with the references.
//!
//! Flags: `--ca` (0.05), `--n` (48; cells along x and z, N/2 along y; the radius is N/8
//! cells), `--dt` (fixed steps; none: adaptive), `--cfl` (0.3), `--max-dt` (0.05),
//! `--viscous-theta` (0.6, `Settings`' default `ViscousScheme::Theta(0.6)`; 0.5 is the paper's
//! Crank–Nicolson), `--t-end` (6), `--bending` (`E_b'`, 0 for none),
//! `--lambda` (viscosity ratio, 1), `--vtk-every` (1, time units; 0 for none), `--f32`,
//! `--sweep`, `--gs-transport paper|tangential|frame|both` (`Settings::gs_transport`, default
//! `paper`), `--strain-advection upwind3|upwind5` (`Settings::strain_advection`, default the
//! paper's `upwind3`), `--conserve-area` (`Settings::reference_area`),
//! `--bending-form divergence|energy` (`Bending::form`),
//! `--membrane-coupling quasi-implicit|explicit` (`Elasticity::coupling`, default the paper's
//! quasi-implicit stress (2.32)-(2.35)),
//! `--bending-coupling semi-implicit|explicit` (`Bending::coupling`, default
//! semi-implicit; `--bending-alpha`, 1, its weight `alpha`),
//! `--traction sharp-resampled|sharp|smoothed` (`Elasticity::traction`, default
//! `sharp-resampled`: the membrane moves and pulls as one surface, its shell's outer layers
//! carry the surface's `G_s` and pass their stress to it; it cuts the paper's overshoot at 8
//! cells per radius to a third and runs to `t` = 12; `sharp` leaves the outer layers their own
//! `G_s`; `smoothed` is the paper's and the library's default),
//! `--law neo_hookean|tension_field` (the membrane: the neo-Hookean law (2.5), default, or its
//! tension-field relaxation `membrane::wrinkling::TensionField`, a membrane that wrinkles instead of
//! carrying compression),
//! `--epsilon E` (`Settings::epsilon`, the band `delta h >= E`; 0.01), `--beta B` (the MTHINC
//! sharpness of the profile, `Settings::with_beta`; 1),
//! `--box LX,LY,LZ` (the box in radii, `8,4,8`: the paper's; each a multiple of `8/N`),
//! `--reference DIR`, `--out DIR` (`out/shear_capsule`).
//!
//! Run: `cargo run --release --example shear_capsule` (N = 48, 6 cells per radius: about a
//! minute, `max_curve_err` 0.060; `--n 64` for 8 cells per radius, about three minutes, 0.056;
//! `--n 32` for 4, 15 s, 0.072).

use eulermembrane_cases as common;

use common::shear::{self, Energy, ShearCase, ShearLaw, ShearOutcome, Steps};
use common::{Args, BoxResult, Terms, num, reference_dir, result};
use eulermembrane::fluid::stepper::ViscousScheme;
use eulermembrane::membrane::{bending::BendingForm, strain::StrainAdvection};
use eulermembrane::simulation::{GsTransport, ReferenceArea, Settings, Traction, timestep::AdaptiveDt};
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
    let n: usize = args.get("n", 48);
    let (ca, eb_prime, lambda) = (args.get("ca", 0.05), args.get("bending", 0.0), args.get("lambda", 1.0));
    // `--dt` fixes the steps; without it they are adaptive, at most `--max-dt`.
    let (dt, steps) = match args.opt::<f64>("dt") {
        Some(dt) => (dt, Steps::Fixed),
        None => (args.get("max-dt", 0.05), Steps::Adaptive { cfl: args.get("cfl", AdaptiveDt::DEFAULT_CFL) }),
    };
    let box_radii = match args.list::<f64>("box") {
        None => ShearCase::PAPER_BOX,
        Some(l) => {
            l.try_into().map_err(|l: Vec<f64>| format!("--box: three lengths LX,LY,LZ, got {}", l.len()))?
        }
    };
    let law = match args.opt::<String>("law") {
        Some(name) => ShearLaw::from_name(&name)?,
        None => ShearLaw::default(),
    };
    let base =
        ShearCase { n, ca, eb_prime, lambda, dt, t_end: args.get("t-end", 6.0), steps, box_radii, law };
    let refdir: Option<std::path::PathBuf> = args.opt("reference");
    let numerics = Numerics::from_args(&args)?;
    if args.flag("sweep") {
        let mut fig = Figure::new(format!("Taylor deformation, N = {n} (Fig. 10)")).x_label("t").y_label("D");
        let mut csv = CsvWriter::create(
            out.join("sweep.csv"),
            &["ca", "n", "d_steady", "angle_deg", "d_ref", "rel_err", "wall_s"],
        )?;
        for ca in SWEEP {
            let case = ShearCase { ca, ..base.clone() };
            eprintln!("shear_capsule: Ca = {ca}, N = {n}, {}, t_end = {}", steps_text(&case), case.t_end);
            let o = simulate(&numerics, &case, None)?;
            let (d_ref, rel) = report(&case, &o, refdir.clone(), numerics.terms.traction);
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
        "shear_capsule: Ca = {}, E_b' = {}, lambda = {}, grid {} x {} x {}, {}, t_end = {}",
        base.ca,
        base.eb_prime,
        base.lambda,
        n,
        n / 2,
        n,
        steps_text(&base),
        base.t_end
    );
    let vtk_every: f64 = args.get("vtk-every", 1.0);
    let o = simulate(&numerics, &base, Some((&out, vtk_every))).map_err(|e| {
        format!("{e}\n(the history up to the failure is in {})", out.join("history.csv").display())
    })?;
    let mut fig =
        Figure::new(format!("Taylor deformation, Ca = {}, E_b' = {}, N = {n}", base.ca, base.eb_prime))
            .x_label("t")
            .y_label("D");
    let t: Vec<f64> = o.samples.iter().map(|s| s.t).collect();
    fig.line(&t, &o.samples.iter().map(|s| s.d).collect::<Vec<_>>(), "present (full Eulerian)");
    add_references(&mut fig, refdir.clone(), base.ca, base.eb_prime, false);
    fig.save(out.join("deformation.svg"))?;
    // The energy identity: without losses the stored energy follows the work received.
    let mut energy =
        Figure::new(format!("Energy identity, Ca = {}, N = {n}", base.ca)).x_label("t").y_label("energy");
    energy.line(&t, &o.samples.iter().map(|s| s.elastic_energy).collect::<Vec<_>>(), "stored energy E");
    energy
        .line(&t, &o.samples.iter().map(|s| s.membrane_work).collect::<Vec<_>>(), "work received W")
        .style(LineStyle::Dashed);
    energy.save(out.join("energy.svg"))?;
    report(&base, &o, refdir, numerics.terms.traction);
    Ok(())
}

/// How `case` steps, for the first line of a run.
fn steps_text(case: &ShearCase) -> String {
    match case.steps {
        Steps::Fixed => format!("dt = {:.3e}", case.dt),
        Steps::Adaptive { cfl } => format!("adaptive steps (Courant number {cfl}, dt <= {:.3e})", case.dt),
    }
}

/// The numerical choices of the flags, parsed once.
struct Numerics {
    terms: Terms,
    gs_transport: GsTransport,
    strain_advection: StrainAdvection,
    reference_area: ReferenceArea,
    viscous: ViscousScheme,
    epsilon: f64,
    beta: f64,
    f32: bool,
}

impl Numerics {
    fn from_args(args: &Args) -> BoxResult<Self> {
        let theta: f64 = args.get("viscous-theta", 0.6);
        Ok(Numerics {
            terms: Terms {
                traction: args.traction(Traction::default())?,
                bending_form: BendingForm::from_name(&args.get("bending-form", "divergence".to_string()))?,
                bending_coupling: args.bending_coupling()?,
                coupling: args.membrane_coupling()?,
            },
            gs_transport: GsTransport::from_name(&args.get("gs-transport", "paper".to_string()))?,
            strain_advection: args.strain_advection()?,
            reference_area: if args.flag("conserve-area") {
                ReferenceArea::Conserved
            } else {
                ReferenceArea::Transported
            },
            viscous: if theta == 0.5 { ViscousScheme::CrankNicolson } else { ViscousScheme::Theta(theta) },
            epsilon: args.get("epsilon", 0.01),
            beta: args.get("beta", 1.0),
            f32: args.flag("f32"),
        })
    }

    fn settings<T: eulermembrane::Real>(&self) -> Settings<T> {
        let mut s = Settings {
            gs_transport: self.gs_transport,
            strain_advection: self.strain_advection,
            reference_area: self.reference_area,
            epsilon: T::lit(self.epsilon),
            ..Settings::default()
        };
        s.flow.viscous = self.viscous;
        s.with_beta(T::lit(self.beta))
    }
}

/// Runs one case in the precision the flags ask for.
fn simulate(numerics: &Numerics, case: &ShearCase, vtk: Option<(&Path, f64)>) -> BoxResult<ShearOutcome> {
    if numerics.f32 {
        shear::run::<f32>(case, numerics.settings(), numerics.terms, 0.05, vtk, false, Energy::Identity)
    } else {
        shear::run::<f64>(case, numerics.settings(), numerics.terms, 0.05, vtk, false, Energy::Identity)
    }
}

/// The largest `|D - D_BEM| / D_BEM` over the times of the Ramanujan & Pozrikidis (1998)
/// curve for this Ca in `[0.5, 4]` that the run reached (`D` interpolated linearly between
/// samples); NaN without the curve or with bending or a viscosity contrast.
fn max_curve_err(case: &ShearCase, o: &ShearOutcome, given: Option<std::path::PathBuf>) -> f64 {
    if case.eb_prime > 0.0 || case.lambda != 1.0 {
        return f64::NAN;
    }
    let Ok(dir) = reference_dir(given, "shear_neo_hookean") else { return f64::NAN };
    let Ok(curve) = read_xy(dir.join(format!("ramanujan_pozrikidis_1998_ca_{}.csv", case.ca))) else {
        return f64::NAN;
    };
    o.max_curve_err(&curve, 0.5..=4.0)
}

/// The steadiness of a long run: the mean `D` over its last time unit against the mean over
/// `t` in `[6, 7]`, relative (NaN for runs that end before `t` = 8).
fn late_change(o: &ShearOutcome) -> f64 {
    let mean = |a: f64, b: f64| {
        let w: Vec<f64> = o.samples.iter().filter(|s| s.t >= a && s.t <= b).map(|s| s.d).collect();
        if w.is_empty() { f64::NAN } else { w.iter().sum::<f64>() / w.len() as f64 }
    };
    if o.t_end < 8.0 {
        return f64::NAN;
    }
    let early = mean(6.0, 7.0);
    (mean(o.t_end - 1.0, o.t_end) - early) / early
}

/// Prints the RESULT line of a run; returns the reference `D` and the relative error (NaN
/// where there is no reference).
fn report(
    case: &ShearCase,
    o: &ShearOutcome,
    refdir: Option<std::path::PathBuf>,
    traction: Traction,
) -> (f64, f64) {
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
        // The headline: the error along the whole curve, which a late mean can hide.
        ("max_curve_err", num(max_curve_err(case, o, refdir))),
        ("d_steady", num(o.d_steady)),
        ("angle_deg", format!("{:.2}", o.angle_steady)),
        ("d_ref", num(d_ref)),
        ("rel_err", num(rel)),
        ("volume_drift", num(o.max_volume_drift)),
        ("steps", o.steps.to_string()),
        ("wall_s", format!("{:.1}", o.wall_s)),
        ("d_ellipsoid", num(o.d_ellipsoid_steady)),
        ("angle_ellipsoid_deg", format!("{:.2}", o.angle_ellipsoid_steady)),
        ("mean_dt", num(o.t_end / o.steps.max(1) as f64)),
        ("t_end", format!("{:.4}", o.t_end)),
        ("s0_ratio", num(o.s0_ratio)),
        ("late_change", num(late_change(o))),
        ("energy_leak", num(o.energy_leak)),
        ("repaired", o.repaired_cells.to_string()),
        ("traction", traction.name().to_string()),
        ("law", case.law.name().to_string()),
        ("box", case.box_radii.map(|l| l.to_string()).join(",")),
    ]);
    (d_ref, rel)
}

/// Adds the published curves for this Ca (and `E_b'`) found in `cases/reference`; a missing
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
