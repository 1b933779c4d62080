//! Many capsules: non-overlapping centres (and orientations) of `K` capsules in a box, by random
//! sequential addition (RSA), reproducible from a seed on every machine.
//!
//! A [`Placement`] takes the box ([`Domain`], or [`Domain::from_grid`]), the capsule's
//! [`Prototype`] (a sphere, or a biconcave red cell held fixed or turned at random), a
//! [`Target`] (a count `K` or a volume fraction), the smallest gap between two surfaces, the
//! smallest distance from a surface to a wall and a seed. [`Placement::place`] draws
//! candidates one after the other, uniformly over the box (and over the rotations), and keeps
//! each that clears the walls and every capsule kept before it, until `K` are kept or a bounded
//! number of attempts is spent. [`Placed::shapes`] turns the result into shapes for
//! [`Scene::capsule`](crate::simulation::Scene::capsule).
//!
//! # Tests of overlap
//!
//! - Two spheres of radius `a` clear each other when their centres are at least `2 a + gap`
//!   apart: exact.
//! - Two biconcave cells clear each other when their **bounding spheres** do (centres at least
//!   `2 a + gap` apart for the paper's cell, whose bounding sphere has the cell's radius `a`;
//!   [`Prototype::bounding_radius`] in general). This is conservative: cells that could stack
//!   closer are kept apart, which limits the volume fraction of cells (see below).
//! - A cell clears a wall when its extent along the wall's normal, computed for its
//!   orientation ([`Prototype::extent`], an upper bound within `3e-3 a`), leaves the asked
//!   distance to the wall; a sphere when its centre is `a + wall_distance` from the wall.
//!
//! On periodic axes distances are those of the nearest periodic image (minimum image).
//!
//! # The limit of the volume fraction
//!
//! Random sequential addition jams: equal spheres added at random in a large periodic box stop
//! fitting at a volume fraction of 0.3828 (Torquato, Uche & Stillinger, Phys. Rev. E 74,
//! 061308, 2006), approached only after ever more attempts. A placement is refused up front when
//! its *exclusion fraction* ([`Placement::packing_fraction`]), the volume of the exclusion
//! spheres (radius `r_b + gap / 2`, with `r_b` the bounding radius) over the volume they can
//! fill, exceeds [`MAX_PACKING_FRACTION`] = 0.30; for spheres without a gap in a periodic box it
//! is the volume fraction itself. Measured with 20 seeds each, at 0.30 the most attempts any
//! placement needed were 30-320 per capsule in periodic cubes of 2 to 200 spheres (the fewest
//! spheres, the most attempts), 55 at 200 spheres, and 10-190 in channels, closed boxes and
//! thin periodic slabs of 20 to 300 spheres or cells: the default budget of
//! [`DEFAULT_ATTEMPTS_PER_CAPSULE`] = 10 000 per capsule leaves a margin of 30 or more. (At
//! 0.34 a periodic cube of 200 spheres needed 700 per capsule, and a closed box of 50 failed
//! within a million.) When the attempts do run out, the error names `count` or
//! `volume_fraction` and says how many capsules were placed.
//!
//! For denser suspensions [`Method::ShakenLattice`] puts the capsules on the widest lattice the
//! room holds (`K` of its sites drawn at random) and shakes them by hard-sphere Monte Carlo
//! moves (each capsule in turn moved by up to a step along each axis, the move kept where it
//! clears the walls and every other capsule; the step steered to an acceptance of 0.3-0.5):
//! the lattices are rectangular (a count of sites along each axis), so the exclusion fraction
//! reaches that of the simple cubic lattice, `pi / 6` = 0.52, in a room whose sides its spacing
//! divides (less otherwise), and the moves carry the lattice's order away towards the
//! hard-sphere fluid's (a few hundred sweeps).
//!
//! For the paper's biconcave cell the bounding sphere holds 2.24 times the cell's volume, so
//! the volume fraction of cells stays below about `0.30 / 2.24 = 0.13` by sequential addition
//! (less with a gap or walls), and at most `0.52 / 2.24 = 0.23` shaken, far from the hematocrit of blood:
//! dense suspensions of cells need a placement that packs the cells themselves (or one that
//! lets them deform into place), which this module does not do.
//!
//! # Reproducibility
//!
//! The random numbers come from xoshiro256** seeded through SplitMix64 ([`Xoshiro256StarStar`]),
//! and the placement uses only additions, multiplications, divisions, square roots and
//! roundings, which IEEE 754 rounds exactly: no `sin`, `cos` or `exp`, whose last bit may change
//! from one platform's math library to another. A seed thus gives the same centres and
//! rotations, bit for bit, on every machine.
//!
//! ```
//! use eulermembrane::interface::placement::{Domain, Orientation, Placement, Prototype, Target};
//!
//! // Red cells of radius 0.2, at random orientations, in a channel with walls at y = 0 and
//! // y = 1, periodic in x and z; two cells of h = 1/32 between surfaces and to the walls.
//! let domain = Domain::new([0.0; 3], [2.0, 1.0, 2.0], [true, false, true])?;
//! let h = 1.0 / 32.0;
//! let cell = Prototype::red_cell(0.2, Orientation::Random)?;
//! let placement =
//!     Placement::new(domain, cell, Target::Count(12)).gap(2.0 * h).wall_distance(2.0 * h).seed(42);
//! let placed = placement.place()?;
//! assert_eq!(placed.len(), 12);
//! assert!((placed.volume_fraction() - 12.0 * cell.volume() / 4.0).abs() < 1e-15);
//! // The cells' bounding spheres, widened by half the gap, fill 22 % of the room they have.
//! assert!((placement.packing_fraction(12) - 0.22).abs() < 0.005);
//! // Twenty would fill 37 %: refused before any attempt, naming the count.
//! let crowded = Placement::new(domain, cell, Target::Count(20)).gap(2.0 * h).wall_distance(2.0 * h);
//! assert!(matches!(crowded.place(), Err(eulermembrane::Error::InvalidParameter { name: "count", .. })));
//! # Ok::<(), eulermembrane::Error>(())
//! ```

use super::shapes::{Biconcave, Shape, Sphere, SurfacePoint};
use crate::grid::Grid;
use crate::tensor::Mat3;
use crate::{Error, Real, Result};
use std::f64::consts::PI;

/// The largest exclusion fraction ([`Placement::packing_fraction`]) a [`Placement`] accepts.
/// Random sequential addition of equal spheres jams at 0.3828 ([`RSA_JAMMING_FRACTION`]); at
/// 0.30 the default attempts placed every case measured (periodic, walled, slabs; 2 to 2000
/// spheres or cells; 20 seeds each) with a margin of 30 or more, while the attempts grow
/// without bound towards jamming (see the [module docs](self)).
pub const MAX_PACKING_FRACTION: f64 = 0.30;

/// The jamming fraction of random sequential addition of equal spheres in 3D, 0.38278
/// (Torquato, Uche & Stillinger 2006), for reference: no placement reaches it.
pub const RSA_JAMMING_FRACTION: f64 = 0.38278;

/// The default [`Placement::attempts_per_capsule`]: the attempts allowed are this times the
/// count.
pub const DEFAULT_ATTEMPTS_PER_CAPSULE: usize = 10_000;

/// How a [`Placement`] finds the centres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Random sequential addition (the default): candidates drawn uniformly, each kept where it
    /// clears the capsules kept before it, up to an exclusion fraction of
    /// [`MAX_PACKING_FRACTION`].
    #[default]
    SequentialAddition,
    /// The widest lattice the room holds, `K` of its sites drawn at random, then `sweeps`
    /// sweeps of hard-sphere Monte Carlo moves (see the [module docs](self)): for volume
    /// fractions sequential addition does not reach. A few hundred sweeps make the centres
    /// those of a hard-sphere fluid.
    ShakenLattice {
        /// The sweeps of moves (one move per capsule each).
        sweeps: usize,
    },
}

mod shaken;

// ---------------------------------------------------------------------------------------------
// Random numbers.
// ---------------------------------------------------------------------------------------------

/// SplitMix64 (Steele, Lea & Flood, *Fast splittable pseudorandom number generators*, OOPSLA
/// 2014; Vigna's reference C code): a 64-bit state advanced by a Weyl sequence and hashed.
/// Every seed, 0 included, is fine; used here to expand a seed into the state of
/// [`Xoshiro256StarStar`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator starting from `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// xoshiro256** 1.0 (Blackman & Vigna, *Scrambled linear pseudorandom number generators*, ACM
/// TOMS 2021): 256 bits of state, period `2^256 - 1`, the authors' all-purpose generator. The
/// state is seeded with four outputs of [`SplitMix64`], as they recommend, so it is never all
/// zero.
///
/// ```
/// use eulermembrane::interface::placement::Xoshiro256StarStar;
/// let mut a = Xoshiro256StarStar::new(7);
/// let mut b = Xoshiro256StarStar::new(7);
/// assert_eq!(a.next_u64(), b.next_u64());
/// let u = a.next_f64();
/// assert!((0.0..1.0).contains(&u));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Xoshiro256StarStar {
    s: [u64; 4],
}

impl Xoshiro256StarStar {
    /// A generator whose state is four outputs of [`SplitMix64::new`]`(seed)`.
    pub fn new(seed: u64) -> Self {
        let mut sm = SplitMix64::new(seed);
        Xoshiro256StarStar { s: std::array::from_fn(|_| sm.next_u64()) }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// A uniform number in `[0, 1)`: the top 53 bits times `2^-53` (exact).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A uniform number in `(-1, 1)`: `2 u - 1` for [`next_f64`](Self::next_f64) `u`, with `-1`
    /// drawn again.
    fn next_symmetric(&mut self) -> f64 {
        loop {
            let v = 2.0 * self.next_f64() - 1.0;
            if v > -1.0 {
                return v;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Rotations and rotated shapes.
// ---------------------------------------------------------------------------------------------

/// A proper rotation, as the matrix `R` that takes a vector of a shape's own (body) frame to the
/// world frame: `v_world = R v_body`. For the biconcave cell (axis along x in its own frame),
/// the cell's axis in the world is `R`'s first column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotation {
    m: Mat3<f64>,
}

impl Default for Rotation {
    fn default() -> Self {
        Rotation::IDENTITY
    }
}

impl Rotation {
    /// No rotation.
    pub const IDENTITY: Rotation = Rotation { m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };

    /// The rotation of a quaternion `q = (w, x, y, z)` (normalised here; `w = cos(angle / 2)`,
    /// `(x, y, z) = sin(angle / 2) axis`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `quaternion` unless its components are finite and not
    /// all zero.
    pub fn from_quaternion(q: [f64; 4]) -> Result<Self> {
        let n2 = q.iter().map(|v| v * v).sum::<f64>();
        if !(q.iter().all(|v| v.is_finite()) && n2 > 0.0 && n2.is_finite()) {
            return Err(Error::invalid(
                "quaternion",
                format!("{q:?}"),
                "four finite components, not all zero",
            ));
        }
        let n = n2.sqrt();
        let [w, x, y, z] = q.map(|v| v / n);
        Ok(Rotation {
            m: [
                [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
                [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
                [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
            ],
        })
    }

    /// The rotation by `angle` (radians, right-handed) about `axis` (normalised here).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `axis` unless it is finite and not zero, or `angle`
    /// unless it is finite.
    pub fn about_axis(axis: [f64; 3], angle: f64) -> Result<Self> {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return Err(Error::invalid("axis", format!("{axis:?}"), "a finite vector, not zero"));
        }
        if !angle.is_finite() {
            return Err(Error::invalid("angle", angle, "a finite angle in radians"));
        }
        let (s, c) = (0.5 * angle).sin_cos();
        Self::from_quaternion([c, s * axis[0] / n, s * axis[1] / n, s * axis[2] / n])
    }

    /// A rotation from its matrix (`v_world = m v_body`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `rotation` unless `m` is finite, orthonormal to
    /// `1e-10` and of determinant `+1` (not a reflection).
    pub fn from_matrix(m: Mat3<f64>) -> Result<Self> {
        let mut worst = 0.0f64;
        for i in 0..3 {
            for j in 0..3 {
                let dot = (0..3).map(|k| m[k][i] * m[k][j]).sum::<f64>();
                worst = worst.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        if !(worst <= 1e-10 && det > 0.0) {
            return Err(Error::invalid(
                "rotation",
                format!("{m:?}"),
                "a finite orthonormal matrix (to 1e-10) of determinant +1",
            ));
        }
        Ok(Rotation { m })
    }

    /// A rotation drawn uniformly (from the Haar measure) with `rng`: a uniform unit quaternion
    /// by Marsaglia's method (Ann. Math. Stat. 43, 645, 1972: two points uniform in the unit
    /// disc), which needs square roots only.
    pub fn random(rng: &mut Xoshiro256StarStar) -> Self {
        let disc = |rng: &mut Xoshiro256StarStar| loop {
            let (x, y) = (rng.next_symmetric(), rng.next_symmetric());
            let s = x * x + y * y;
            if s < 1.0 && s > 0.0 {
                return (x, y, s);
            }
        };
        let (x1, y1, s1) = disc(rng);
        let (x2, y2, s2) = disc(rng);
        let k = ((1.0 - s1) / s2).sqrt();
        Self::from_quaternion([x1, y1, x2 * k, y2 * k]).unwrap_or(Rotation::IDENTITY)
    }

    /// The matrix `R` (`v_world = R v_body`).
    pub fn matrix(&self) -> Mat3<f64> {
        self.m
    }

    /// `R v`: a body-frame vector in the world frame.
    pub fn apply(&self, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| self.m[i][0] * v[0] + self.m[i][1] * v[1] + self.m[i][2] * v[2])
    }

    /// `R^T v`: a world-frame vector in the body frame.
    pub fn apply_inverse(&self, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| self.m[0][i] * v[0] + self.m[1][i] * v[1] + self.m[2][i] * v[2])
    }
}

/// A 3D shape turned by a [`Rotation`] about its centre: the query point is turned back into
/// the shape's own frame, and the closest point and normal turned forward; distances and
/// curvatures are unchanged. This is how a [`Biconcave`] cell (whose axis can only lie along
/// x, y or z) gets any orientation.
///
/// ```
/// use eulermembrane::interface::placement::{Rotated, Rotation};
/// use eulermembrane::interface::shapes::{Biconcave, Shape};
/// // A red cell whose axis points along (1, 1, 0) / sqrt(2).
/// let q = Rotation::about_axis([0.0, 0.0, 1.0], std::f64::consts::FRAC_PI_4)?;
/// let cell = Rotated::new(Biconcave::new([0.5; 3], 0.2)?, q)?;
/// // The dimple's centre lies on the new axis.
/// let d = 0.5 * 0.2 * 0.35 / 2f64.sqrt();
/// assert!(cell.signed_distance([0.5 + d, 0.5 + d, 0.5]).abs() < 1e-12);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Rotated<S> {
    shape: S,
    rotation: Rotation,
    pivot: [f64; 3],
}

impl<S: Shape> Rotated<S> {
    /// `shape` turned by `rotation` about its [`center`](Shape::center).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `Rotated shape` for a 2D shape (a curve in the
    /// xy-plane) or a shape without a centre.
    pub fn new(shape: S, rotation: Rotation) -> Result<Self> {
        if shape.dimension() != 3 {
            return Err(Error::invalid(
                "Rotated shape",
                format!("a shape of dimension {}", shape.dimension()),
                "a 3D shape (a 2D curve in the xy-plane cannot be turned out of it)",
            ));
        }
        let Some(pivot) = shape.center() else {
            return Err(Error::invalid(
                "Rotated shape",
                "a shape without a centre",
                "a shape with a centre to turn about (e.g. SignedDistanceFn::with_center)",
            ));
        };
        Ok(Rotated { shape, rotation, pivot })
    }

    /// The shape in its own frame.
    pub fn shape(&self) -> &S {
        &self.shape
    }

    /// The rotation.
    pub fn rotation(&self) -> Rotation {
        self.rotation
    }

    /// A world point in the shape's frame: `c + R^T (x - c)`.
    fn to_body(&self, x: [f64; 3]) -> [f64; 3] {
        let c = self.pivot;
        let b = self.rotation.apply_inverse([x[0] - c[0], x[1] - c[1], x[2] - c[2]]);
        [c[0] + b[0], c[1] + b[1], c[2] + b[2]]
    }
}

impl<S: Shape> Shape for Rotated<S> {
    fn dimension(&self) -> usize {
        3
    }
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        self.shape.signed_distance(self.to_body(x))
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let sp = self.shape.closest(self.to_body(x));
        let c = self.pivot;
        let p = self.rotation.apply([sp.point[0] - c[0], sp.point[1] - c[1], sp.point[2] - c[2]]);
        SurfacePoint {
            point: [c[0] + p[0], c[1] + p[1], c[2] + p[2]],
            normal: self.rotation.apply(sp.normal),
            ..sp
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.pivot)
    }
    fn volume(&self) -> Option<f64> {
        self.shape.volume()
    }
    fn bounding_radius(&self) -> Option<f64> {
        // Turned about its own centre: the same ball holds it.
        self.shape.bounding_radius()
    }
}

// ---------------------------------------------------------------------------------------------
// The box, the prototype, the target.
// ---------------------------------------------------------------------------------------------

/// The box capsules are placed in: `[lower, upper]`, periodic along the axes where `periodic`
/// says so, bounded by walls along the others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    lower: [f64; 3],
    upper: [f64; 3],
    periodic: [bool; 3],
}

impl Domain {
    /// The box `[lower, upper]`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `upper - lower` unless every side is finite and `> 0`.
    pub fn new(lower: [f64; 3], upper: [f64; 3], periodic: [bool; 3]) -> Result<Self> {
        for d in 0..3 {
            let len = upper[d] - lower[d];
            if !(lower[d].is_finite() && upper[d].is_finite() && len > 0.0 && len.is_finite()) {
                return Err(Error::invalid(
                    "upper - lower",
                    format!("{len} on axis {d}"),
                    "a finite length > 0 on every axis",
                ));
            }
        }
        Ok(Domain { lower, upper, periodic })
    }

    /// The box of a grid, periodic where the grid is.
    pub fn from_grid<T: Real>(grid: &Grid<T>) -> Self {
        Domain {
            lower: grid.lower().map(|x| x.f64()),
            upper: grid.upper().map(|x| x.f64()),
            periodic: std::array::from_fn(|d| grid.is_periodic(d)),
        }
    }

    /// The lower corner.
    pub fn lower(&self) -> [f64; 3] {
        self.lower
    }

    /// The upper corner.
    pub fn upper(&self) -> [f64; 3] {
        self.upper
    }

    /// Which axes are periodic.
    pub fn periodic(&self) -> [bool; 3] {
        self.periodic
    }

    /// The side lengths `upper - lower`.
    pub fn lengths(&self) -> [f64; 3] {
        std::array::from_fn(|d| self.upper[d] - self.lower[d])
    }

    /// The volume of the box.
    pub fn volume(&self) -> f64 {
        let l = self.lengths();
        l[0] * l[1] * l[2]
    }

    /// `b - a`, on periodic axes that to the nearest periodic image of `b` (minimum image).
    pub fn separation(&self, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        let l = self.lengths();
        std::array::from_fn(|d| {
            let s = b[d] - a[d];
            if self.periodic[d] { s - l[d] * (s / l[d]).round() } else { s }
        })
    }

    /// The distance from `a` to the nearest periodic image of `b`.
    pub fn distance(&self, a: [f64; 3], b: [f64; 3]) -> f64 {
        let s = self.separation(a, b);
        (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
    }
}

/// How the placed biconcave cells are oriented.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Orientation {
    /// Every cell turned by the same rotation (the identity: axis along x).
    Fixed(Rotation),
    /// Each cell turned by its own uniformly random rotation ([`Rotation::random`]).
    #[default]
    Random,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Sphere { radius: f64 },
    Biconcave { radius: f64, coefficients: [f64; 3], orientation: Orientation },
}

/// The shape each capsule takes, before it is moved into place: a sphere, or a biconcave cell
/// ([`Biconcave`]) with its orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prototype {
    kind: Kind,
    volume: f64,
    bound: f64,
}

/// Samples of the meridian in the extent of a biconcave cell ([`Prototype::extent`]).
const EXTENT_SAMPLES: usize = 1024;

impl Prototype {
    /// A sphere of `radius`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `Sphere radius` unless `radius` is finite and `> 0`.
    pub fn sphere(radius: f64) -> Result<Self> {
        let s = Sphere::new([0.0; 3], radius)?;
        Ok(Prototype { kind: Kind::Sphere { radius }, volume: s.volume().unwrap_or(0.0), bound: radius })
    }

    /// The paper's red cell of `radius` ([`Biconcave::new`]: coefficients `0.35, 2.003,
    /// -1.123`), oriented as `orientation` says.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `Biconcave radius` unless `radius` is finite and `> 0`.
    pub fn red_cell(radius: f64, orientation: Orientation) -> Result<Self> {
        Self::biconcave(radius, [0.35, 2.003, -1.123], orientation)
    }

    /// A biconcave cell with coefficients `c` ([`Biconcave::with_coefficients`], axis along x
    /// in its own frame), oriented as `orientation` says.
    ///
    /// # Errors
    /// Those of [`Biconcave::with_coefficients`].
    pub fn biconcave(radius: f64, coefficients: [f64; 3], orientation: Orientation) -> Result<Self> {
        let b = Biconcave::with_coefficients([0.0; 3], radius, 0, coefficients)?;
        // |x - c|^2 = (a f cos t / 2)^2 + a^2 sin^2 t <= a^2 max(1, (f_max / 2)^2): the rim, at
        // distance a, is the farthest point unless the cell is thicker than it is wide.
        let bound = radius * f64::max(1.0, 0.5 * Self::f_max(coefficients));
        Ok(Prototype {
            kind: Kind::Biconcave { radius, coefficients, orientation },
            volume: b.volume().unwrap_or(0.0),
            bound,
        })
    }

    /// The largest thickness factor `f(s) = c1 + c2 s + c3 s^2` on `[0, 1]`.
    fn f_max(c: [f64; 3]) -> f64 {
        let f = |s: f64| c[0] + c[1] * s + c[2] * s * s;
        let mut m = f(0.0).max(f(1.0));
        if c[2] < 0.0 {
            let s = -c[1] / (2.0 * c[2]);
            if (0.0..=1.0).contains(&s) {
                m = m.max(f(s));
            }
        }
        m
    }

    /// The volume of one capsule.
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// The radius of the smallest sphere about the centre that holds the capsule: the radius
    /// for a sphere and for the paper's cell.
    pub fn bounding_radius(&self) -> f64 {
        self.bound
    }

    /// How the capsules are oriented (`Fixed(identity)` for a sphere, where it does not matter).
    pub fn orientation(&self) -> Orientation {
        match self.kind {
            Kind::Sphere { .. } => Orientation::Fixed(Rotation::IDENTITY),
            Kind::Biconcave { orientation, .. } => orientation,
        }
    }

    /// An upper bound of the capsule's extent from its centre along world axis `axis` (0, 1 or
    /// 2; taken modulo 3), turned by `rotation`: `max over the surface of (x - c)[axis]`.
    ///
    /// The radius for a sphere. For a biconcave cell whose axis makes the angle `theta` with
    /// the world axis, `max over t of (a/2) f(sin^2 t) |cos t| |cos theta| + a sin t sin theta`,
    /// sampled at 1025 points of the meridian (in the rational parameter `tan(t/2)`, so that no
    /// `sin` or `cos` is called) plus a bound of the error between samples (at most `3e-3 a`
    /// for the paper's cell).
    pub fn extent(&self, rotation: &Rotation, axis: usize) -> f64 {
        match self.kind {
            Kind::Sphere { radius } => radius,
            Kind::Biconcave { radius, coefficients: c, .. } => {
                let cos_theta = rotation.m[axis % 3][0].abs().min(1.0);
                let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
                let (p, q) = (0.5 * radius * cos_theta, radius * sin_theta);
                let f = |s: f64| c[0] + c[1] * s + c[2] * s * s;
                let mut best = 0.0f64;
                for k in 0..=EXTENT_SAMPLES {
                    // t = 2 atan(u): cos t = (1 - u^2) / (1 + u^2), sin t = 2 u / (1 + u^2).
                    let u = k as f64 / EXTENT_SAMPLES as f64;
                    let w = 1.0 / (1.0 + u * u);
                    let (ct, st) = ((1.0 - u * u) * w, 2.0 * u * w);
                    best = best.max(p * f(st * st) * ct + q * st);
                }
                // |dF/dt| <= p (2 max|f'| + f_max) + q and dt/du <= 2: the maximum lies within
                // half a sample spacing of a sample.
                let fp_max = c[1].abs().max((c[1] + 2.0 * c[2]).abs());
                let lipschitz = 2.0 * (p * (2.0 * fp_max + Self::f_max(c)) + q);
                best + 0.5 * lipschitz / EXTENT_SAMPLES as f64
            }
        }
    }

    /// The extent along walled axis `axis` that the centres' region leaves room for: the
    /// [`extent`](Self::extent) of the fixed orientation, or for random orientations a lower
    /// bound of the extent over all rotations (each candidate is then checked with its own).
    fn wall_extent(&self, axis: usize) -> f64 {
        match self.kind {
            Kind::Sphere { radius } => radius,
            Kind::Biconcave { orientation: Orientation::Fixed(r), .. } => self.extent(&r, axis),
            // The extent is at least that of the pole, (a c1 / 2) |cos theta|, and of the rim,
            // a sin theta; the larger of the two is smallest where they are equal.
            Kind::Biconcave { radius, coefficients: c, orientation: Orientation::Random } => {
                let p = 0.5 * radius * c[0];
                p * radius / (p * p + radius * radius).sqrt()
            }
        }
    }

    /// Whether each capsule needs a check of its own extent against the walls.
    fn random(&self) -> bool {
        matches!(self.kind, Kind::Biconcave { orientation: Orientation::Random, .. })
    }

    /// The capsule turned by `rotation` (ignored for a sphere) and moved to `center`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `center` unless it is finite.
    pub fn shape_at(&self, center: [f64; 3], rotation: Rotation) -> Result<PlacedShape> {
        match self.kind {
            Kind::Sphere { radius } => Ok(PlacedShape::Sphere(Sphere::new(center, radius)?)),
            Kind::Biconcave { radius, coefficients, .. } => {
                let b = Biconcave::with_coefficients(center, radius, 0, coefficients)?;
                Ok(PlacedShape::Biconcave(Rotated::new(b, rotation)?))
            }
        }
    }
}

/// How many capsules to place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// Exactly this many (at least 1).
    Count(usize),
    /// The volume fraction `K V_capsule / V_box` (`V_box` the whole box's volume): `K` is
    /// `round(fraction V_box / V_capsule)`, so the fraction placed
    /// ([`Placed::volume_fraction`]) differs from the target by up to half a capsule's.
    VolumeFraction(f64),
}

/// A placed capsule's shape, ready for [`Scene::capsule`](crate::simulation::Scene::capsule).
#[derive(Debug, Clone, PartialEq)]
pub enum PlacedShape {
    /// A sphere.
    Sphere(Sphere),
    /// A turned biconcave cell.
    Biconcave(Rotated<Biconcave>),
}

impl Shape for PlacedShape {
    fn dimension(&self) -> usize {
        3
    }
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        match self {
            PlacedShape::Sphere(s) => s.signed_distance(x),
            PlacedShape::Biconcave(b) => b.signed_distance(x),
        }
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        match self {
            PlacedShape::Sphere(s) => s.closest(x),
            PlacedShape::Biconcave(b) => b.closest(x),
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        match self {
            PlacedShape::Sphere(s) => s.center(),
            PlacedShape::Biconcave(b) => b.center(),
        }
    }
    fn volume(&self) -> Option<f64> {
        match self {
            PlacedShape::Sphere(s) => s.volume(),
            PlacedShape::Biconcave(b) => b.volume(),
        }
    }
    fn bounding_radius(&self) -> Option<f64> {
        match self {
            PlacedShape::Sphere(s) => s.bounding_radius(),
            PlacedShape::Biconcave(b) => b.bounding_radius(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The placement.
// ---------------------------------------------------------------------------------------------

/// Random sequential addition of `K` capsules in a box, without overlap, from a seed (see the
/// [module docs](self) for the tests of overlap, the limit of the volume fraction and why a
/// seed gives the same placement on every machine).
///
/// The parameters other than the box, the prototype and the target have defaults: `gap` 0,
/// `wall_distance` 0, `seed` 0, [`DEFAULT_ATTEMPTS_PER_CAPSULE`]. With smoothed interfaces
/// (whose profile is about four cells wide) give a gap and a wall distance of about two
/// cells, so that the profiles of neighbours barely touch.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::placement::{Domain, Placement, Prototype, Target};
/// use eulermembrane::interface::shapes::Shape;
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::simulation::{Phase, Scene};
///
/// // 16 spheres filling 10 % of a periodic unit box, two cells apart.
/// let grid = Grid::<f64>::periodic([32; 3], [0.0; 3], [1.0; 3])?;
/// let radius = (0.1 / 16.0 / (4.0 / 3.0 * std::f64::consts::PI)).cbrt();
/// let sphere = Prototype::sphere(radius)?;
/// let placed = Placement::new(Domain::from_grid(&grid), sphere, Target::VolumeFraction(0.1))
///     .gap(2.0 / 32.0)
///     .seed(1)
///     .place()?;
/// assert_eq!(placed.len(), 16);
/// assert!((placed.volume_fraction() - 0.1).abs() < 1e-12);
///
/// let mut scene = Scene::new(grid, Phase::new(1.0, 1.0)?);
/// for shape in placed.shapes()? {
///     scene = scene.capsule(shape);
/// }
/// let sim = scene.elasticity(NeoHookean::new(1.0)?).build()?;
/// assert_eq!(sim.capsule_count(), 16);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    domain: Domain,
    prototype: Prototype,
    target: Target,
    gap: f64,
    wall_distance: f64,
    seed: u64,
    attempts_per_capsule: usize,
    method: Method,
}

impl Placement {
    /// A placement of `target` capsules of `prototype` in `domain`, with the default gap (0),
    /// wall distance (0), seed (0) and attempts.
    pub fn new(domain: Domain, prototype: Prototype, target: Target) -> Self {
        Placement {
            domain,
            prototype,
            target,
            gap: 0.0,
            wall_distance: 0.0,
            seed: 0,
            attempts_per_capsule: DEFAULT_ATTEMPTS_PER_CAPSULE,
            method: Method::SequentialAddition,
        }
    }

    /// How the centres are found (default [`Method::SequentialAddition`]).
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// The smallest distance between two capsules' surfaces (between bounding spheres for
    /// cells), in length units (checked by [`place`](Self::place): finite, `>= 0`).
    pub fn gap(mut self, gap: f64) -> Self {
        self.gap = gap;
        self
    }

    /// The smallest distance between a capsule's surface and a wall, in length units (checked
    /// by [`place`](Self::place): finite, `>= 0`; unused on periodic axes).
    pub fn wall_distance(mut self, distance: f64) -> Self {
        self.wall_distance = distance;
        self
    }

    /// The seed of the random numbers ([`Xoshiro256StarStar::new`]).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// The attempts allowed per capsule: [`place`](Self::place) gives up after this times the
    /// count (checked: `>= 1`). Default [`DEFAULT_ATTEMPTS_PER_CAPSULE`].
    pub fn attempts_per_capsule(mut self, attempts: usize) -> Self {
        self.attempts_per_capsule = attempts;
        self
    }

    /// The name and the value of the target, for errors.
    fn target_name(&self) -> (&'static str, String) {
        match self.target {
            Target::Count(k) => ("count", k.to_string()),
            Target::VolumeFraction(f) => ("volume_fraction", f.to_string()),
        }
    }

    /// The count the target asks for.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `count` for 0, or `volume_fraction` unless it is
    /// finite, in `(0, 1)` and gives at least one capsule.
    pub fn count(&self) -> Result<usize> {
        match self.target {
            Target::Count(0) => Err(Error::invalid("count", 0, "at least 1 capsule")),
            Target::Count(k) => Ok(k),
            Target::VolumeFraction(f) => {
                if !(f.is_finite() && f > 0.0 && f < 1.0) {
                    return Err(Error::invalid("volume_fraction", f, "a finite fraction in (0, 1)"));
                }
                let k = (f * self.domain.volume() / self.prototype.volume()).round();
                if k < 1.0 {
                    return Err(Error::invalid(
                        "volume_fraction",
                        format!("{f} (less than half a capsule in the box)"),
                        "a fraction of at least half a capsule's volume over the box's",
                    ));
                }
                if k > u32::MAX as f64 {
                    return Err(Error::invalid(
                        "volume_fraction",
                        format!("{f} ({k} capsules)"),
                        "at most 2^32 - 1 capsules",
                    ));
                }
                Ok(k as usize)
            }
        }
    }

    /// The exclusion fraction of `count` capsules (see [`MAX_PACKING_FRACTION`]): the volume of
    /// the exclusion spheres, radius `r_e = bounding radius + gap / 2`, over the volume `V_e`
    /// they can fill. On a periodic axis `V_e` spans the period; on a walled axis the range of
    /// the centres widened by `r_e / 2` on each side (an empirical allowance, measured: the
    /// layer next to a wall packs more loosely than the bulk). The range of the centres is
    /// that of a sphere, of a cell in its fixed orientation, or, for cells at random
    /// orientations, of their bounding sphere.
    pub fn packing_fraction(&self, count: usize) -> f64 {
        let rb = self.prototype.bounding_radius();
        let re = rb + 0.5 * self.gap;
        let l = self.domain.lengths();
        let reach: f64 = (0..3)
            .map(|d| {
                if self.domain.periodic[d] {
                    l[d]
                } else {
                    let e = if self.prototype.random() { rb } else { self.prototype.wall_extent(d) };
                    (l[d] - 2.0 * (self.wall_distance + e)).max(0.0) + re
                }
            })
            .product();
        count as f64 * 4.0 / 3.0 * PI * re * re * re / reach
    }

    /// Validates the parameters and returns the count.
    fn check(&self) -> Result<usize> {
        if !(self.gap.is_finite() && self.gap >= 0.0) {
            return Err(Error::invalid("gap", self.gap, "a finite distance >= 0"));
        }
        if !(self.wall_distance.is_finite() && self.wall_distance >= 0.0) {
            return Err(Error::invalid("wall_distance", self.wall_distance, "a finite distance >= 0"));
        }
        if self.attempts_per_capsule == 0 {
            return Err(Error::invalid("attempts_per_capsule", 0, "at least 1"));
        }
        let count = self.count()?;
        let l = self.domain.lengths();
        let rb = self.prototype.bounding_radius();
        for d in 0..3 {
            let e = self.prototype.wall_extent(d);
            if self.domain.periodic[d] {
                if 2.0 * rb + self.gap > l[d] {
                    return Err(Error::invalid(
                        "Domain",
                        format!(
                            "periodic axis {d} of length {} for capsules of bounding diameter {} and gap {}",
                            l[d],
                            2.0 * rb,
                            self.gap
                        ),
                        "periodic sides at least the bounding diameter plus the gap (a capsule must \
                         clear its own periodic image)",
                    ));
                }
            } else if 2.0 * (self.wall_distance + e) > l[d] {
                return Err(Error::invalid(
                    "Domain",
                    format!(
                        "walled axis {d} of length {} for capsules of extent {e} and wall distance {}",
                        l[d], self.wall_distance
                    ),
                    "walled sides wider than the capsule plus twice the wall distance",
                ));
            }
        }
        let eta = self.packing_fraction(count);
        if eta.is_nan() || (self.method == Method::SequentialAddition && eta > MAX_PACKING_FRACTION) {
            let (name, value) = self.target_name();
            return Err(Error::invalid(
                name,
                format!(
                    "{value} ({count} capsules: exclusion fraction {eta:.4} of spheres of radius bounding \
                     radius + gap/2 = {})",
                    rb + 0.5 * self.gap
                ),
                "an exclusion fraction <= MAX_PACKING_FRACTION = 0.30 (random sequential addition jams \
                 at 0.383): fewer or smaller capsules, a smaller gap or a larger box",
            ));
        }
        Ok(count)
    }

    /// Places the capsules by the [`Method`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming
    /// - `gap`, `wall_distance` or `attempts_per_capsule` for a value out of range;
    /// - `count` or `volume_fraction` for no capsule; by sequential addition for an exclusion
    ///   fraction above [`MAX_PACKING_FRACTION`], or when the attempts run out (the value says
    ///   how many capsules were placed); shaken, when no lattice of the room spaces them by
    ///   the bounding diameter plus the gap;
    /// - `Domain` for a periodic side shorter than a capsule's bounding diameter plus the gap
    ///   or a walled side narrower than a capsule plus twice the wall distance.
    pub fn place(&self) -> Result<Placed> {
        let count = self.check()?;
        if let Method::ShakenLattice { sweeps } = self.method {
            return self.place_shaken(count, sweeps);
        }
        let dom = &self.domain;
        let proto = &self.prototype;
        let rb = proto.bounding_radius();
        let diameter = 2.0 * rb + self.gap;
        let random = proto.random();
        let fixed = match proto.orientation() {
            Orientation::Fixed(r) => r,
            Orientation::Random => Rotation::IDENTITY,
        };
        // Where the centres are drawn: between the walls less the smallest extent (for a
        // random orientation each candidate is then checked against its own extent).
        let (lo, hi) = self.centre_room(|d| proto.wall_extent(d));
        let mut rng = Xoshiro256StarStar::new(self.seed);
        let mut bins = Bins::new(dom, diameter, count);
        let mut centers: Vec<[f64; 3]> = Vec::with_capacity(count);
        let mut rotations = Vec::with_capacity(count);
        let budget = self.attempts_per_capsule.saturating_mul(count);
        let mut attempts = 0usize;
        while centers.len() < count {
            if attempts == budget {
                let (name, value) = self.target_name();
                return Err(Error::invalid(
                    name,
                    format!(
                        "{value}: {} of {count} capsules placed in {attempts} attempts \
                         (exclusion fraction {:.4})",
                        centers.len(),
                        self.packing_fraction(count)
                    ),
                    "a count random sequential addition reaches within attempts_per_capsule x count \
                     attempts: fewer or smaller capsules, a smaller gap or wall distance, a larger box, \
                     or more attempts",
                ));
            }
            attempts += 1;
            let rotation = if random { Rotation::random(&mut rng) } else { fixed };
            let c: [f64; 3] = std::array::from_fn(|d| lo[d] + rng.next_f64() * (hi[d] - lo[d]));
            if random && !self.clears_walls(c, &rotation, rb) {
                continue;
            }
            if bins.conflicts(dom, c, &centers, diameter) {
                continue;
            }
            bins.insert(c, centers.len());
            centers.push(c);
            rotations.push(rotation);
        }
        Ok(Placed { domain: *dom, prototype: *proto, centers, rotations, attempts })
    }

    /// The room of the centres along each axis: the whole period, or between the walls less
    /// the wall distance and the extent `extent(d)` along the wall's normal.
    fn centre_room(&self, extent: impl Fn(usize) -> f64) -> ([f64; 3], [f64; 3]) {
        let dom = &self.domain;
        let mut lo = dom.lower;
        let mut hi = dom.upper;
        for d in 0..3 {
            if !dom.periodic[d] {
                let e = extent(d);
                lo[d] = dom.lower[d] + self.wall_distance + e;
                hi[d] = dom.upper[d] - self.wall_distance - e;
            }
        }
        (lo, hi)
    }

    /// Whether a cell turned by `rotation` at `c` keeps the wall distance on every walled axis.
    fn clears_walls(&self, c: [f64; 3], rotation: &Rotation, rb: f64) -> bool {
        (0..3).filter(|&d| !self.domain.periodic[d]).all(|d| {
            let room = (c[d] - self.domain.lower[d]).min(self.domain.upper[d] - c[d]) - self.wall_distance;
            room >= rb || room >= self.prototype.extent(rotation, d)
        })
    }
}

/// A uniform grid of bins at least one exclusion diameter wide, each listing the capsules whose
/// centre lies in it: a candidate is compared with the capsules of its bin and the neighbours'.
struct Bins {
    n: [usize; 3],
    lower: [f64; 3],
    width: [f64; 3],
    periodic: [bool; 3],
    bins: Vec<Vec<usize>>,
}

impl Bins {
    fn new(dom: &Domain, diameter: f64, count: usize) -> Self {
        let l = dom.lengths();
        let mut n: [usize; 3] =
            std::array::from_fn(|d| ((l[d] / diameter).floor() as usize).clamp(1, 1 << 20));
        // No more bins than a few per capsule.
        let cap = (8 * count).max(64);
        while n[0] * n[1] * n[2] > cap {
            let d = (0..3).max_by_key(|&d| n[d]).unwrap_or(0);
            n[d] = n[d].div_ceil(2);
        }
        Bins {
            n,
            lower: dom.lower,
            width: std::array::from_fn(|d| l[d] / n[d] as f64),
            periodic: dom.periodic,
            bins: vec![Vec::new(); n[0] * n[1] * n[2]],
        }
    }

    fn bin_of(&self, c: [f64; 3]) -> [usize; 3] {
        std::array::from_fn(|d| {
            (((c[d] - self.lower[d]) / self.width[d]).floor().max(0.0) as usize).min(self.n[d] - 1)
        })
    }

    fn insert(&mut self, c: [f64; 3], index: usize) {
        let b = self.bin_of(c);
        self.bins[b[0] + self.n[0] * (b[1] + self.n[1] * b[2])].push(index);
    }

    fn remove(&mut self, c: [f64; 3], index: usize) {
        let b = self.bin_of(c);
        self.bins[b[0] + self.n[0] * (b[1] + self.n[1] * b[2])].retain(|&p| p != index);
    }

    /// The bins along `d` next to bin `i` (itself included), each once.
    fn neighbours(&self, d: usize, i: usize) -> ([usize; 3], usize) {
        let n = self.n[d];
        if n <= 3 {
            ([0, 1, 2], n)
        } else if self.periodic[d] {
            ([(i + n - 1) % n, i, (i + 1) % n], 3)
        } else if i == 0 {
            ([0, 1, 0], 2)
        } else if i == n - 1 {
            ([n - 2, n - 1, 0], 2)
        } else {
            ([i - 1, i, i + 1], 3)
        }
    }

    /// Whether a capsule at `c` comes closer than `diameter` to one of `centers`.
    fn conflicts(&self, dom: &Domain, c: [f64; 3], centers: &[[f64; 3]], diameter: f64) -> bool {
        let b = self.bin_of(c);
        let (xs, nx) = self.neighbours(0, b[0]);
        let (ys, ny) = self.neighbours(1, b[1]);
        let (zs, nz) = self.neighbours(2, b[2]);
        for &k in &zs[..nz] {
            for &j in &ys[..ny] {
                for &i in &xs[..nx] {
                    for &p in &self.bins[i + self.n[0] * (j + self.n[1] * k)] {
                        if dom.distance(c, centers[p]) < diameter {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

/// The result of [`Placement::place`]: the capsules' centres and rotations.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    domain: Domain,
    prototype: Prototype,
    centers: Vec<[f64; 3]>,
    rotations: Vec<Rotation>,
    attempts: usize,
}

impl Placed {
    /// The number of capsules.
    pub fn len(&self) -> usize {
        self.centers.len()
    }

    /// Whether no capsule was placed (never, for a placement that succeeded).
    pub fn is_empty(&self) -> bool {
        self.centers.is_empty()
    }

    /// The centres, in the order they were placed (in `[lower, upper]` on every axis).
    pub fn centers(&self) -> &[[f64; 3]] {
        &self.centers
    }

    /// The rotations of the capsules, as the prototype's [`Orientation`] says (the identity for
    /// spheres).
    pub fn rotations(&self) -> &[Rotation] {
        &self.rotations
    }

    /// The box.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// The prototype.
    pub fn prototype(&self) -> &Prototype {
        &self.prototype
    }

    /// The candidates drawn, the accepted ones included.
    pub fn attempts(&self) -> usize {
        self.attempts
    }

    /// The volume fraction of the capsules, `K V_capsule / V_box`.
    pub fn volume_fraction(&self) -> f64 {
        self.len() as f64 * self.prototype.volume() / self.domain.volume()
    }

    /// The capsules' shapes, for [`Scene::capsule`](crate::simulation::Scene::capsule).
    ///
    /// # Errors
    /// Those of the shapes' constructors (none for the centres a placement returns).
    pub fn shapes(&self) -> Result<Vec<PlacedShape>> {
        self.centers.iter().zip(&self.rotations).map(|(&c, &r)| self.prototype.shape_at(c, r)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn generators_match_the_reference_outputs() {
        // Vigna's splitmix64.c from state 0, and xoshiro256starstar.c from the state (1, 2, 3, 4).
        let mut sm = SplitMix64::new(0);
        assert_eq!(sm.next_u64(), 0xe220_a839_7b1d_cdaf);
        assert_eq!(sm.next_u64(), 0x6e78_9e6a_a1b9_65f4);
        let mut x = Xoshiro256StarStar { s: [1, 2, 3, 4] };
        let got: Vec<u64> = (0..4).map(|_| x.next_u64()).collect();
        assert_eq!(got, [11520, 0, 1_509_978_240, 1_215_971_899_390_074_240]);
        let mut r = Xoshiro256StarStar::new(3);
        for _ in 0..10_000 {
            let u = r.next_f64();
            assert!((0.0..1.0).contains(&u));
            let v = r.next_symmetric();
            assert!(v > -1.0 && v < 1.0);
        }
    }

    /// The centres' bits of [`the_placement_of_a_seed_is_pinned`].
    const PINNED_CENTERS: [[u64; 3]; 5] = [
        [13819607255785911984, 4603886505315116396, 4601885887644791847],
        [4571985274736253696, 4598475632746531491, 4605075134822573275],
        [13828217671857771088, 4605472890374851562, 4608389168469758156],
        [13828253066127908872, 4598968246270905487, 4602638145827882133],
        [4606312288973687590, 4605418757461789059, 4600523933550275139],
    ];
    /// The y components of the cells' axes.
    const PINNED_AXIS_Y: [u64; 5] = [
        4568722596094067328,
        4606785159280461352,
        13815965402224815965,
        4586741446416206529,
        4605255026443019952,
    ];
    const PINNED_ATTEMPTS: usize = 8;

    fn assert_rotation(r: &Rotation) {
        let m = r.matrix();
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
                assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        assert!(Rotation::from_matrix(m).is_ok());
    }

    #[test]
    fn random_rotations_are_rotations_and_uniform() {
        let mut rng = Xoshiro256StarStar::new(11);
        let n = 20_000;
        let mut mean_axis = [0.0; 3];
        let mut second = [0.0; 3];
        for _ in 0..n {
            let r = Rotation::random(&mut rng);
            assert_rotation(&r);
            let v = r.apply([1.0, 0.0, 0.0]);
            for d in 0..3 {
                mean_axis[d] += v[d] / n as f64;
                second[d] += v[d] * v[d] / n as f64;
            }
            let w = r.apply_inverse(v);
            assert!((w[0] - 1.0).abs() < 1e-14 && w[1].abs() < 1e-14 && w[2].abs() < 1e-14);
        }
        // The turned x axis is uniform on the sphere: mean 0, second moments 1/3 (errors of
        // 1/sqrt(n) = 0.007).
        for d in 0..3 {
            assert!(mean_axis[d].abs() < 0.03, "{mean_axis:?}");
            assert!((second[d] - 1.0 / 3.0).abs() < 0.02, "{second:?}");
        }
        let q = Rotation::about_axis([0.0, 0.0, 2.0], PI / 2.0).unwrap();
        let v = q.apply([1.0, 0.0, 0.0]);
        assert!(v[0].abs() < 1e-15 && (v[1] - 1.0).abs() < 1e-15);
        assert!(Rotation::from_quaternion([0.0; 4]).is_err());
        assert!(Rotation::about_axis([0.0; 3], 1.0).is_err());
        let mut reflection = Rotation::IDENTITY.matrix();
        reflection[2][2] = -1.0;
        assert!(Rotation::from_matrix(reflection).is_err());
    }

    #[test]
    fn a_rotated_biconcave_cell_is_the_cell_about_another_axis() {
        // Taking x to y: the cell whose axis lies along y.
        let c = [0.3, -0.2, 0.45];
        let q = Rotation::about_axis([0.0, 0.0, 1.0], PI / 2.0).unwrap();
        let turned = Rotated::new(Biconcave::new(c, 0.25).unwrap(), q).unwrap();
        let along_y = Biconcave::with_coefficients(c, 0.25, 1, [0.35, 2.003, -1.123]).unwrap();
        let mut rng = Xoshiro256StarStar::new(5);
        for _ in 0..200 {
            let x: [f64; 3] = std::array::from_fn(|d| c[d] + 0.7 * rng.next_symmetric());
            let (a, b) = (turned.closest(x), along_y.closest(x));
            assert!((a.distance - b.distance).abs() < 1e-12, "{x:?}");
            assert!((a.mean_curvature - b.mean_curvature).abs() < 1e-8 * b.mean_curvature.abs().max(1.0));
            for d in 0..3 {
                assert!((a.point[d] - b.point[d]).abs() < 1e-12);
                assert!((a.normal[d] - b.normal[d]).abs() < 1e-9);
            }
            assert!((turned.signed_distance(x) - along_y.signed_distance(x)).abs() < 1e-12);
        }
        assert_eq!(turned.center(), Some(c));
        assert_eq!(turned.volume(), along_y.volume());
        // Any rotation: distances are those of the cell at the turned-back point, and the
        // closest point lies on the surface along the normal.
        let r = Rotation::random(&mut rng);
        let cell = Rotated::new(Biconcave::new(c, 0.25).unwrap(), r).unwrap();
        for _ in 0..50 {
            let x: [f64; 3] = std::array::from_fn(|d| c[d] + 0.5 * rng.next_symmetric());
            let sp = cell.closest(x);
            assert!(cell.signed_distance(sp.point).abs() < 1e-10);
            let along: f64 = (0..3).map(|d| (x[d] - sp.point[d]) * sp.normal[d]).sum();
            assert!((along - sp.distance).abs() < 1e-10);
        }
        // A sphere turned is the sphere; a 2D shape is refused.
        let s = Sphere::new(c, 0.2).unwrap();
        let rs = Rotated::new(s, r).unwrap();
        assert!((rs.signed_distance([0.0; 3]) - s.signed_distance([0.0; 3])).abs() < 1e-15);
        assert!(Rotated::new(super::super::shapes::Circle::new([0.0; 2], 1.0).unwrap(), r).is_err());
    }

    /// Points of the surface of capsule `i`: the sphere or the turned meridian of the cell.
    fn surface_points(placed: &Placed, i: usize) -> Vec<[f64; 3]> {
        let c = placed.centers()[i];
        let r = placed.rotations()[i];
        let mut out = Vec::new();
        let (radius, coefficients) = match placed.prototype().kind {
            Kind::Sphere { radius } => (radius, None),
            Kind::Biconcave { radius, coefficients, .. } => (radius, Some(coefficients)),
        };
        for it in 0..=60 {
            let t = PI * it as f64 / 60.0;
            for ip in 0..48 {
                let p = 2.0 * PI * ip as f64 / 48.0;
                let body = match coefficients {
                    None => [radius * t.cos(), radius * t.sin() * p.cos(), radius * t.sin() * p.sin()],
                    Some(k) => {
                        let s = t.sin() * t.sin();
                        let x = 0.5 * radius * (k[0] + k[1] * s + k[2] * s * s) * t.cos();
                        [x, radius * t.sin() * p.cos(), radius * t.sin() * p.sin()]
                    }
                };
                let w = r.apply(body);
                out.push([c[0] + w[0], c[1] + w[1], c[2] + w[2]]);
            }
        }
        out
    }

    /// Every pair at least `2 r_b + gap` apart (minimum image); every surface at least
    /// `wall` from every wall.
    fn assert_valid(placed: &Placed, gap: f64, wall: f64) {
        let dom = placed.domain();
        let d = 2.0 * placed.prototype().bounding_radius() + gap;
        let cs = placed.centers();
        for i in 0..cs.len() {
            for j in 0..i {
                let r = dom.distance(cs[i], cs[j]);
                assert!(r >= d, "capsules {i} and {j}: {r} < {d}");
            }
            for k in 0..3 {
                assert!(cs[i][k] >= dom.lower()[k] && cs[i][k] <= dom.upper()[k]);
                if !dom.periodic()[k] {
                    for p in surface_points(placed, i) {
                        assert!(p[k] - dom.lower()[k] >= wall - 1e-12, "capsule {i} axis {k}: {p:?}");
                        assert!(dom.upper()[k] - p[k] >= wall - 1e-12, "capsule {i} axis {k}: {p:?}");
                    }
                }
            }
        }
    }

    fn periodic_box() -> Domain {
        Domain::new([0.0; 3], [1.0; 3], [true; 3]).unwrap()
    }

    fn channel() -> Domain {
        Domain::new([-1.0, 0.0, 0.0], [1.0, 1.0, 1.5], [true, false, true]).unwrap()
    }

    #[test]
    fn a_shaken_lattice_reaches_fractions_sequential_addition_does_not() {
        // 49 spheres of radius 1 at a volume fraction of 0.2 between walls 16 apart, periodic
        // 8 x 8: exclusion fraction 0.33 with a gap of 1/4 and a wall distance of 5/8 (two and
        // five cells at 8 cells per radius).
        let dom = Domain::new([0.0, 0.0, -8.0], [8.0, 8.0, 8.0], [true, true, false]).unwrap();
        let sphere = Prototype::sphere(1.0).unwrap();
        let p = Placement::new(dom, sphere, Target::VolumeFraction(0.2)).gap(0.25).wall_distance(0.625);
        assert!(p.packing_fraction(49) > MAX_PACKING_FRACTION);
        assert!(matches!(p.place(), Err(Error::InvalidParameter { name: "volume_fraction", .. })));
        let shaken = p.clone().method(Method::ShakenLattice { sweeps: 300 }).seed(3);
        let a = shaken.place().unwrap();
        assert_eq!(a.len(), 49);
        assert!((a.volume_fraction() - 0.2004).abs() < 1e-4, "{}", a.volume_fraction());
        assert_valid(&a, 0.25, 0.625);
        assert_eq!(a, shaken.place().unwrap());
        assert_ne!(a.centers(), shaken.clone().seed(4).place().unwrap().centers());
        // The moves carry the capsules off the lattice: no two share a row along x any more.
        let unshaken = shaken.clone().method(Method::ShakenLattice { sweeps: 0 }).place().unwrap();
        assert_valid(&unshaken, 0.25, 0.625);
        let rows = |q: &Placed| {
            let mut ys: Vec<f64> = q.centers().iter().map(|c| c[1]).collect();
            ys.sort_by(f64::total_cmp);
            ys.dedup();
            ys.len()
        };
        assert!(rows(&unshaken) <= 8 && rows(&a) == 49, "{} {}", rows(&unshaken), rows(&a));
        // Denser than a lattice of the room holds: refused by name.
        let crowded = Placement::new(dom, sphere, Target::VolumeFraction(0.5))
            .gap(0.25)
            .method(Method::ShakenLattice { sweeps: 10 });
        let err = crowded.place().unwrap_err();
        assert!(matches!(err, Error::InvalidParameter { name: "volume_fraction", .. }), "{err}");
    }

    #[test]
    fn a_seed_gives_one_placement() {
        let cases = [
            Placement::new(periodic_box(), Prototype::sphere(0.08).unwrap(), Target::VolumeFraction(0.2)),
            Placement::new(
                channel(),
                Prototype::red_cell(0.12, Orientation::Random).unwrap(),
                Target::Count(30),
            )
            .wall_distance(0.03),
        ];
        for p in cases {
            let p = p.gap(0.02);
            let a = p.clone().seed(9).place().unwrap();
            let b = p.clone().seed(9).place().unwrap();
            assert_eq!(a, b);
            let c = p.clone().seed(10).place().unwrap();
            assert_eq!(a.len(), c.len());
            assert_ne!(a.centers(), c.centers());
        }
    }

    #[test]
    fn the_placement_of_a_seed_is_pinned() {
        // The same numbers on every machine and in every later version: a change here changes
        // every placement users made from a seed.
        let p = Placement::new(
            channel(),
            Prototype::red_cell(0.12, Orientation::Random).unwrap(),
            Target::Count(5),
        )
        .gap(0.02)
        .wall_distance(0.03)
        .seed(2024);
        let placed = p.place().unwrap();
        let bits: Vec<[u64; 3]> = placed.centers().iter().map(|c| c.map(f64::to_bits)).collect();
        let axis: Vec<u64> = placed.rotations().iter().map(|r| r.matrix()[1][0].to_bits()).collect();
        assert_eq!(bits, PINNED_CENTERS);
        assert_eq!(axis, PINNED_AXIS_Y);
        assert_eq!(placed.attempts(), PINNED_ATTEMPTS);
    }

    #[test]
    fn spheres_clear_each_other_and_the_walls() {
        let (gap, wall) = (0.03, 0.05);
        for (dom, seed) in [(periodic_box(), 1), (channel(), 2)] {
            let p = Placement::new(dom, Prototype::sphere(0.07).unwrap(), Target::VolumeFraction(0.12))
                .gap(gap)
                .wall_distance(wall)
                .seed(seed);
            let placed = p.place().unwrap();
            assert_valid(&placed, gap, wall);
            assert!(placed.rotations().iter().all(|r| *r == Rotation::IDENTITY));
        }
        // Walls on every axis.
        let walled = Domain::new([0.0; 3], [1.0, 0.8, 0.6], [false; 3]).unwrap();
        let placed = Placement::new(walled, Prototype::sphere(0.06).unwrap(), Target::Count(40))
            .gap(gap)
            .wall_distance(wall)
            .place()
            .unwrap();
        assert_valid(&placed, gap, wall);
    }

    #[test]
    fn turned_red_cells_clear_each_other_and_the_walls() {
        let (gap, wall) = (0.02, 0.04);
        let proto = Prototype::red_cell(0.15, Orientation::Random).unwrap();
        assert_eq!(proto.bounding_radius(), 0.15);
        let placed = Placement::new(channel(), proto, Target::VolumeFraction(0.08))
            .gap(gap)
            .wall_distance(wall)
            .seed(4)
            .place()
            .unwrap();
        assert_valid(&placed, gap, wall);
        let rs = placed.rotations();
        assert!(rs.iter().skip(1).all(|r| *r != rs[0]), "random orientations");
        // Some cells lie flatter against the walls than their bounding sphere would allow.
        let near = placed.centers().iter().filter(|c| c[1].min(1.0 - c[1]) < 0.15 + wall).count();
        assert!(near > 0);
        // The shapes: turned cells, their axes the rotations' first columns.
        let shapes = placed.shapes().unwrap();
        for ((s, c), r) in shapes.iter().zip(placed.centers()).zip(rs) {
            assert_eq!(s.center(), Some(*c));
            let pole = r.apply([0.5 * 0.15 * 0.35, 0.0, 0.0]);
            assert!(s.signed_distance([c[0] + pole[0], c[1] + pole[1], c[2] + pole[2]]).abs() < 1e-12);
        }
        // A fixed orientation: every cell flat in the xz-plane (axis along y), walls at y = 0, 1.
        let flat = Rotation::about_axis([0.0, 0.0, 1.0], PI / 2.0).unwrap();
        let proto = Prototype::red_cell(0.15, Orientation::Fixed(flat)).unwrap();
        let e = proto.extent(&flat, 1);
        // Half the largest thickness, (a / 2) max f(s) sqrt(1 - s) = 0.379831 a, and the margin.
        assert!((0.15 * 0.379831..=0.15 * (0.379832 + 3e-3)).contains(&e), "{e}");
        let placed =
            Placement::new(channel(), proto, Target::Count(12)).gap(gap).wall_distance(wall).place().unwrap();
        assert_valid(&placed, gap, wall);
        assert!(placed.rotations().iter().all(|r| *r == flat));
    }

    #[test]
    fn the_extent_bounds_the_surface_tightly() {
        let proto = Prototype::red_cell(1.0, Orientation::Random).unwrap();
        let mut rng = Xoshiro256StarStar::new(8);
        for _ in 0..50 {
            let r = Rotation::random(&mut rng);
            for d in 0..3 {
                let e = proto.extent(&r, d);
                // The largest coordinate over a dense sampling of the surface.
                let mut m = f64::NEG_INFINITY;
                for it in 0..=2000 {
                    let t = PI * it as f64 / 2000.0;
                    let s = t.sin() * t.sin();
                    let x = 0.5 * (0.35 + 2.003 * s - 1.123 * s * s) * t.cos();
                    // Over the parallel: x u_d + sin t * |(row d of R) without the axis part|.
                    let row = r.matrix()[d];
                    let ortho = (row[1] * row[1] + row[2] * row[2]).sqrt();
                    m = m.max(x * row[0] + t.sin() * ortho);
                }
                assert!((m..=m + 3e-3).contains(&e), "{e} against {m}");
                assert!(proto.wall_extent(d) <= e);
            }
        }
    }

    #[test]
    fn the_volume_fraction_is_the_count_times_the_volume_over_the_box() {
        let dom = Domain::new([0.0; 3], [1.2, 1.0, 0.9], [true, false, true]).unwrap();
        for proto in
            [Prototype::sphere(0.05).unwrap(), Prototype::red_cell(0.08, Orientation::Random).unwrap()]
        {
            let phi = 0.07;
            let p = Placement::new(dom, proto, Target::VolumeFraction(phi)).gap(0.01).wall_distance(0.01);
            let placed = p.place().unwrap();
            let k = placed.len();
            assert_eq!(k, p.count().unwrap());
            let exact = k as f64 * proto.volume() / (1.2 * 1.0 * 0.9);
            assert!((placed.volume_fraction() - exact).abs() <= 4.0 * f64::EPSILON * exact);
            // Within half a capsule of the target.
            assert!((placed.volume_fraction() - phi).abs() <= 0.5 * proto.volume() / dom.volume() + 1e-15);
            let shapes = placed.shapes().unwrap();
            let sum: f64 = shapes.iter().map(|s| s.volume().unwrap()).sum();
            assert!((sum / dom.volume() - exact).abs() <= 1e-14);
        }
        let v = Prototype::sphere(0.1).unwrap().volume();
        assert!((v - 4.0 / 3.0 * PI * 1e-3).abs() < 1e-18);
    }

    #[test]
    fn unreachable_fractions_and_bad_parameters_are_refused() {
        let sphere = Prototype::sphere(0.05).unwrap();
        let place = |t: Target| Placement::new(periodic_box(), sphere, t);
        let name = |r: Result<Placed>| match r {
            Err(Error::InvalidParameter { name, value, .. }) => (name, value),
            other => panic!("{other:?}"),
        };
        // Above the limit.
        let (n, v) = name(place(Target::VolumeFraction(0.35)).place());
        assert_eq!(n, "volume_fraction");
        assert!(v.contains("exclusion fraction 0.3"), "{v}");
        // Below the limit, but not with this gap.
        let (n, _) = name(place(Target::VolumeFraction(0.25)).gap(0.02).place());
        assert_eq!(n, "volume_fraction");
        // A count above the limit.
        let k = (0.33 / sphere.volume()).ceil() as usize;
        assert_eq!(name(place(Target::Count(k)).place()).0, "count");
        // Attempts run out: the error says how many were placed.
        let (n, v) = name(place(Target::VolumeFraction(0.25)).attempts_per_capsule(2).place());
        assert_eq!(n, "volume_fraction");
        assert!(
            v.contains("capsules placed in")
                && v.contains(&format!("of {} capsules", (0.25 / sphere.volume()).round())),
            "{v}"
        );
        // Bad values.
        assert_eq!(name(place(Target::Count(0)).place()).0, "count");
        assert_eq!(name(place(Target::VolumeFraction(f64::NAN)).place()).0, "volume_fraction");
        assert_eq!(name(place(Target::VolumeFraction(1e-9)).place()).0, "volume_fraction");
        assert_eq!(name(place(Target::Count(3)).gap(-1.0).place()).0, "gap");
        assert_eq!(name(place(Target::Count(3)).wall_distance(f64::INFINITY).place()).0, "wall_distance");
        assert_eq!(name(place(Target::Count(3)).attempts_per_capsule(0).place()).0, "attempts_per_capsule");
        // A box a capsule does not fit in.
        let thin = Domain::new([0.0; 3], [1.0, 1.0, 0.08], [true; 3]).unwrap();
        assert_eq!(name(Placement::new(thin, sphere, Target::Count(1)).place()).0, "Domain");
        let slab = Domain::new([0.0; 3], [1.0, 1.0, 0.15], [true, true, false]).unwrap();
        assert_eq!(
            name(Placement::new(slab, sphere, Target::Count(1)).wall_distance(0.03).place()).0,
            "Domain"
        );
        assert!(Domain::new([0.0; 3], [1.0, 0.0, 1.0], [true; 3]).is_err());
        assert!(Prototype::sphere(-1.0).is_err());
        assert!(Prototype::red_cell(f64::NAN, Orientation::Random).is_err());
    }

    #[test]
    fn a_grid_gives_the_box() {
        use crate::grid::Boundary;
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[2] = [Boundary::wall(), Boundary::wall()];
        let g = Grid::<f32>::new([8, 8, 8], [0.0; 3], [1.0, 2.0, 0.5], bc).unwrap();
        let d = Domain::from_grid(&g);
        assert_eq!(d.periodic(), [true, true, false]);
        assert_eq!(d.upper(), [1.0, 2.0, 0.5]);
        assert!((d.volume() - 1.0).abs() < 1e-15);
        let s = d.separation([0.05, 0.1, 0.05], [0.95, 1.95, 0.45]);
        assert!((s[0] + 0.1).abs() < 1e-12 && (s[1] + 0.15).abs() < 1e-12 && (s[2] - 0.4).abs() < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// Up to the limit, any seed places every capsule, apart and clear of the walls: spheres
        /// or turned red cells, in a periodic cube, a channel, a closed box or a thin periodic
        /// slab.
        #[test]
        fn placements_succeed_up_to_the_limit(
            seed in any::<u64>(),
            share in 0.05f64..=1.0,
            geometry in 0usize..4,
            cells in any::<bool>(),
            gap in 0.0f64..0.02,
        ) {
            let dom = match geometry {
                0 => periodic_box(),
                1 => channel(),
                2 => Domain::new([0.0; 3], [1.0, 0.8, 0.9], [false; 3]).unwrap(),
                _ => Domain::new([0.0; 3], [1.0, 1.0, 0.4], [true; 3]).unwrap(),
            };
            let proto = if cells {
                Prototype::red_cell(0.08, Orientation::Random).unwrap()
            } else {
                Prototype::sphere(0.06).unwrap()
            };
            let wall = 0.01;
            let p = Placement::new(dom, proto, Target::Count(1)).gap(gap).wall_distance(wall).seed(seed);
            // The count whose exclusion fraction is `share` of the limit.
            let k = ((share * MAX_PACKING_FRACTION / p.packing_fraction(1)).floor() as usize).max(1);
            let p = Placement { target: Target::Count(k), ..p };
            prop_assert!(p.packing_fraction(k) <= MAX_PACKING_FRACTION);
            let placed = p.place().unwrap();
            prop_assert_eq!(placed.len(), k);
            prop_assert!(placed.attempts() <= 1000 * k, "{} attempts for {k}", placed.attempts());
            assert_valid(&placed, gap, wall);
        }
    }
}
