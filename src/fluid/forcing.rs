//! Explicit forces added on the velocity faces (where the pressure gradient lives, so that force
//! and pressure balance exactly). A [`Forcing`] contributes a force density per unit volume;
//! `()` contributes nothing and costs nothing; tuples add their members.

use crate::grid::ops::par_interior_update;
use crate::grid::{Grid, VectorField};
use crate::{Real, Result};

/// An explicit force density on the faces of the staggered grid.
pub trait Forcing<T: Real>: Sync {
    /// Whether the force is present at all (`()` is not: nothing is evaluated).
    fn is_active(&self) -> bool {
        true
    }
    /// Adds the force density at time `time`, given the velocity `v` (ghosts filled), to the
    /// interior faces of `out`.
    ///
    /// # Errors
    /// Whatever keeps the force from being evaluated (a field of another grid, a value that
    /// cannot be computed); the step that asked for it then fails and leaves its state as it was.
    fn add(&self, grid: &Grid<T>, time: T, v: &VectorField<T>, out: &mut VectorField<T>) -> Result<()>;
}

impl<T: Real> Forcing<T> for () {
    fn is_active(&self) -> bool {
        false
    }
    fn add(&self, _: &Grid<T>, _: T, _: &VectorField<T>, _: &mut VectorField<T>) -> Result<()> {
        Ok(())
    }
}

impl<T: Real, A: Forcing<T>, B: Forcing<T>> Forcing<T> for (A, B) {
    fn is_active(&self) -> bool {
        self.0.is_active() || self.1.is_active()
    }
    fn add(&self, grid: &Grid<T>, time: T, v: &VectorField<T>, out: &mut VectorField<T>) -> Result<()> {
        if self.0.is_active() {
            self.0.add(grid, time, v, out)?;
        }
        if self.1.is_active() {
            self.1.add(grid, time, v, out)?;
        }
        Ok(())
    }
}

/// A uniform body force density `f` (force per unit volume), e.g. a driving pressure gradient
/// `-dP/dx` along x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyForce<T> {
    f: [T; 3],
}

impl<T: Real> BodyForce<T> {
    /// A uniform force density. Errors: a non-finite component.
    pub fn new(f: [T; 3]) -> Result<Self> {
        for (d, name) in ["f[0]", "f[1]", "f[2]"].into_iter().enumerate() {
            crate::error::finite(name, f[d])?;
        }
        Ok(BodyForce { f })
    }

    /// The force density.
    pub fn density(&self) -> [T; 3] {
        self.f
    }
}

impl<T: Real> Forcing<T> for BodyForce<T> {
    fn is_active(&self) -> bool {
        self.f.iter().any(|&x| x != T::zero())
    }
    fn add(&self, grid: &Grid<T>, _: T, _: &VectorField<T>, out: &mut VectorField<T>) -> Result<()> {
        out.matches(grid, "force")?;
        for (d, comp) in out.c.iter_mut().enumerate() {
            if self.f[d] == T::zero() {
                continue;
            }
            let f = self.f[d];
            let wall = !grid.is_periodic(d);
            par_interior_update(
                grid,
                &mut comp.data,
                |_, i, j, k, old| {
                    if wall && [i, j, k][d] == 0 { old } else { old + f }
                },
            );
        }
        Ok(())
    }
}
