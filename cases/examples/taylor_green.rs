//! Decaying 2D Taylor-Green vortex in a periodic box: the flow stepper against the exact
//! solution `u = sin x cos y e^{-2 nu t}`, `v = -cos x sin y e^{-2 nu t}` at N = 16, 32, 64.
//!
//! Flags: `--t-end T` (1), `--sor` (the paper's SOR for the predictor instead of BiCGStab),
//! `--out DIR` (`out/taylor_green`).
//!
//! `cargo run --release --example taylor_green [-- --t-end 1.0 --sor]`
use eulermembrane_cases as common;
use eulermembrane_cases::flows;

use eulermembrane::fluid::{sor::SorParams, stepper::PredictorSolver};

fn main() {
    let args = common::Args::parse(include_str!("taylor_green.rs"));
    let out = args.out_dir("taylor_green");
    let t_end: f64 = args.get("t-end", 1.0);
    let solver = if args.flag("sor") {
        PredictorSolver::Sor(SorParams::default())
    } else {
        PredictorSolver::default()
    };
    let ns = [16usize, 32, 64];
    let mut errs = Vec::new();
    println!("{:>5} {:>12} {:>12} {:>7}", "N", "L2(u)", "Linf(u)", "order");
    for (m, &n) in ns.iter().enumerate() {
        let t0 = std::time::Instant::now();
        let vti = out.join(format!("taylor_green_n{n}.vti"));
        let (l2, linf) = flows::taylor_green_snapshot(n, t_end, solver, Some(&vti));
        let ord = if m > 0 { common::order(errs[m - 1], l2, ns[m - 1] as f64, n as f64) } else { f64::NAN };
        errs.push(l2);
        println!("{n:>5} {l2:>12.4e} {linf:>12.4e} {ord:>7.3}   ({:.2} s)", t0.elapsed().as_secs_f64());
    }
    let order = common::order(errs[1], errs[2], 32.0, 64.0);
    common::result(&[("l2_u_n64", common::num(errs[2])), ("order_l2_u", format!("{order:.3}"))]);
}
