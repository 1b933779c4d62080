//! Checks for membrane laws, for users' own [`SurfaceLaw`](crate::membrane::SurfaceLaw)s as for
//! the crate's (behind the `testing` feature).
