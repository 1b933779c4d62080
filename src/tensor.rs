//! Small fixed-size vectors and symmetric tensors at a point.
//!
//! A symmetric second-order tensor `A` is stored as its six independent components in the order
//! of the paper's Appendix B, `A' = (A11, A22, A33, A12, A23, A31)` ([`XX`], [`YY`], [`ZZ`],
//! [`XY`], [`YZ`], [`ZX`]). The stored off-diagonal entries are the tensor components themselves
//! (no factor two): `A' = (A11, A22, A33, A12, A23, A31)` with `A12 = A21`, and so on.

use crate::Real;

/// A 3-vector.
pub type Vec3<T> = [T; 3];
/// A general 3x3 tensor, row-major: `m[i][j]`.
pub type Mat3<T> = [[T; 3]; 3];
/// A symmetric 3x3 tensor in the component order of Appendix B (see the module docs).
pub type Sym<T> = [T; 6];

/// Index of A11 in [`Sym`].
pub const XX: usize = 0;
/// Index of A22 in [`Sym`].
pub const YY: usize = 1;
/// Index of A33 in [`Sym`].
pub const ZZ: usize = 2;
/// Index of A12 in [`Sym`].
pub const XY: usize = 3;
/// Index of A23 in [`Sym`].
pub const YZ: usize = 4;
/// Index of A31 in [`Sym`].
pub const ZX: usize = 5;

/// The (row, column) pair of each [`Sym`] component.
pub const SYM_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];

/// Index in [`Sym`] of the component (i, j), for any order of i and j.
#[inline]
pub const fn sym_index(i: usize, j: usize) -> usize {
    const T: [[usize; 3]; 3] = [[XX, XY, ZX], [XY, YY, YZ], [ZX, YZ, ZZ]];
    T[i][j]
}

/// Expands a symmetric tensor to a full 3x3 matrix.
#[inline]
pub fn sym_to_mat<T: Real>(a: &Sym<T>) -> Mat3<T> {
    [[a[XX], a[XY], a[ZX]], [a[XY], a[YY], a[YZ]], [a[ZX], a[YZ], a[ZZ]]]
}

/// Symmetric part of a full matrix, as a [`Sym`].
#[inline]
pub fn mat_to_sym<T: Real>(m: &Mat3<T>) -> Sym<T> {
    let h = T::lit(0.5);
    [m[0][0], m[1][1], m[2][2], h * (m[0][1] + m[1][0]), h * (m[1][2] + m[2][1]), h * (m[2][0] + m[0][2])]
}

/// The identity as a [`Sym`].
#[inline]
pub fn identity<T: Real>() -> Sym<T> {
    let (o, z) = (T::one(), T::zero());
    [o, o, o, z, z, z]
}

/// The surface projector `P = I - n n` for a unit normal `n`.
#[inline]
pub fn projector<T: Real>(n: &Vec3<T>) -> Sym<T> {
    let o = T::one();
    [o - n[0] * n[0], o - n[1] * n[1], o - n[2] * n[2], -n[0] * n[1], -n[1] * n[2], -n[2] * n[0]]
}

/// Trace of a symmetric tensor.
#[inline]
pub fn trace<T: Real>(a: &Sym<T>) -> T {
    a[XX] + a[YY] + a[ZZ]
}

/// Double contraction `A : B` of two symmetric tensors.
#[inline]
pub fn ddot<T: Real>(a: &Sym<T>, b: &Sym<T>) -> T {
    let two = T::lit(2.0);
    a[XX] * b[XX] + a[YY] * b[YY] + a[ZZ] * b[ZZ] + two * (a[XY] * b[XY] + a[YZ] * b[YZ] + a[ZX] * b[ZX])
}

/// Product `A B` of two full matrices.
#[inline]
pub fn matmul<T: Real>(a: &Mat3<T>, b: &Mat3<T>) -> Mat3<T> {
    let mut c = [[T::zero(); 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}

/// Transpose of a full matrix.
#[inline]
pub fn transpose<T: Real>(a: &Mat3<T>) -> Mat3<T> {
    let mut t = *a;
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = a[j][i];
        }
    }
    t
}

/// `P A P` for symmetric `P` and `A` (the in-plane part of `A`, e.g. `B_s = P G_s P`, (2.18)).
#[inline]
pub fn project<T: Real>(p: &Sym<T>, a: &Sym<T>) -> Sym<T> {
    let pm = sym_to_mat(p);
    mat_to_sym(&matmul(&matmul(&pm, &sym_to_mat(a)), &pm))
}

/// Tensor-vector product `A v` for symmetric `A`.
#[inline]
pub fn sym_mul_vec<T: Real>(a: &Sym<T>, v: &Vec3<T>) -> Vec3<T> {
    [
        a[XX] * v[0] + a[XY] * v[1] + a[ZX] * v[2],
        a[XY] * v[0] + a[YY] * v[1] + a[YZ] * v[2],
        a[ZX] * v[0] + a[YZ] * v[1] + a[ZZ] * v[2],
    ]
}

/// Dot product of two vectors.
#[inline]
pub fn dot<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product `a x b`.
#[inline]
pub fn cross<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> Vec3<T> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The skew matrix `[a]_x` with `[a]_x y = a x y`.
#[inline]
pub fn skew<T: Real>(a: &Vec3<T>) -> Mat3<T> {
    let z = T::zero();
    [[z, -a[2], a[1]], [a[2], z, -a[0]], [-a[1], a[0], z]]
}

/// The rotation `R` of least angle with `R from = to`, for unit vectors at most 60 degrees
/// apart (`from . to >= 1/2`); `None` otherwise (also for a zero vector). Rodrigues' formula
/// `R = I + [w]_x + [w]_x^2 / (1 + c)` with `w = from x to`, `c = from . to`.
#[inline]
pub fn rotation_taking<T: Real>(from: &Vec3<T>, to: &Vec3<T>) -> Option<Mat3<T>> {
    let c = dot(from, to);
    // Also refuses a NaN.
    if c.partial_cmp(&T::lit(0.5)).is_none_or(|o| o == std::cmp::Ordering::Less) {
        return None;
    }
    let k = skew(&cross(from, to));
    let k2 = matmul(&k, &k);
    let f = T::one() / (T::one() + c);
    let i3 = sym_to_mat(&identity::<T>());
    Some(std::array::from_fn(|i| std::array::from_fn(|j| i3[i][j] + k[i][j] + f * k2[i][j])))
}

/// `R A R^T` for a rotation `R` and a symmetric `A`.
#[inline]
pub fn rotate<T: Real>(r: &Mat3<T>, a: &Sym<T>) -> Sym<T> {
    mat_to_sym(&matmul(&matmul(r, &sym_to_mat(a)), &transpose(r)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_taking_maps_one_normal_and_its_projector_onto_the_other() {
        let norm = |v: [f64; 3]| {
            let l = dot(&v, &v).sqrt();
            v.map(|x| x / l)
        };
        let (a, b) = (norm([0.3, -0.2, 0.9]), norm([0.1, 0.4, 0.8]));
        let r = rotation_taking(&a, &b).unwrap();
        let rt = transpose(&r);
        let ra = [0, 1, 2].map(|i| dot(&r[i], &a));
        for i in 0..3 {
            assert!((ra[i] - b[i]).abs() < 1e-14, "{ra:?} {b:?}");
            for j in 0..3 {
                let rrt = dot(&r[i], &[rt[0][j], rt[1][j], rt[2][j]]);
                assert!((rrt - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        let (pa, pb) = (rotate(&r, &projector(&a)), projector(&b));
        assert!(pa.iter().zip(&pb).all(|(x, y)| (x - y).abs() < 1e-14), "{pa:?} {pb:?}");
        // The least rotation turns nothing about the common normal of the two.
        let axis = norm(cross(&a, &b));
        let ra = [0, 1, 2].map(|i| dot(&r[i], &axis));
        assert!(ra.iter().zip(&axis).all(|(x, y)| (x - y).abs() < 1e-14));
        assert!(rotation_taking(&a, &[-a[0], -a[1], -a[2]]).is_none());
        assert!(rotation_taking(&a, &[0.0; 3]).is_none());
    }

    #[test]
    fn projector_annihilates_normal_and_is_idempotent() {
        let n: [f64; 3] = [0.6, 0.0, 0.8];
        let p = projector(&n);
        let pn = sym_mul_vec(&p, &n);
        assert!(pn.iter().all(|x| x.abs() < 1e-15));
        let pp = project(&p, &identity::<f64>());
        assert!(pp.iter().zip(&p).all(|(a, b)| (a - b).abs() < 1e-15));
        assert!((trace(&p) - 2.0).abs() < 1e-15);
    }

    #[test]
    fn sym_index_matches_pairs() {
        for (c, &(i, j)) in SYM_PAIRS.iter().enumerate() {
            assert_eq!(sym_index(i, j), c);
            assert_eq!(sym_index(j, i), c);
        }
    }
}
