//! Plane Poiseuille flow (body force between walls at rest) and Couette flow (moving top wall),
//! each started from rest: the steady profiles against the exact parabola and line at N = 16,
//! 32, 64, and the start-up transient against its series solution.
//!
//! Flags: `--out DIR` (`out/channel_flow`).
//!
//! `cargo run --release --example channel_flow`
use eulermembrane_cases as common;
use eulermembrane_cases::flows;

fn main() {
    let args = common::Args::parse(include_str!("channel_flow.rs"));
    let out = args.out_dir("channel_flow");
    let (mu, f, u_top) = (1.0, 1.0, 1.0);
    // Steady state: exp(-pi^2 mu t) at t = 4 is 1e-17. Crank-Nicolson barely damps the
    // highest modes when mu dt / h^2 is large, so dt follows h^2 (mu dt / h^2 = 2).
    let t_end = 4.0;
    println!("{:>4} {:>14} {:>14}", "N", "poiseuille", "couette");
    let ns = [16usize, 32, 64];
    let mut pe = Vec::new();
    let mut ce = Vec::new();
    for &n in &ns {
        let dt = 2.0 / (mu * (n * n) as f64);
        let p = flows::poiseuille(n, mu, f, dt, t_end);
        let c = flows::couette(n, mu, u_top, dt, t_end);
        pe.push(flows::rel_max_err(&p, |y| flows::poiseuille_exact(y, f64::INFINITY, mu, f)));
        ce.push(flows::rel_max_err(&c, |y| flows::couette_exact(y, f64::INFINITY, mu, u_top)));
        println!("{n:>4} {:>14.4e} {:>14.4e}", pe.last().unwrap(), ce.last().unwrap());
    }
    let order = common::order(pe[1], pe[2], 32.0, 64.0);
    // Start-up transient at t = 0.05 (about a third of the way to steady), small dt so that the
    // time error is below the space error.
    let (n, t) = (32, 0.05);
    let tp = flows::poiseuille(n, mu, f, 1e-4, t);
    let tc = flows::couette(n, mu, u_top, 1e-4, t);
    let ep = flows::rel_max_err(&tp, |y| flows::poiseuille_exact(y, t, mu, f));
    let ec = flows::rel_max_err(&tc, |y| flows::couette_exact(y, t, mu, u_top));
    println!("transient at t = {t}, N = {n}: poiseuille {ep:.3e}, couette {ec:.3e}");
    let mut csv = String::from("y,u_poiseuille,u_poiseuille_exact,u_couette,u_couette_exact\n");
    for (a, b) in tp.iter().zip(&tc) {
        csv += &format!(
            "{},{},{},{},{}\n",
            a.0,
            a.1,
            flows::poiseuille_exact(a.0, t, mu, f),
            b.1,
            flows::couette_exact(b.0, t, mu, u_top)
        );
    }
    std::fs::write(out.join("transient_t0.05.csv"), csv).expect("write csv");
    common::result(&[
        ("poiseuille_rel_err", common::num(pe[1])),
        ("couette_rel_err", common::num(ce[1])),
        ("order", format!("{order:.3}")),
        ("transient_rel_err", common::num(ep.max(ec))),
    ]);
}
