//! Steady Couette flow through a fixed plane interface with viscosity ratio 5: the smoothed
//! mixture viscosity (2.25) of a tanh VOF profile against the exact piecewise-linear profile of
//! the sharp interface, at N = 16, 32, 64.
//!
//! Flags: `--out DIR` (`out/two_layer_couette`).
//!
//! `cargo run --release --example two_layer_couette`
use eulermembrane_cases as common;
use eulermembrane_cases::flows;

fn main() {
    let args = common::Args::parse(include_str!("two_layer_couette.rs"));
    let out = args.out_dir("two_layer_couette");
    let (mu1, mu2, y_i) = (5.0, 1.0, 0.5 + 1.0 / 3.0 * 0.1);
    let ns = [16usize, 32, 64];
    let mut errs = Vec::new();
    println!("{:>4} {:>12} {:>7}", "N", "rel_err", "order");
    for (m, &n) in ns.iter().enumerate() {
        let prof = flows::two_layer_couette(n, mu1, mu2, y_i);
        let e = flows::rel_max_err(&prof, |y| flows::two_layer_exact(y, mu1, mu2, y_i));
        let ord = if m > 0 { common::order(errs[m - 1], e, ns[m - 1] as f64, n as f64) } else { f64::NAN };
        println!("{n:>4} {e:>12.4e} {ord:>7.3}");
        errs.push(e);
        let mut csv = String::from("y,u,u_exact\n");
        for (y, u) in &prof {
            csv += &format!("{y},{u},{}\n", flows::two_layer_exact(*y, mu1, mu2, y_i));
        }
        std::fs::write(out.join(format!("profile_n{n}.csv")), csv).expect("write csv");
    }
    let order = common::order(errs[1], errs[2], 32.0, 64.0);
    common::result(&[("rel_err", common::num(errs[1])), ("order", format!("{order:.3}"))]);
}
