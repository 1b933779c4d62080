//! The one error type of the crate.
//!
//! Every fallible public function returns [`Result<T>`]. Variants name the parameter (or field,
//! or solver), the offending value, and what is allowed, so that a message can be acted upon.

use std::fmt;

/// Errors returned by the public API.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A parameter is outside its allowed range.
    InvalidParameter {
        /// Name of the parameter, as in the API (e.g. `"dt"`, `"spacing[1]"`).
        name: &'static str,
        /// The value that was given, formatted.
        value: String,
        /// What is allowed (e.g. `"a finite number > 0"`).
        allowed: &'static str,
    },
    /// A combination of settings that a component cannot handle.
    Unsupported {
        /// The component that refuses (e.g. `"SpectralSolver"`).
        component: &'static str,
        /// What was asked and what to do instead.
        detail: String,
    },
    /// An iterative solver did not reach its tolerance.
    NoConvergence {
        /// Name of the solver.
        solver: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// Relative residual (or change) reached.
        residual: f64,
        /// The tolerance that was asked for.
        tolerance: f64,
    },
    /// A NaN or infinity appeared in a field.
    NonFinite {
        /// The field that holds it (e.g. `"velocity.u"`).
        field: &'static str,
        /// Interior cell index (i, j, k) of the first non-finite value found.
        cell: [usize; 3],
    },
    /// A time step of a [`Simulation`](crate::simulation::Simulation) failed; the state is as
    /// it was before the step. `source` says why (e.g. [`Error::NonFinite`] with the field and
    /// cell, or [`Error::NoConvergence`]).
    Step {
        /// Number of the step that failed (1 for the first step).
        step: usize,
        /// Time at the start of the failed step.
        time: f64,
        /// The step size that was tried.
        dt: f64,
        /// The error that stopped the step.
        source: Box<Error>,
    },
    /// Reading or writing a file failed.
    Io {
        /// The path involved (empty where the error came without one, e.g. through `?` on a
        /// [`std::io::Error`]).
        path: String,
        /// The operating-system message.
        message: String,
    },
    /// A user's own code failed (an observer, an effect, a law, a law check): its message.
    User {
        /// What failed and why, as the user's code said it.
        message: String,
    },
}

impl Error {
    /// An [`Error::User`] with `message`: how a user's observer, effect or law reports a
    /// failure of its own.
    ///
    /// ```
    /// let e = eulermembrane::Error::user("the probe left the box");
    /// assert_eq!(e.to_string(), "the probe left the box");
    /// ```
    pub fn user(message: impl Into<String>) -> Self {
        Error::User { message: message.into() }
    }

    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(name: &'static str, value: impl fmt::Display, allowed: &'static str) -> Self {
        Error::InvalidParameter { name, value: value.to_string(), allowed }
    }
}

/// An I/O error without a path (`?` in an observer that writes a file): [`Error::Io`] with an
/// empty `path`.
impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Io { path: String::new(), message: e.to_string() }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidParameter { name, value, allowed } => {
                write!(f, "invalid parameter `{name}` = {value}: allowed is {allowed}")
            }
            Error::Unsupported { component, detail } => write!(f, "{component}: {detail}"),
            Error::NoConvergence { solver, iterations, residual, tolerance } => write!(
                f,
                "{solver} did not converge: residual {residual:.3e} after {iterations} iterations \
                 (tolerance {tolerance:.1e})"
            ),
            Error::NonFinite { field, cell } => {
                write!(f, "non-finite value in field `{field}` at cell {cell:?}")
            }
            // The advice belongs to the context: only a time step can be retried with a smaller dt.
            Error::Step { step, time, dt, source } => {
                write!(
                    f,
                    "step {step} (from t = {time:e} with dt = {dt:e}) failed: {source}; the state is as before the step"
                )?;
                match source.as_ref() {
                    // A parameter that the step cannot meet: a smaller step does not help.
                    Error::InvalidParameter { .. } => write!(f, ": change that parameter"),
                    _ => write!(f, ": retry with a smaller dt (see simulation::stability for the limits)"),
                }
            }
            Error::Io { path, message } if path.is_empty() => write!(f, "I/O error: {message}"),
            Error::Io { path, message } => write!(f, "I/O error on `{path}`: {message}"),
            Error::User { message } => f.write_str(message),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Step { source, .. } => Some(source.as_ref()),
            _ => None,
        }
    }
}

/// Result type of the crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Validates a parameter that must be finite and strictly positive: `Ok(x)`, or an
/// [`Error::InvalidParameter`] naming `name`, the value and `"a finite number > 0"`.
///
/// For the constructors of users' own types (e.g. a [`SurfaceLaw`](crate::membrane::law::SurfaceLaw)),
/// so that their errors read like the crate's.
///
/// # Example
/// ```
/// use eulermembrane::{Error, positive};
///
/// assert_eq!(positive("gs", 2.0), Ok(2.0));
/// match positive("gs", -1.0) {
///     Err(Error::InvalidParameter { name, value, allowed }) => {
///         assert_eq!((name, value.as_str(), allowed), ("gs", "-1", "a finite number > 0"));
///     }
///     other => panic!("{other:?}"),
/// }
/// assert!(positive("gs", f64::NAN).is_err() && positive("gs", 0.0f32).is_err());
/// ```
pub fn positive<T: crate::Real>(name: &'static str, x: T) -> Result<T> {
    if x.is_finite() && x > T::zero() { Ok(x) } else { Err(Error::invalid(name, x, "a finite number > 0")) }
}

/// Validates a parameter that must be finite (not NaN, not infinite): `Ok(x)`, or an
/// [`Error::InvalidParameter`] naming `name`, the value and `"a finite number"`.
///
/// # Example
/// ```
/// use eulermembrane::finite;
///
/// assert_eq!(finite("psi", -0.5), Ok(-0.5));
/// let e = finite("psi", f64::INFINITY).unwrap_err();
/// assert_eq!(e.to_string(), "invalid parameter `psi` = inf: allowed is a finite number");
/// ```
pub fn finite<T: crate::Real>(name: &'static str, x: T) -> Result<T> {
    if x.is_finite() { Ok(x) } else { Err(Error::invalid(name, x, "a finite number")) }
}
