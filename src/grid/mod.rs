//! The staggered (MAC) grid of Fig. 2, its boundaries, fields and discrete operators.
//!
//! # Layout
//! The domain `[lower, upper]` is divided into `n[0] x n[1] x n[2]` cells of uniform spacing `h[d]`
//! per axis ((2.28)). Cell `(i, j, k)`, with `0 <= i < n[0]` etc., has its centre at
//! `lower + (i + 1/2, j + 1/2, k + 1/2) h`. Every field is stored with [`GHOST`] layers of ghost
//! cells on each side, x fastest, in a plain `Vec`.
//!
//! Staggering: scalars (`phi`, `p`, `kappa_R tilde`) and tensors (`G_s`, `tau`) live at cell
//! centres. Velocity component `d` with index `(i, j, k)` lives on the *lower* face of cell
//! `(i, j, k)` normal to axis `d`: `u[i,j,k]` at `x = lower_x + i h_x`, cell-centred in y and z.
//! On a wall axis the faces `0` and `n[d]` lie on the walls.
//!
//! A 2D problem is a 3D grid with one cell along z and periodic z boundaries: every stencil then
//! reads copies of the same plane, and z-derivatives vanish exactly.

mod boundary;
mod decomposition;
mod field;
mod geometry;
#[cfg(feature = "mpi")]
mod mpi_ranks;
pub mod ops;
mod window;

pub use boundary::Boundary;
pub use decomposition::{Decomposition, Exchange, LocalParts};
pub use field::{Field, SymField, VectorField};
pub use geometry::{GHOST, Grid};
#[cfg(feature = "mpi")]
pub use mpi_ranks::MpiExchange;
pub use window::Window;
