//! Boundary conditions on the six sides of the box.

use crate::Real;

/// The condition on one side of the domain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Boundary<T> {
    /// Periodic: must be set on both sides of an axis.
    Periodic,
    /// A no-slip, impermeable wall moving tangentially with `velocity` (its component normal to
    /// the wall must be zero). Scalars get a zero normal gradient there.
    Wall {
        /// Wall velocity (u, v, w).
        velocity: [T; 3],
    },
}

impl<T: Real> Boundary<T> {
    /// A wall at rest.
    pub fn wall() -> Self {
        Boundary::Wall { velocity: [T::zero(); 3] }
    }

    /// The sides of a box periodic on every axis but `wall`, which gets walls at rest on both
    /// sides (none: periodic everywhere). For the tests that run once per wall axis.
    #[cfg(test)]
    pub(crate) fn walls_on(wall: Option<usize>) -> [[Self; 2]; 3] {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        if let Some(w) = wall {
            bc[w] = [Boundary::wall(), Boundary::wall()];
        }
        bc
    }

    /// Whether this side is periodic.
    pub fn is_periodic(&self) -> bool {
        matches!(self, Boundary::Periodic)
    }

    /// Velocity of the side (zero for periodic sides).
    pub fn velocity(&self) -> [T; 3] {
        match self {
            Boundary::Periodic => [T::zero(); 3],
            Boundary::Wall { velocity } => *velocity,
        }
    }
}
