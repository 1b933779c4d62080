//! The pressure projection (2.36)-(2.38): `div(grad psi / rho) = div v* / dt`,
//! `v^{n+1} = v* - dt grad psi / rho`, `p^{n+1} = p^n + psi`.
//!
//! The solve of (2.36) is a [`PressureSolver`]. The default, [`SpectralPcg`]: uniform density,
//! one direct [`SpectralSolver`] solve, exact to round-off; variable density, PCG on
//! `-div(grad psi / rho)`, preconditioned by the direct solve with a reference density.

use super::krylov::{KrylovInfo, KrylovParams, KrylovWorkspace, LinOp, Precond, pcg};
use super::momentum::{Coefficient, face_density};
use super::spectral::{Location, SpectralSolver};
use crate::grid::ops::{divergence_at_cell, gradient_at_face, par_interior};
use crate::grid::{Field, Grid, VectorField};
use crate::{Real, Result};

/// Solver state of the projection step, allocated once: the right-hand side of (2.36) and the
/// [`PressureSolver`] that solves it.
pub struct Projection<T: Real> {
    rhs: Field<T>,
    solver: Box<dyn PressureSolver<T>>,
}

/// The strategy that solves the pressure equation (2.36) `-div(grad psi / rho) = b`, once per
/// step.
///
/// [`FlowStepper::new`](super::stepper::FlowStepper::new) builds the default, [`SpectralPcg`], from
/// [`FlowConfig::poisson`](super::stepper::FlowConfig::poisson);
/// [`FlowStepper::with_pressure_solver`](super::stepper::FlowStepper::with_pressure_solver) and
/// [`Scene::pressure_solver`](crate::simulation::Scene::pressure_solver) take a user's. A solver
/// owns its workspace: the step calls it through one dynamic dispatch and it must not allocate.
///
/// A user solver that wraps the default one and counts its calls:
///
/// ```
/// use eulermembrane::fluid::forcing::BodyForce;
/// use eulermembrane::fluid::krylov::KrylovInfo;
/// use eulermembrane::fluid::momentum::{Coefficient, Materials};
/// use eulermembrane::fluid::projection::{PressureSolver, SpectralPcg};
/// use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper};
/// use eulermembrane::grid::{Field, Grid};
///
/// struct Counted(SpectralPcg<f64>, usize);
/// impl PressureSolver<f64> for Counted {
///     fn name(&self) -> &str {
///         "counted_spectral_pcg"
///     }
///     fn solve(
///         &mut self,
///         grid: &Grid<f64>,
///         rho: &Coefficient<f64>,
///         b: &mut Field<f64>,
///         psi: &mut Field<f64>,
///     ) -> eulermembrane::Result<KrylovInfo> {
///         self.1 += 1;
///         self.0.solve(grid, rho, b, psi)
///     }
/// }
///
/// let grid = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3])?;
/// let config = FlowConfig::default();
/// let solver = Counted(SpectralPcg::new(&grid, config.poisson)?, 0);
/// let mut flow = FlowStepper::new(&grid, Materials::uniform(1.0, 1.0)?, config)?
///     .with_pressure_solver(Box::new(solver));
/// flow.step(1e-2, &BodyForce::new([1.0, 0.0, 0.0])?, None)?;
/// assert_eq!(flow.pressure_solver().name(), "counted_spectral_pcg");
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub trait PressureSolver<T: Real>: Send + Sync {
    /// A short snake_case name, for [`Simulation::numerics`](crate::simulation::Simulation::numerics)
    /// and error messages.
    fn name(&self) -> &str;

    /// Solves `-div(grad psi / rho) = b` (2.36) at the interior cells, with zero normal flux
    /// on walls and the face densities `rho` averaged as [`Projection`] does. `b` has zero mean
    /// (the solution is defined up to a constant) and is the solver's to overwrite; `psi`
    /// holds the previous increment on entry. Returns the iterations (0 for a direct solve) and
    /// the final relative residual.
    ///
    /// # Errors
    /// A solve that does not converge; the step then fails and leaves the state as it was.
    fn solve(
        &mut self,
        grid: &Grid<T>,
        rho: &Coefficient<T>,
        b: &mut Field<T>,
        psi: &mut Field<T>,
    ) -> Result<KrylovInfo>;
}

/// The default [`PressureSolver`]: uniform density, one direct [`SpectralSolver`] solve (FFT on
/// the periodic axes, Thomas along the wall axis), exact to round-off; variable density, PCG
/// preconditioned by the direct solve with `rho_ref = sqrt(rho_min rho_max)`.
pub struct SpectralPcg<T: Real> {
    direct: SpectralSolver<T>,
    pcg: Option<KrylovWorkspace<Field<T>>>,
    params: KrylovParams,
}

impl<T: Real> SpectralPcg<T> {
    /// The solver for `grid` with the PCG stopping rule `params` (unused at uniform density).
    ///
    /// Errors: a tolerance outside `(0, 1)` or no iteration allowed (naming
    /// `FlowConfig::poisson`); a grid the direct solve cannot handle, as [`SpectralSolver::new`].
    pub fn new(grid: &Grid<T>, params: KrylovParams) -> Result<Self> {
        params.validate("FlowConfig::poisson")?;
        Ok(SpectralPcg { direct: SpectralSolver::new(grid, Location::CellNeumann)?, pcg: None, params })
    }
}

impl<T: Real> PressureSolver<T> for SpectralPcg<T> {
    fn name(&self) -> &str {
        "spectral_pcg"
    }

    fn solve(
        &mut self,
        grid: &Grid<T>,
        rho: &Coefficient<T>,
        b: &mut Field<T>,
        psi: &mut Field<T>,
    ) -> Result<KrylovInfo> {
        match rho {
            Coefficient::Uniform(r) => {
                let r = *r;
                crate::grid::ops::par_interior_update(grid, &mut b.data, |_, _, _, _, b| b * r);
                self.direct.solve(grid, T::zero(), T::one(), &b.data, &mut psi.data);
                Ok(KrylovInfo::default())
            }
            Coefficient::Field(_) => {
                let (lo, hi) = rho.range(grid);
                let ws = self.pcg.get_or_insert_with(|| KrylovWorkspace::new(grid));
                let op = VariableDensityOp { grid, rho };
                // Start from zero: psi is an increment, and a relative tolerance is then met
                // against the size of this step's divergence.
                psi.fill(T::zero());
                let mut pc = DirectPrecond {
                    grid,
                    solver: &mut self.direct,
                    inv_rho_ref: T::one() / (lo * hi).sqrt(),
                };
                pcg(grid, &op, &mut pc, b, psi, ws, self.params)
            }
        }
    }
}

struct VariableDensityOp<'a, T> {
    grid: &'a Grid<T>,
    rho: &'a Coefficient<T>,
}

impl<T: Real> LinOp<T, Field<T>> for VariableDensityOp<'_, T> {
    fn apply(&self, x: &mut Field<T>, y: &mut Field<T>) -> Result<()> {
        let g = self.grid;
        x.fill_ghosts(g);
        let st = g.strides();
        let h = g.h();
        par_interior(g, &mut y.data, |idx, i, j, k| {
            let ijk = [i, j, k];
            let n = g.n();
            let mut s = T::zero();
            for d in 0..3 {
                let wall = !g.is_periodic(d);
                let lo = if wall && ijk[d] == 0 {
                    T::zero()
                } else {
                    (x.data[idx] - x.data[idx - st[d]]) / (h[d] * face_density(g, self.rho, d, idx))
                };
                let up = idx + st[d];
                let hi = if wall && ijk[d] == n[d] - 1 {
                    T::zero()
                } else {
                    (x.data[up] - x.data[idx]) / (h[d] * face_density(g, self.rho, d, up))
                };
                s += (hi - lo) / h[d];
            }
            -s
        });
        Ok(())
    }
}

struct DirectPrecond<'a, T: Real> {
    grid: &'a Grid<T>,
    solver: &'a mut SpectralSolver<T>,
    inv_rho_ref: T,
}

impl<T: Real> Precond<T, Field<T>> for DirectPrecond<'_, T> {
    fn apply(&mut self, r: &Field<T>, z: &mut Field<T>) {
        self.solver.solve(self.grid, T::zero(), self.inv_rho_ref, &r.data, &mut z.data);
    }
}

impl<T: Real> Projection<T> {
    /// The projection with the default solver, [`SpectralPcg`]. Errors as [`SpectralPcg::new`].
    pub fn new(grid: &Grid<T>, params: KrylovParams) -> Result<Self> {
        Ok(Projection::with_solver(grid, Box::new(SpectralPcg::new(grid, params)?)))
    }

    /// The projection with the pressure solver `solver`.
    pub fn with_solver(grid: &Grid<T>, solver: Box<dyn PressureSolver<T>>) -> Self {
        Projection { rhs: Field::zeros(grid), solver }
    }

    /// The pressure solver.
    pub fn solver(&self) -> &dyn PressureSolver<T> {
        self.solver.as_ref()
    }

    /// Solves (2.36) for `psi` given `v*` (ghosts filled), then writes `v^{n+1}` (2.37) into
    /// `v_new`. Returns the PCG statistics (zero iterations for the direct solve).
    pub fn project(
        &mut self,
        grid: &Grid<T>,
        rho: &Coefficient<T>,
        dt: T,
        vstar: &VectorField<T>,
        psi: &mut Field<T>,
        v_new: &mut VectorField<T>,
    ) -> Result<KrylovInfo> {
        let inv_dt = T::one() / dt;
        // Right-hand side -div(v*)/dt of -div(grad psi / rho) = -div(v*)/dt, mean removed.
        par_interior(grid, &mut self.rhs.data, |idx, _, _, _| -divergence_at_cell(grid, vstar, idx) * inv_dt);
        let [sum, cells] =
            grid.sum_over_parts([self.rhs.interior_sum(grid), T::from_usize(grid.cell_count()).unwrap()]);
        let mean = sum / cells;
        let rhs = &mut self.rhs;
        crate::grid::ops::par_interior_update(grid, &mut rhs.data, |_, _, _, _, b| b - mean);
        let info = self.solver.solve(grid, rho, rhs, psi)?;
        psi.fill_ghosts(grid);
        for (d, out) in v_new.c.iter_mut().enumerate() {
            let wall = !grid.is_periodic(d);
            par_interior(grid, &mut out.data, |idx, i, j, k| {
                if wall && [i, j, k][d] == 0 {
                    T::zero()
                } else {
                    vstar.c[d].data[idx]
                        - dt * gradient_at_face(grid, psi, d, idx) / face_density(grid, rho, d, idx)
                }
            });
        }
        Ok(info)
    }
}
