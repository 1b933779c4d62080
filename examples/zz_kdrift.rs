// Scratch: drift of the carried reference curvature kappa~_R / delta in shear with bending.
mod common;
use common::shear::{ShearCase, build};
use eulermembrane::simulation::Settings;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a[1].parse().unwrap();
    let dt: f64 = a[2].parse().unwrap();
    let t_end: f64 = a[3].parse().unwrap();
    let case = ShearCase { n, ca: 0.05, eb_prime: 0.0375, lambda: 1.0, dt, t_end };
    let mut sim = build::<f64>(&case, Settings::default()).unwrap();
    let steps = (t_end / dt).round() as usize;
    let every = (0.1 / dt).round() as usize;
    for s in 0..=steps {
        if s % every == 0 {
            let k = sim.kappa_r_tilde(0).unwrap().unwrap();
            let d = sim.delta(0).unwrap();
            let (mut sk, mut sd, mut sk2) = (0.0, 0.0, 0.0);
            for (x, y) in k.data.iter().zip(&d.data) {
                if *y * (8.0 / n as f64) > 0.01 {
                    sk += x;
                    sd += y;
                    sk2 += x * x / y;
                }
            }
            let mean = sk / sd;
            println!(
                "t={:.2} mean_kappa_R={:.4} rms={:.4}",
                s as f64 * dt,
                mean,
                (sk2 / sd - mean * mean).max(0.0).sqrt()
            );
        }
        if s < steps {
            sim.step(dt).unwrap();
        }
    }
}
