//! The pressure projection (2.36)-(2.38): `div(grad psi / rho) = div v* / dt`,
//! `v^{n+1} = v* - dt grad psi / rho`, `p^{n+1} = p^n + psi`.
//!
//! Uniform density: one direct [`SpectralSolver`] solve, exact to round-off. Variable density:
//! PCG on `-div(grad psi / rho)`, preconditioned by the direct solve with a reference density.

use super::krylov::{KrylovInfo, KrylovParams, KrylovWorkspace, LinOp, Precond, pcg};
use super::momentum::{Coefficient, face_density};
use super::spectral::{Location, SpectralSolver};
use crate::grid::ops::{divergence_at_cell, gradient_at_face, par_interior};
use crate::grid::{Field, Grid, VectorField};
use crate::{Real, Result};

/// Solver state of the projection step, allocated once.
pub struct Projection<T: Real> {
    direct: SpectralSolver<T>,
    rhs: Field<T>,
    pcg: Option<KrylovWorkspace<Field<T>>>,
    params: KrylovParams,
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
    /// Builds the direct solver. Errors as [`SpectralSolver::new`].
    pub fn new(grid: &Grid<T>, params: KrylovParams) -> Result<Self> {
        Ok(Projection {
            direct: SpectralSolver::new(grid, Location::CellNeumann)?,
            rhs: Field::zeros(grid),
            pcg: None,
            params,
        })
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
        let mean = self.rhs.interior_sum(grid) / T::from_usize(grid.cell_count()).unwrap();
        let rhs = &mut self.rhs;
        crate::grid::ops::par_interior_update(grid, &mut rhs.data, |_, _, _, _, b| b - mean);
        let info = match rho {
            Coefficient::Uniform(r) => {
                let r = *r;
                crate::grid::ops::par_interior_update(grid, &mut rhs.data, |_, _, _, _, b| b * r);
                self.direct.solve(grid, T::zero(), T::one(), &rhs.data, &mut psi.data);
                KrylovInfo::default()
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
                pcg(grid, &op, &mut pc, &self.rhs, psi, ws, self.params)?
            }
        };
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
