//! Sec. 3.1 of the paper: MTHINC advection of `phi` and of the convolved reference curvature
//! `kappa_R tilde` in a time-reversing single-vortex flow (Table 1, Figs. 3-4).
//!
//! An ellipse `(x-0.5)^2/a^2 + (y-0.75)^2/b^2 = 1`, `a = 0.15` (along x), `b = 0.7 a`, in the
//! periodic unit square is advected by the stream function
//! `Psi = (1/pi) sin^2(pi x) S(pi y) cos(pi t / T)`, `T = 1`, with `S = cos^2` as printed in the
//! paper (`--stream cos`, default) or the classic `S = sin^2` (`--stream sin`). Face velocities
//! are differences of `Psi` at cell nodes, so the discrete divergence vanishes to round-off. The
//! time step is the largest with `max CFL <= 0.25` that divides `T`. At `t = T` the exact
//! solution is the initial field; errors (3.1) of `phi` and of `kappa_R delta_bar =
//! kappa_R tilde * dx` are printed with their orders next to the paper's Table 1.
//!
//! Flags: `--n N` (one resolution; default: 32, 64, 128, 256), `--stream cos|sin`,
//! `--normals youngs|central_phi|atanh2|atanh4` (default youngs, the paper's),
//! `--quadrature exact|gauss2`, `--beta B`, `--cfl C`, `--tiny E` (uniform-cell threshold), `--out DIR` (default
//! `out/single_vortex`; SVG contour plots of Fig. 3 and curvature profiles of Fig. 4),
//! `--no-plots`. The run itself is `cases/src/vortex.rs`.
//!
//! Run: `cargo run --release --example single_vortex -- --n 128`.

use eulermembrane_cases as common;

use common::Args;
use common::vortex::{self, Snap, VortexCase};
use eulermembrane::grid::{Field, Grid};
use eulermembrane::interface::{geometry::NormalScheme, mthinc::CellQuadrature};
use eulermembrane_cases::plot::{Figure, LineStyle, Panels, contour_segments};
use std::fmt::Write as _;

/// The paper's Table 1: (N, L1, L2, Linf) of phi and of kappa_R delta_bar.
const PAPER_PHI: [(usize, f64, f64, f64); 4] = [
    (32, 2.67e-3, 9.82e-3, 1.02e-1),
    (64, 1.01e-3, 5.15e-3, 7.54e-2),
    (128, 4.35e-4, 3.20e-3, 6.10e-2),
    (256, 2.03e-4, 2.13e-3, 5.96e-2),
];
const PAPER_KAPPA: [(usize, f64, f64, f64); 4] = [
    (32, 5.66e-2, 2.12e-1, 2.01),
    (64, 2.03e-2, 1.09e-1, 1.56),
    (128, 6.80e-3, 5.22e-2, 1.05),
    (256, 2.39e-3, 2.49e-2, 6.88e-1),
];

struct Opts {
    ns: Vec<usize>,
    sin: bool,
    normals: NormalScheme,
    quadrature: CellQuadrature,
    beta: f64,
    cfl: f64,
    tiny: f64,
    out: std::path::PathBuf,
    plots: bool,
}

fn parse(args: &Args) -> Result<Opts, String> {
    let n: Option<usize> = args.opt("n");
    if n.is_some_and(|n| n < 8) {
        return Err(format!("--n {}: at least 8", n.unwrap_or(0)));
    }
    let sin = match args.get("stream", "cos".to_string()).as_str() {
        "sin" => true,
        "cos" => false,
        s => return Err(format!("--stream {s}: cos or sin")),
    };
    let quadrature = match args.get("quadrature", "gauss2".to_string()).as_str() {
        "exact" => CellQuadrature::ExactAlongNormal,
        "gauss2" => CellQuadrature::Gauss2,
        s => return Err(format!("--quadrature {s}: exact or gauss2")),
    };
    let cfl = args.get("cfl", 0.25);
    if !(cfl > 0.0 && cfl <= 1.0) {
        return Err(format!("--cfl {cfl}: in (0, 1]"));
    }
    Ok(Opts {
        ns: n.map_or_else(|| vec![32, 64, 128, 256], |n| vec![n]),
        sin,
        normals: NormalScheme::from_name(&args.get("normals", "youngs".to_string()))
            .map_err(|e| e.to_string())?,
        quadrature,
        beta: args.get("beta", 1.0),
        cfl,
        tiny: args.get("tiny", eulermembrane::interface::advect::AdvectionParams::<f64>::default().tiny),
        out: args.out_dir("single_vortex"),
        plots: !args.flag("no-plots"),
    })
}

struct Run {
    n: usize,
    phi: [f64; 3],
    kappa: [f64; 3],
    drift: f64,
    min: f64,
    max: f64,
}

fn run(n: usize, o: &Opts) -> Result<Run, Box<dyn std::error::Error>> {
    let case = VortexCase {
        n,
        sin: o.sin,
        normals: o.normals,
        quadrature: o.quadrature,
        beta: o.beta,
        cfl: o.cfl,
        tiny: Some(o.tiny),
    };
    let r = vortex::run::<f64>(&case, o.plots, false)?;
    if o.plots {
        plots(&r.grid, &r.snaps, o, n)?;
    }
    Ok(Run { n, phi: r.phi, kappa: r.kappa, drift: r.drift, min: r.min, max: r.max })
}

fn main() {
    let o = match parse(&Args::parse(include_str!("single_vortex.rs"))) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let mut runs = Vec::new();
    for &n in &o.ns {
        match run(n, &o) {
            Ok(r) => {
                println!(
                    "RESULT n={} l1_phi={:.3e} l2_phi={:.3e} linf_phi={:.3e} l1_kappa={:.3e} \
                     l2_kappa={:.3e} linf_kappa={:.3e} mass_drift={:.2e} phi_min={:.3e} \
                     phi_max={:.12}",
                    r.n,
                    r.phi[0],
                    r.phi[1],
                    r.phi[2],
                    r.kappa[0],
                    r.kappa[1],
                    r.kappa[2],
                    r.drift,
                    r.min,
                    r.max
                );
                runs.push(r);
            }
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
        }
    }
    print_table(&runs, &o);
}

fn print_table(runs: &[Run], o: &Opts) {
    println!(
        "\nSingle vortex, stream {}, normals {}, after one period (paper's Table 1 in brackets)",
        if o.sin { "sin^2" } else { "cos^2" },
        o.normals.name()
    );
    for (name, pick, paper) in [("phi", 0usize, &PAPER_PHI), ("kappa_R delta_bar", 1, &PAPER_KAPPA)] {
        println!("{name}");
        println!(
            "{:>5} {:>22} {:>6} {:>22} {:>6} {:>22} {:>6}",
            "N", "L1 (paper)", "order", "L2 (paper)", "order", "Linf (paper)", "order"
        );
        for (k, r) in runs.iter().enumerate() {
            let e = if pick == 0 { r.phi } else { r.kappa };
            let p = paper.iter().find(|p| p.0 == r.n);
            let mut line = format!("{:>5}", r.n);
            for c in 0..3 {
                let pv = p.map(|p| [p.1, p.2, p.3][c]);
                let cell = match pv {
                    Some(pv) => format!("{:.2e} ({:.2e})", e[c], pv),
                    None => format!("{:.2e}", e[c]),
                };
                let ord = if k > 0 && runs[k - 1].n * 2 == r.n {
                    let pe = if pick == 0 { runs[k - 1].phi } else { runs[k - 1].kappa };
                    format!("{:.2}", (pe[c] / e[c]).log2())
                } else {
                    "-".into()
                };
                let _ = write!(line, " {cell:>22} {ord:>6}");
            }
            println!("{line}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Plots (Figs. 3 and 4) with `eulermembrane_cases::plot`.

/// Contour segments of a cell-centred 2D field at `level` (marching squares on cell centres).
fn contour(g: &Grid<f64>, f: &Field<f64>, level: f64) -> Vec<[(f64, f64); 2]> {
    let [nx, ny, _] = g.n();
    let h = g.h();
    let values: Vec<f64> = g.cells().map(|(i, j, k)| f.values()[g.idx_u(i, j, k)]).collect();
    contour_segments(nx, ny, 0.5 * h[0], 0.5 * h[1], h[0], h[1], &values, level)
}

fn plots(g: &Grid<f64>, snaps: &[Snap<f64>], o: &Opts, n: usize) -> eulermembrane::Result<()> {
    let dir = o.out.as_path();
    // Fig. 3: contours phi = 0.05, 0.5, 0.95 at t = 0, T/2, T.
    let mut panels = Panels::new(3);
    for (t, phi, _) in snaps {
        let mut fig = Figure::new(format!("N = {n}, t = {t:.2}"))
            .size(360.0, 380.0)
            .x_range(0.0, 1.0)
            .y_range(0.0, 1.0)
            .equal_aspect(true)
            .x_label("x")
            .y_label("y");
        let styles = [(0.05, LineStyle::Dotted), (0.5, LineStyle::Solid), (0.95, LineStyle::Dashed)];
        for (level, style) in styles {
            fig.segments(contour(g, phi, level), &format!("phi = {level}")).style(style);
        }
        panels.push(fig);
    }
    panels.save(dir.join(format!("contours_n{n}.svg")))?;

    // Fig. 4: kappa_R delta_bar across the band: its peak in each 5-degree sector of polar angle
    // about the initial centre (the band's maximum, which numerical diffusion would lower).
    let h = g.h()[0];
    let sample = |phi: &Field<f64>, kt: &Field<f64>| -> (Vec<f64>, Vec<f64>) {
        let bins = 72;
        let mut peak = vec![0.0f64; bins];
        for (i, j, k) in g.cells() {
            let id = g.idx_u(i, j, k);
            if !(phi.values()[id] > 0.02 && phi.values()[id] < 0.98) {
                continue;
            }
            let x = g.cell_center(i as isize, j as isize, k as isize);
            let th = (x[1] - 0.75).atan2(x[0] - 0.5).to_degrees();
            let b = (((th + 180.0) / 360.0 * bins as f64) as usize).min(bins - 1);
            peak[b] = peak[b].max(kt.values()[id] * h);
        }
        ((0..bins).map(|b| -180.0 + (b as f64 + 0.5) * 360.0 / bins as f64).collect(), peak)
    };
    let mut fig = Figure::new(format!("peak of kappa_R delta_bar per 5-degree sector, N = {n}"))
        .x_label("polar angle about (0.5, 0.75) (deg)")
        .y_label("kappa_R delta_bar")
        .x_range(-180.0, 180.0);
    let (first, last) = (&snaps[0], &snaps[snaps.len() - 1]);
    let (x0, y0) = sample(&first.1, &first.2);
    fig.line(&x0, &y0, "t = 0 (exact)");
    let (x1, y1) = sample(&last.1, &last.2);
    fig.line(&x1, &y1, "t = T").style(LineStyle::Dashed);
    fig.save(dir.join(format!("kappa_profile_n{n}.svg")))
}
