//! Measurements on a simulation state: what the paper plots, computed from the public fields only
//! (no stepper or driver is needed).
//!
//! | quantity | formula | module |
//! |---|---|---|
//! | volume | `V = sum phi_ijk dx dy dz` | [`volume`](fn@volume::volume) |
//! | centroid (3.5) | `x_c = sum phi x dx dy dz / sum phi dx dy dz` | [`centroid`](volume::centroid) |
//! | surface area | `s = sum delta_ijk dx dy dz` | [`area_from_delta`](area::area_from_delta) |
//! | area transport (3.6)-(3.7) | `s^{n+1} = s^n - dt sum delta n.grad v.n dx dy dz` | [`AreaTracker`](area::AreaTracker) |
//! | surface modes (3.2)-(3.4) | `R_{n,m} = sum delta w Y_{n,m}(theta, varphi) dx dy dz` | [`surface_modes`](modes::surface_modes) |
//! | Taylor deformation (Sec. 3.3.1) | `D = (L - B)/(L + B)` of an ellipse fitted to `phi = 1/2` | [`taylor_deformation`](taylor::taylor_deformation) |
//! | ellipsoid of inertia | `D = (a - c)/(a + c)` of the ellipsoid with the volume and second moments of `phi` | [`ellipsoid_fit`](ellipsoid::ellipsoid_fit) |
//! | energy budget (Sec. 3.2) | `E_kin + E_el + int mu grad v : grad v dt - int v.F dt` | [`EnergyBudget`](energy::EnergyBudget) |
//! | membrane velocity on a mode | `c = sum delta v.m / sum delta m.m` | [`surface_velocity_projection`](mobility::surface_velocity_projection) |
//! | velocity profiles (Fig. 17) | `<u>(y)` averaged over x (and z) | [`streamwise_profile`](profile::streamwise_profile) |
//! | normal part of `G_s` | largest and delta-weighted mean norm of `G_s n`, largest `tr G_s`, over the band | [`gs_tangency`](tangency::gs_tangency) |
//!
//! Conventions shared by every function here:
//! - fields are read at cell centres (`phi`, `delta`, normals, energy densities) or on the
//!   staggered faces (velocity, face forces), as everywhere in the crate; functions that
//!   difference or average the velocity read one ghost layer, which must be filled
//!   ([`VectorField::fill_ghosts`](crate::grid::VectorField::fill_ghosts));
//! - fields may be `f32` or `f64`; every result is accumulated and returned in `f64`;
//! - sums over cells are reproducible: they add 64 fixed blocks of x-lines, each in order, then
//!   the blocks in order (as [`crate::fluid::linalg`]), so a result does not depend on the number
//!   of threads;
//! - a field of the wrong size is an [`Error::InvalidParameter`](crate::Error), a NaN or an
//!   infinity that reaches a result is an [`Error::NonFinite`](crate::Error) naming the field and
//!   the first cell that holds one;
//! - functions about "the capsule" (centroid, modes, Taylor deformation, ellipsoid fit) assume the fields hold
//!   one capsule; with several capsules, pass a `phi`/`delta` masked to one of them.
//!
//! Each submodule opens with the equations it implements; everything public is re-exported here.
//!
//! Periodic boxes: displacements from a reference point (the centroid, or the cell where `phi`
//! is largest while the centroid is being computed) are wrapped into `[-L/2, L/2)` along every
//! periodic axis, so a capsule that straddles a periodic boundary is measured whole, provided it
//! spans less than half the period along that axis.

pub mod area;
pub mod ellipsoid;
pub mod energy;
pub mod mobility;
pub mod modes;
pub mod profile;
mod reduce;
pub mod suspension;
pub mod tangency;
pub mod taylor;
pub mod volume;
