// Scratch (not committed): the red cell at rest / in flow with bending, variants.
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Biconcave;
use eulermembrane::membrane::Skalak;
use eulermembrane::simulation::{Phase, Scene, Settings};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a[1].parse().unwrap();
    let steps: usize = a[2].parse().unwrap();
    let dt: f64 = a[3].parse().unwrap();
    let (mut es, mut alpha, mut force, mut eb, mut every) = (0.0, 40.0, 0.0, 5e-5, 10usize);
    for kv in &a[4..] {
        let (k, v) = kv.split_once('=').unwrap();
        match k {
            "es" => es = v.parse().unwrap(),
            "alpha" => alpha = v.parse().unwrap(),
            "force" => force = v.parse().unwrap(),
            "eb" => eb = v.parse().unwrap(),
            "every" => every = v.parse().unwrap(),
            _ => panic!("{k}"),
        }
    }
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let grid = Grid::new([n; 3], [0.0; 3], [0.5; 3], bc).unwrap();
    let mut s = Scene::new(grid, Phase::new(1.0, 0.05).unwrap())
        .inside(Phase::new(1.0, 0.25).unwrap())
        .capsule(Biconcave::new([0.25; 3], 0.17).unwrap())
        .bending(eb)
        .settings(Settings::default());
    if es > 0.0 {
        s = s.elasticity(Skalak::new(es, alpha).unwrap());
    }
    if force > 0.0 {
        s = s.body_force([force, 0.0, 0.0]);
    }
    let mut sim = s.build().unwrap();
    let vmax = |sim: &eulermembrane::simulation::Simulation<f64>| {
        sim.velocity().c.iter().flat_map(|f| f.data.iter()).fold(0.0f64, |m, x| m.max(x.abs()))
    };
    let a0 = sim.area(0).unwrap();
    let mut line = String::new();
    for s in 1..=steps {
        if let Err(e) = sim.step(dt) {
            line += &format!(" failed {e}");
            break;
        }
        if s % every == 0 {
            line += &format!(" {:.2e}/{:.3}", vmax(&sim), sim.area(0).unwrap() / a0);
        }
    }
    println!("n={n} dt={dt} {:?}:{line}", &a[4..]);
}
