//! Membrane mechanics at a point: eqs (2.1)–(2.6), (2.18), (2.33), (2.35) and Appendix B.
//!
//! The membrane is described on the Eulerian grid by the surface deformation tensor
//! `G_s = F·P_R·Fᵀ` (2.18) and the current unit normal `n`; the surface left Cauchy–Green tensor
//! is `B_s = P·G_s·P` with `P = I − n n`. From `B_s` follow the invariants `c1`, `c2` (2.3), the
//! in-plane Cauchy stress (2.4)
//!
//! ```text
//! τ = (2/√c2) (∂W_s/∂c1 B_s + c2 ∂W_s/∂c2 P),
//! ```
//!
//! its Jacobian `J = ∂τ/∂G_s` (2.33) used by the quasi-implicit predictor (2.32)–(2.35), and the
//! term `H(∇v, G_s, J)` of (2.35), (B.6)–(B.7).
//!
//! - [`law`]: the [`SurfaceLaw`](law::SurfaceLaw) trait (energy and its derivatives in `c1`, `c2`) and the
//!   paper's laws [`NeoHookean`](law::NeoHookean) (2.5) and [`Skalak`](law::Skalak) (2.6);
//! - [`wrinkling`]: [`TensionField`](wrinkling::TensionField), the tension-field (relaxed) energy of any law: a membrane
//!   that wrinkles instead of carrying compression;
//! - [`stress`](mod@stress): `B_s`, `c1`, `c2`, `τ`, `J'`, `H`, energy density and principal tensions —
//!   pointwise, allocation free, generic over the law and over `f32`/`f64`;
//! - [`loading`]: uniaxial and equibiaxial tension of a flat sheet for any law (checked against
//!   the closed forms of the two paper laws and against Barthès-Biesel et al. 2002);
//! - [`band`]: the cells where `delta h >= epsilon`, where all membrane work happens, so that its
//!   cost grows with the capsule surface rather than with the box;
//! - [`force`]: the in-plane force `div(delta tau)` on the staggered faces, explicit
//!   ([`Forcing`](crate::fluid::forcing::Forcing)) and quasi-implicit
//!   ([`ImplicitTerm`](crate::fluid::momentum::ImplicitTerm)) parts of (2.35);
//! - [`bending`]: the modified bending stress (2.16)-(2.17) and its force;
//! - [`bending_implicit`]: the stiff part of the bending force linearised in the velocity, for
//!   the predictor (semi-implicit bending);
//! - [`strain`]: transport of `G_s` (2.40) with third-order upwind fluxes, AB2, and the re-set to
//!   `P` outside the band.
//!
//! Conventions: [`Sym`](crate::tensor::Sym) holds tensor components in the order
//! `(11, 22, 33, 12, 23, 31)`; `grad_v[i][j] = ∂v_j/∂x_i` (the paper's `∇v`); the 6x6 Jacobian
//! maps tensor-component increments `dG'` to `dτ'` (see [`stress`](mod@stress) for the factor-two
//! convention and for two corrections to Appendix B).

pub mod band;
pub mod bending;
mod bending_energy;
pub mod bending_implicit;
pub mod extension;
pub mod force;
pub mod law;
pub mod loading;
pub mod outer_layers;
pub mod strain;
pub mod stress;
pub mod wrinkling;
