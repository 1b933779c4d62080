//! Uniaxial stretching of a flat membrane: tension–strain curves of the neo-Hookean (2.5) and
//! Skalak (2.6) laws, three ways.
//!
//! A flat sheet (`n = e3`) is stretched by `λ1` along `e1` with the lateral edge free
//! (`T2 = 0`). For each law the principal tension `T1/G_s` is plotted against the Green–Lagrange
//! strain `e1 = (λ1² − 1)/2`:
//!
//! 1. by the closed forms derived in `membrane::law` (`NeoHookean::uniaxial_tension`,
//!    `Skalak::uniaxial_tension`): `T1/G_s = λ1^{3/2} − λ1^{-3/2}` (neo-Hookean) and
//!    `T1/G_s = (λ1/λ2)(λ1² − 1)(1 + α λ2²/(1 + α λ1⁴))`, `λ2² = (1 + α λ1²)/(1 + α λ1⁴)`
//!    (Skalak);
//! 2. by the generic code the grid solver uses — the stress (2.4) of `membrane::stress::stress` from
//!    the laws' energy derivatives, with `λ2` found by a safeguarded Newton iteration on
//!    `T2 = 0` (`membrane::loading::uniaxial_tension`);
//! 3. against the points digitised from Barthès-Biesel, Diaz & Dhenin, J. Fluid Mech. 460
//!    (2002), for neo-Hookean and Skalak with area-dilation coefficient `C = 1`.
//!
//! Conventions (cases/reference/README.md): neo-Hookean `E_s = 3 G_s`; Skalak `G_s = E_s/2`
//! and `C = α` (eq. (2.6) is exactly `(G_s/4)(I1² + 2 I1 − 2 I2 + C I2²)`), so `α = 1`.
//! Here `G_s = 1`.
//!
//! Usage: `cargo run --release --example uniaxial_stretch -- [--out DIR] [--n N]
//! [--reference DIR]`. `--n` is the number of samples on each model curve (default 200);
//! `--out` (default `out/uniaxial_stretch`) receives `model_curves.csv`,
//! `bb2002_comparison.csv` and `uniaxial_stretch.svg`; `--reference` is the folder holding
//! `uniaxial_stretch/*.csv` (default: `cases/reference`).
//!
//! The last line is `RESULT max_rel_err_neo_hookean=… max_rel_err_skalak=…
//! max_rel_err_bb2002=…`: the first two are the largest relative differences between the
//! generic code and the closed form over `0 < e1 ≤ 1` (must be ≤ 1e-10); the last is the
//! largest difference between a published point and the model **relative to the curve's full
//! scale** (the largest model `T1/G_s` over the digitised range), must be ≤ 0.03. Pointwise
//! relative errors `|y − T1|/T1` are printed above it: they exceed 3% for some points, mostly
//! at small strain where the digitisation scatter (≈ ±0.02 G_s) is a large fraction of a
//! small tension (see tests/membrane_laws.rs, `bb2002_pointwise_relative_errors`).

use eulermembrane_cases as common;

use eulermembrane::membrane::{
    law::{NeoHookean, Skalak, SurfaceLaw},
    loading::uniaxial_tension,
};
use std::fmt::Write as _;

use common::BoxResult;

/// One law's comparison with the published points.
struct Published {
    name: &'static str,
    /// (e1, published T1/G_s, model T1/G_s)
    points: Vec<(f64, f64, f64)>,
    full_scale: f64,
}

impl Published {
    fn max_full_scale_err(&self) -> f64 {
        self.points.iter().map(|p| (p.1 - p.2).abs() / self.full_scale).fold(0.0, f64::max)
    }
    fn pointwise(&self) -> impl Iterator<Item = f64> + '_ {
        self.points.iter().map(|p| (p.1 - p.2).abs() / p.2.abs())
    }
}

fn main() {
    common::exit_on_error(run());
}

fn run() -> BoxResult<()> {
    let args = common::Args::parse(include_str!("uniaxial_stretch.rs"));
    let out = args.out_dir("uniaxial_stretch");
    let n: usize = args.get("n", 200);
    if n < 2 {
        return Err(format!("--n {n}: at least 2").into());
    }

    // G_s = 1 for both laws.
    let neo = NeoHookean::new(3.0)?;
    let skalak = Skalak::new(2.0, 1.0)?;
    println!("Uniaxial tension of a flat membrane (T2 = 0), G_s = 1");
    println!("  {}: E_s = {}, G_s = {}", SurfaceLaw::<f64>::name(&neo), neo.es(), neo.shear_modulus());
    println!(
        "  {}: E_s = {}, alpha = C = {}, G_s = {}",
        SurfaceLaw::<f64>::name(&skalak),
        skalak.es(),
        skalak.alpha(),
        skalak.shear_modulus()
    );

    // 1 + 2: model curves, closed form and generic code, 0 < e1 <= 1.
    let e_max = 1.0;
    let mut csv = String::from(
        "e1,lambda1,neo_hookean_closed,neo_hookean_generic,neo_hookean_lambda2,\
         skalak_closed,skalak_generic,skalak_lambda2\n",
    );
    let (mut err_neo, mut err_sk) = (0.0f64, 0.0f64);
    let mut curve_neo = Vec::with_capacity(n);
    let mut curve_sk = Vec::with_capacity(n);
    for i in 1..=n {
        let e1 = e_max * i as f64 / n as f64;
        let l1 = (1.0 + 2.0 * e1).sqrt();
        let (tn, l2n) = neo.uniaxial_tension(l1);
        let (ts, l2s) = skalak.uniaxial_tension(l1);
        let (gn, _) = uniaxial_tension(&neo, l1)?;
        let (gs, _) = uniaxial_tension(&skalak, l1)?;
        err_neo = err_neo.max((gn - tn).abs() / tn.abs());
        err_sk = err_sk.max((gs - ts).abs() / ts.abs());
        curve_neo.push((e1, tn));
        curve_sk.push((e1, ts));
        writeln!(csv, "{e1:.6},{l1:.12},{tn:.15e},{gn:.15e},{l2n:.12},{ts:.15e},{gs:.15e},{l2s:.12}")?;
    }
    let curves_path = out.join("model_curves.csv");
    std::fs::write(&curves_path, csv).map_err(|e| format!("{}: {e}", curves_path.display()))?;

    // 3: published points.
    let refdir = common::reference_dir(args.opt("reference"), "uniaxial_stretch")?;
    let mut published = Vec::new();
    for (name, file, law) in [
        ("neo_hookean", "barthes_biesel_2002_neo_hookean.csv", &neo as &dyn SurfaceLaw<f64>),
        ("skalak", "barthes_biesel_2002_skalak.csv", &skalak),
    ] {
        let mut points = Vec::new();
        for (e1, y) in common::csv::read_xy(refdir.join(file))? {
            let (t, _) = uniaxial_tension(law, (1.0 + 2.0 * e1).sqrt())?;
            points.push((e1, y, t));
        }
        let full_scale = points.iter().map(|p| p.2).fold(0.0, f64::max);
        published.push(Published { name, points, full_scale });
    }
    let mut cmp = String::from("law,e1,published,model,rel_err_pointwise,err_over_full_scale\n");
    for p in &published {
        for &(e1, y, t) in &p.points {
            let (r, f) = ((y - t).abs() / t.abs(), (y - t).abs() / p.full_scale);
            writeln!(cmp, "{},{e1:.6},{y:.6},{t:.6},{r:.6},{f:.6}", p.name)?;
        }
    }
    let cmp_path = out.join("bb2002_comparison.csv");
    std::fs::write(&cmp_path, cmp).map_err(|e| format!("{}: {e}", cmp_path.display()))?;

    // Plot.
    let svg = svg_plot(
        &[
            Series { label: "neo-Hookean, closed form", color: "#1f77b4", kind: Kind::Line(&curve_neo) },
            Series { label: "Skalak C = 1, closed form", color: "#d62728", kind: Kind::Line(&curve_sk) },
            Series {
                label: "neo-Hookean, generic stress code",
                color: "#1f77b4",
                kind: Kind::Dots(&subsample(&curve_neo, 10)),
            },
            Series {
                label: "Skalak, generic stress code",
                color: "#d62728",
                kind: Kind::Dots(&subsample(&curve_sk, 10)),
            },
            Series {
                label: "Barthès-Biesel et al. 2002, neo-Hookean",
                color: "#1f77b4",
                kind: Kind::Circles(&published[0].points.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>()),
            },
            Series {
                label: "Barthès-Biesel et al. 2002, Skalak C = 1",
                color: "#d62728",
                kind: Kind::Circles(&published[1].points.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>()),
            },
        ],
        (0.0, e_max),
        (0.0, 6.0),
        "e1 = (λ1² − 1)/2",
        "T1 / G_s",
        "Uniaxial tension of a flat membrane",
    );
    let svg_path = out.join("uniaxial_stretch.svg");
    std::fs::write(&svg_path, svg).map_err(|e| format!("{}: {e}", svg_path.display()))?;

    // Summary table.
    println!();
    println!(
        "{:>6} {:>9} | {:>12} {:>12} | {:>12} {:>12}",
        "e1", "lambda1", "NH closed", "NH generic", "SK closed", "SK generic"
    );
    for k in 1..=10 {
        let e1 = 0.1 * k as f64;
        let l1 = (1.0 + 2.0 * e1).sqrt();
        println!(
            "{e1:>6.2} {l1:>9.5} | {:>12.8} {:>12.8} | {:>12.8} {:>12.8}",
            neo.uniaxial_tension(l1).0,
            uniaxial_tension(&neo, l1)?.0,
            skalak.uniaxial_tension(l1).0,
            uniaxial_tension(&skalak, l1)?.0
        );
    }
    println!();
    println!("Generic stress code vs closed form (0 < e1 <= {e_max}, {} samples):", n);
    println!("  neo_hookean max relative difference {err_neo:.3e}");
    println!("  skalak      max relative difference {err_sk:.3e}");
    println!();
    println!("Barthès-Biesel et al. (2002), digitised points vs model:");
    let mut max_fs = 0.0f64;
    for p in &published {
        let fs = p.max_full_scale_err();
        max_fs = max_fs.max(fs);
        let pw: Vec<f64> = p.pointwise().collect();
        let over = pw.iter().filter(|&&r| r > 0.03).count();
        let (kmax, rmax) =
            pw.iter().enumerate().fold((0, 0.0f64), |m, (k, &r)| if r > m.1 { (k, r) } else { m });
        let large: Vec<f64> = p.points.iter().zip(&pw).filter(|(q, _)| q.0 >= 0.2).map(|(_, &r)| r).collect();
        let rmax_large = large.iter().copied().fold(0.0, f64::max);
        println!(
            "  {:<11} {} points, full scale {:.3}: max |error|/full scale {:.4}; pointwise \
             relative: max {:.3} (point #{kmax}, e1 = {:.4}), {over} points > 3%, \
             max {:.4} for e1 >= 0.2",
            p.name,
            p.points.len(),
            p.full_scale,
            fs,
            rmax,
            p.points[kmax].0,
            rmax_large
        );
    }
    println!();
    println!("Wrote {}, {} and {}", curves_path.display(), cmp_path.display(), svg_path.display());
    println!(
        "RESULT max_rel_err_neo_hookean={err_neo:.3e} max_rel_err_skalak={err_sk:.3e} max_rel_err_bb2002={max_fs:.4}"
    );
    Ok(())
}

fn subsample(v: &[(f64, f64)], every: usize) -> Vec<(f64, f64)> {
    v.iter().skip(every - 1).step_by(every).copied().collect()
}

// ---------------------------------------------------------------------------------------------
// A small self-contained SVG line plot.
// ---------------------------------------------------------------------------------------------

enum Kind<'a> {
    Line(&'a [(f64, f64)]),
    Dots(&'a [(f64, f64)]),
    Circles(&'a [(f64, f64)]),
}

struct Series<'a> {
    label: &'a str,
    color: &'a str,
    kind: Kind<'a>,
}

fn svg_plot(
    series: &[Series],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    xlabel: &str,
    ylabel: &str,
    title: &str,
) -> String {
    let (w, h) = (720.0, 500.0);
    let (ml, mr, mt, mb) = (70.0, 20.0, 40.0, 60.0);
    let px = |x: f64| ml + (x - x0) / (x1 - x0) * (w - ml - mr);
    let py = |y: f64| h - mb - (y - y0) / (y1 - y0) * (h - mt - mb);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="{}" y="24" text-anchor="middle" font-size="16">{title}</text>"#, w / 2.0);
    // Grid and ticks.
    for k in 0..=5 {
        let x = x0 + (x1 - x0) * k as f64 / 5.0;
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="#ddd"/><text x="{0:.1}" y="{3:.1}" text-anchor="middle">{x:.1}</text>"##,
            px(x),
            py(y0),
            py(y1),
            py(y0) + 18.0
        );
    }
    for k in 0..=6 {
        let y = y0 + (y1 - y0) * k as f64 / 6.0;
        let _ = writeln!(
            s,
            r##"<line x1="{1:.1}" y1="{0:.1}" x2="{2:.1}" y2="{0:.1}" stroke="#ddd"/><text x="{3:.1}" y="{4:.1}" text-anchor="end">{y:.0}</text>"##,
            py(y),
            px(x0),
            px(x1),
            px(x0) - 6.0,
            py(y) + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{ml}" y="{mt}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        w - ml - mr,
        h - mt - mb
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{xlabel}</text>"#,
        (ml + w - mr) / 2.0,
        h - 15.0
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{0}" text-anchor="middle" transform="rotate(-90 18 {0})">{ylabel}</text>"#,
        (mt + h - mb) / 2.0
    );
    let inside = |&(x, y): &(f64, f64)| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    for (k, se) in series.iter().enumerate() {
        match se.kind {
            Kind::Line(pts) => {
                let path: Vec<String> = pts
                    .iter()
                    .filter(|p| inside(p))
                    .map(|&(x, y)| format!("{:.2},{:.2}", px(x), py(y)))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polyline fill="none" stroke="{}" stroke-width="2" points="{}"/>"#,
                    se.color,
                    path.join(" ")
                );
            }
            Kind::Dots(pts) => {
                for &(x, y) in pts.iter().filter(|p| inside(p)) {
                    let _ = writeln!(
                        s,
                        r#"<rect x="{:.2}" y="{:.2}" width="6" height="6" fill="{}"/>"#,
                        px(x) - 3.0,
                        py(y) - 3.0,
                        se.color
                    );
                }
            }
            Kind::Circles(pts) => {
                for &(x, y) in pts.iter().filter(|p| inside(p)) {
                    let _ = writeln!(
                        s,
                        r#"<circle cx="{:.2}" cy="{:.2}" r="3.5" fill="none" stroke="{}"/>"#,
                        px(x),
                        py(y),
                        se.color
                    );
                }
            }
        }
        // Legend entry.
        let (lx, ly) = (ml + 15.0, mt + 18.0 + 18.0 * k as f64);
        let mark = match se.kind {
            Kind::Line(_) => format!(
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="2"/>"#,
                lx + 22.0,
                se.color
            ),
            Kind::Dots(_) => format!(
                r#"<rect x="{}" y="{}" width="6" height="6" fill="{}"/>"#,
                lx + 8.0,
                ly - 3.0,
                se.color
            ),
            Kind::Circles(_) => {
                format!(r#"<circle cx="{}" cy="{ly}" r="3.5" fill="none" stroke="{}"/>"#, lx + 11.0, se.color)
            }
        };
        let _ = writeln!(s, r#"{mark}<text x="{}" y="{}">{}</text>"#, lx + 30.0, ly + 4.0, se.label);
    }
    s.push_str("</svg>\n");
    s
}
