//! What the decomposition tests share (`tests/decomposition.rs` on threads, `tests/mpi.rs` on
//! MPI ranks): fields whose every value differs, the comparison of a part with the whole grid,
//! and the grids and splits checked.

#![allow(dead_code)] // each test file uses its own share

use eulermembrane::fluid::spectral::{Location, SpectralSolver};
use eulermembrane::grid::{Boundary, Decomposition, Field, GHOST, Grid, SymField, VectorField};

/// A value that differs at every cell and component, so that a misplaced ghost shows.
pub fn value(c: usize, [i, j, k]: [usize; 3]) -> f64 {
    let x = (i * 7919 + j * 104_729 + k * 1_299_709 + c * 15_485_863) as f64;
    (x * 0.618_033_988_749_895).fract() - 0.5
}

/// A field of `grid` holding `value` at its interior cells (global index = local + `offset`)
/// and NaN in its ghosts.
pub fn field(grid: &Grid<f64>, c: usize) -> Field<f64> {
    let mut f = Field::zeros(grid);
    f.fill(f64::NAN);
    let o = grid.offset();
    for (i, j, k) in grid.cells() {
        let at = grid.idx_u(i, j, k);
        f.values_mut()[at] = value(c, [i + o[0], j + o[1], k + o[2]]);
    }
    f
}

/// Whether every stored value of `part` equals `whole` at the same global cell.
pub fn same_as_whole(
    part_grid: &Grid<f64>,
    part: &Field<f64>,
    whole_grid: &Grid<f64>,
    whole: &Field<f64>,
) -> Result<(), String> {
    let g = GHOST as isize;
    let [nx, ny, nz] = part_grid.n().map(|n| n as isize);
    let o = part_grid.offset().map(|x| x as isize);
    for k in -g..nz + g {
        for j in -g..ny + g {
            for i in -g..nx + g {
                let (a, b) =
                    (part.at(part_grid, i, j, k), whole.at(whole_grid, i + o[0], j + o[1], k + o[2]));
                if a.to_bits() != b.to_bits() {
                    return Err(format!("cell ({i}, {j}, {k}) of the part at {o:?}: {a} against {b}"));
                }
            }
        }
    }
    Ok(())
}

/// Grids with walls (moving) on `wall`, periodic elsewhere.
pub fn grid(wall: Option<usize>) -> Grid<f64> {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    if let Some(w) = wall {
        let mut u = [0.5, -1.5, 2.0];
        u[w] = 0.0;
        bc[w] = [Boundary::wall(), Boundary::Wall { velocity: u }];
    }
    Grid::new([17, 16, 18], [0.0, -1.0, 0.5], [1.3, 0.2, 2.0], bc).unwrap()
}

/// Every periodic axis of every grid, split into each of `parts`.
pub fn cases(parts: &[usize]) -> Vec<(Grid<f64>, Decomposition)> {
    let mut out = Vec::new();
    for wall in [None, Some(0), Some(1), Some(2)] {
        for axis in (0..3).filter(|&a| Some(a) != wall) {
            for &p in parts {
                out.push((grid(wall), Decomposition::slabs(axis, p).unwrap()));
            }
        }
    }
    out
}

/// The whole grid's fields after a fill: a scalar, a velocity (and its homogeneous fill) and a
/// tensor, components numbered as [`check_part`] numbers them.
pub struct Whole {
    scalar: Field<f64>,
    v: VectorField<f64>,
    v0: VectorField<f64>,
    t: SymField<f64>,
}

impl Whole {
    pub fn new(whole: &Grid<f64>) -> Self {
        let mut scalar = field(whole, 0);
        scalar.fill_ghosts(whole);
        let mut v = VectorField { c: [field(whole, 1), field(whole, 2), field(whole, 3)] };
        let mut v0 = v.clone();
        v.fill_ghosts(whole);
        v0.fill_ghosts_homogeneous(whole);
        let mut t = SymField { c: std::array::from_fn(|c| field(whole, 4 + c)) };
        t.fill_ghosts(whole);
        Whole { scalar, v, v0, t }
    }
}

/// Fills the same fields on `part` and compares every stored value with the whole grid's.
pub fn check_part(part: &Grid<f64>, whole_grid: &Grid<f64>, whole: &Whole) -> Result<(), String> {
    let mut f = field(part, 0);
    f.fill_ghosts(part);
    same_as_whole(part, &f, whole_grid, &whole.scalar)?;
    let mut pv = VectorField { c: [field(part, 1), field(part, 2), field(part, 3)] };
    let mut pv0 = pv.clone();
    pv.fill_ghosts(part);
    pv0.fill_ghosts_homogeneous(part);
    for c in 0..3 {
        same_as_whole(part, &pv.c[c], whole_grid, &whole.v.c[c])?;
        same_as_whole(part, &pv0.c[c], whole_grid, &whole.v0.c[c])?;
    }
    let mut pt = SymField { c: std::array::from_fn(|c| field(part, 4 + c)) };
    pt.fill_ghosts(part);
    for c in 0..6 {
        same_as_whole(part, &pt.c[c], whole_grid, &whole.t.c[c])?;
    }
    Ok(())
}

/// The largest difference between `part`'s interior values and the whole grid's at its cells.
pub fn max_difference(part_grid: &Grid<f64>, part: &[f64], whole_grid: &Grid<f64>, whole: &[f64]) -> f64 {
    let o = part_grid.offset();
    part_grid
        .cells()
        .map(|(i, j, k)| {
            (part[part_grid.idx_u(i, j, k)] - whole[whole_grid.idx_u(i + o[0], j + o[1], k + o[2])]).abs()
        })
        .fold(0.0, f64::max)
}

/// Runs `steps` flow steps on `g` (a whole grid or a part) from a sheared, perturbed start,
/// with a viscosity and a density that vary in space; returns the velocity and the pressure.
pub fn flow_on(g: &Grid<f64>, steps: usize) -> Result<(VectorField<f64>, Field<f64>), String> {
    use eulermembrane::fluid::forcing::BodyForce;
    use eulermembrane::fluid::momentum::{Coefficient, Materials};
    use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper};
    use std::f64::consts::TAU;
    let blob =
        |x: [f64; 3]| (-((x[0] - 0.6).powi(2) + (x[1] + 0.4).powi(2) + (x[2] - 1.2).powi(2)) * 8.0).exp();
    let mut mu = Field::from_cell_fn(g, |x| 0.05 + 0.2 * blob(x));
    let mut rho = Field::from_cell_fn(g, |x| 1.0 + 0.5 * blob(x));
    mu.fill_ghosts(g);
    rho.fill_ghosts(g);
    let materials = Materials { rho: Coefficient::Field(rho), mu: Coefficient::Field(mu) };
    let mut s = FlowStepper::new(g, materials, FlowConfig::default()).map_err(|e| e.to_string())?;
    s.set_velocity(|x| {
        let (a, b, c) = ((TAU * x[0] / 1.3).sin(), (TAU * x[1] / 1.2).cos(), (TAU * x[2] / 1.5).sin());
        [0.3 * b * c, 0.2 * a * c, 0.1 * a * b]
    })
    .map_err(|e| e.to_string())?;
    let force = BodyForce::new([0.5, -0.2, 0.1]).map_err(|e| e.to_string())?;
    for _ in 0..steps {
        s.step(2e-3, &force, None).map_err(|e| e.to_string())?;
    }
    Ok((s.velocity().clone(), s.pressure().clone()))
}

/// Every kind of unknown of the direct solver.
pub const LOCATIONS: [Location; 4] =
    [Location::CellNeumann, Location::Velocity(0), Location::Velocity(1), Location::Velocity(2)];

/// The direct solver's four solves on `g` (a whole grid or a part) for unknowns at `location`:
/// `solve` (singular where the operator is), `solve_pair`, `solve_blended`, `solve_pair_blended`,
/// the right-hand sides and weights made by [`field`].
pub fn four_solves(g: &Grid<f64>, location: Location) -> Result<[Vec<f64>; 6], String> {
    let mut s = SpectralSolver::new(g, location).map_err(|e| e.to_string())?;
    let (b, b2) = (field(g, 0), field(g, 1));
    let weight = |c| {
        let mut w = field(g, c);
        w.values_mut().iter_mut().for_each(|x| *x += 0.5);
        w
    };
    let (w1, w2) = (weight(2), weight(3));
    let (b, b2, w1, w2) = (b.values(), b2.values(), w1.values(), w2.values());
    let (sigma, c) = (3.0, 0.7);
    let mut x = [(); 6].map(|_| vec![0.0; g.len()]);
    let [x0, x1, x2, x3, x4, x5] = &mut x;
    s.solve(g, 0.0, c, b, x0);
    s.solve_pair(g, sigma, c, [b, b2], [x1, x2]);
    s.solve_blended(g, sigma, [c, 2.0 * c], w1, b, x3);
    s.solve_pair_blended(g, sigma, [c, 2.0 * c], [w1, w2], [b, b2], [x4, x5]);
    Ok(x)
}
