//! The scene of the capsule-cost measurement (`examples/capsule_cost.rs`, `benches/capsule_cost.rs`):
//! `K` identical neo-Hookean spheres in a periodic cube, in a periodic shear wave.

use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::placement::{Domain, Placement, Prototype, Target};
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{Elasticity, Phase, Scene, Settings, Simulation, Traction};

/// The capillary number `mu a U / (E_s L)`-like scale of the membrane: `E_s = mu a / CA` with
/// `a = 1`, `mu = 1` and the wave's amplitude 1.
pub const CA: f64 = 0.05;

/// The step `0.3 h`: a Courant number of 0.3 at the wave's amplitude.
pub fn step(cells_per_radius: f64) -> f64 {
    0.3 / cells_per_radius
}

/// A periodic cube of `n` cells at `cells_per_radius` cells per radius (radius 1, so `n /
/// cells_per_radius` radii wide), `rho = mu = 1`, with `k` spheres placed at random (seed 1, at
/// least two cells apart), the neo-Hookean membrane `E_s = 1 / CA` with the traction
/// `traction`, and the velocity `u_x = sin(2 pi z / L)`.
///
/// # Errors
/// A grid, placement (e.g. too many capsules for the box) or scene that cannot be built.
pub fn periodic_capsules(
    n: usize,
    k: usize,
    cells_per_radius: f64,
    settings: Settings<f64>,
    traction: Traction,
) -> Result<Simulation<f64>, Box<dyn std::error::Error>> {
    let half = 0.5 * n as f64 / cells_per_radius;
    let grid = Grid::new([n; 3], [-half; 3], [half; 3], [[Boundary::Periodic; 2]; 3])?;
    let mut scene = Scene::new(grid.clone(), Phase::new(1.0, 1.0)?).settings(settings);
    if k > 0 {
        let placed = Placement::new(Domain::from_grid(&grid), Prototype::sphere(1.0)?, Target::Count(k))
            .gap(2.0 / cells_per_radius)
            .seed(1)
            .place()
            .map_err(|e| format!("placing {k} capsules in {n}^3 cells: {e}"))?;
        for shape in placed.shapes()? {
            scene = scene.capsule(shape);
        }
        scene = scene.effect(Elasticity::new(NeoHookean::new(1.0 / CA)?).traction(traction));
    }
    let mut sim = scene.build()?;
    let l = 2.0 * half;
    sim.set_velocity(|x| [(2.0 * std::f64::consts::PI * x[2] / l).sin(), 0.0, 0.0])?;
    Ok(sim)
}
