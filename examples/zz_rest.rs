// Scratch (not committed): sphere at rest with bending, variants.
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::NormalScheme;
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::simulation::{Phase, Scene, Settings};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let cells_per_radius: f64 = a[1].parse().unwrap();
    let steps: usize = a[2].parse().unwrap();
    let h = 0.1 / cells_per_radius;
    let n = (3.125 * cells_per_radius).round() as usize;
    let l = n as f64 * h;
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let grid = Grid::new([n; 3], [0.0; 3], [l; 3], bc).unwrap();
    let mut set = Settings::<f64>::default();
    for kv in &a[3..] {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        match k {
            "eps" => set.epsilon = v.parse().unwrap(),
            "beta" => set.advection.beta = v.parse().unwrap(),
            "sbeta" => set.smoothing.beta = v.parse().unwrap(),
            "energy" => set.bending_form = eulermembrane::membrane::BendingForm::EnergyGradient,
            "normals" => {
                set.normals = match v {
                    "youngs" => NormalScheme::Youngs,
                    "central" => NormalScheme::CentralPhi,
                    "atanh2" => NormalScheme::Atanh2,
                    _ => NormalScheme::Atanh4,
                }
            }
            "advnormals" => {
                set.advection.normals = match v {
                    "youngs" => NormalScheme::Youngs,
                    "atanh2" => NormalScheme::Atanh2,
                    _ => NormalScheme::Atanh4,
                }
            }
            _ => panic!("{k}"),
        }
    }
    let mut sim = Scene::new(grid, Phase::new(1.0, 0.15).unwrap())
        .capsule(Sphere::new([l / 2.0; 3], 0.1).unwrap())
        .bending(5e-5)
        .settings(set)
        .build()
        .unwrap();
    let vmax = |sim: &eulermembrane::simulation::Simulation<f64>| {
        sim.velocity().c.iter().flat_map(|f| f.data.iter()).fold(0.0f64, |m, x| m.max(x.abs()))
    };
    let mut line = String::new();
    for s in 1..=steps {
        if let Err(e) = sim.step(4e-4) {
            line += &format!(" failed {e}");
            break;
        }
        if s % 10 == 0 {
            line += &format!(" {:.2e}", vmax(&sim));
        }
    }
    println!("R/h={cells_per_radius} n={n} {:?}:{line}", &a[3..]);
}
