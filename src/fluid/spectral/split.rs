//! The direct solve on a part of a decomposed grid ([`Grid::split`]): the same operator and
//! closures as the whole grid's, distributed by one transpose.
//!
//! A part holds a slab along the split axis `s` (layout A). It transforms along the other
//! periodic axes, which it holds whole; an all-to-all exchange then gives each part a slab
//! along another periodic axis `t` (layout B: `s` whole), where it transforms along `s` and
//! inverts the modes (a division per mode, or the Thomas solves along the wall axis, which is
//! whole in both layouts); the way back mirrors it. `t` is periodic, so a grid with a wall
//! needs two periodic axes (which the whole-grid solver needs as well). Each 1D transform
//! and line solve is the whole grid's, in another order of the axes: the result agrees with
//! the whole grid's to round-off (`tests/decomposition.rs`).

use super::{
    AxisKind, Closure, Modes, eliminate_row, from_lines, gather, scatter, solve_line, substitute_row,
    to_lines,
};
use crate::grid::{Decomposition, Exchange, Grid};
use crate::{Error, Real, Result};
use rustfft::Fft;
use rustfft::num_complex::Complex;
use std::sync::Arc;

/// One of the two layouts: a slab along `axis` of `dims` cells starting at global `offset`.
struct Layout {
    dims: [usize; 3],
    offset: [usize; 3],
    /// Every part's `(first, count)` along `axis`.
    ranges: Vec<(usize, usize)>,
    axis: usize,
}

impl Layout {
    fn new(n: [usize; 3], axis: usize, part: usize, parts: usize) -> Result<Self> {
        let d = Decomposition::slabs(axis, parts)?;
        let ranges: Vec<_> = (0..parts).map(|p| d.range(n[axis], p)).collect();
        let (mut dims, mut offset) = (n, [0; 3]);
        (offset[axis], dims[axis]) = ranges[part];
        Ok(Layout { dims, offset, ranges, axis })
    }

    fn len(&self) -> usize {
        self.dims.iter().product()
    }
}

/// The distributed solver of one part (see the module docs).
pub(super) struct SplitSolve<T: Real> {
    n: [usize; 3],
    h: [T; 3],
    kinds: [AxisKind; 3],
    wall: Option<usize>,
    modes: Modes<T>,
    exchange: Arc<dyn Exchange>,
    la: Layout,
    lb: Layout,
    /// Layout A (the grid's slab) and a second array for the paired blended solves.
    a: Vec<Complex<T>>,
    a2: Vec<Complex<T>>,
    /// Layout B and a second array for the blended solves.
    b: Vec<Complex<T>>,
    b2: Vec<Complex<T>>,
    lines: Vec<Complex<T>>,
    fft_scratch: Vec<Complex<T>>,
    /// The eliminated upper diagonals of the Thomas solves (layout B).
    cp: Vec<T>,
    send: Vec<f64>,
    recv: Vec<f64>,
}

impl<T: Real> SplitSolve<T> {
    /// The solver of `grid`'s part, for the closures `kinds` (at most one wall axis, checked by
    /// the caller). Errors: no periodic axis besides the split one; an axis to transpose to
    /// with fewer cells than parts.
    pub(super) fn new(grid: &Grid<T>, kinds: [AxisKind; 3], wall: Option<usize>) -> Result<Self> {
        let part = grid.part().expect("a split grid has a part");
        let (s, exchange) = (part.axis, part.exchange.clone());
        let (me, parts) = (exchange.part(), exchange.parts());
        let n = grid.global_cells();
        let Some(t) = (0..3).filter(|&a| a != s && kinds[a] == AxisKind::Periodic).max_by_key(|&a| n[a])
        else {
            return Err(Error::Unsupported {
                component: "SpectralSolver",
                detail: "a decomposed grid without a second periodic axis: the transpose needs one".into(),
            });
        };
        if n[t] < parts {
            return Err(Error::invalid(
                "Decomposition parts",
                format!("{parts} parts, {} cells along axis {t}", n[t]),
                "at most as many parts as cells along the axis the solver transposes to",
            ));
        }
        let (la, lb) = (Layout::new(n, s, me, parts)?, Layout::new(n, t, me, parts)?);
        let h = grid.h();
        let modes = Modes::new(n, h);
        let scratch = (0..3).map(|a| modes.scratch_len(a)).max();
        let longest = la.len().max(lb.len());
        Ok(SplitSolve {
            n,
            h,
            kinds,
            wall,
            modes,
            exchange,
            a: vec![Complex::default(); la.len()],
            a2: Vec::new(),
            b: vec![Complex::default(); lb.len()],
            b2: Vec::new(),
            lines: vec![Complex::default(); longest],
            fft_scratch: vec![Complex::default(); scratch.unwrap_or(0)],
            cp: vec![T::zero(); if wall.is_some() { lb.len() } else { 0 }],
            send: Vec::with_capacity(2 * longest),
            recv: vec![0.0; 2 * longest],
            la,
            lb,
        })
    }

    /// Solves for `b -> x` (and `b2 -> x2` packed as the imaginary part) as
    /// `SpectralSolver::solve` does.
    pub(super) fn solve(
        &mut self,
        grid: &Grid<T>,
        sigma: T,
        c: T,
        b: [Option<&[T]>; 2],
        x: [Option<&mut [T]>; 2],
    ) {
        gather(grid, &mut self.a, b[0].expect("a right-hand side"), b[1]);
        self.forward();
        self.invert(false, sigma, c);
        let scale = self.inverse(false, false);
        let [x1, x2] = x;
        scatter(grid, &self.a, scale, x1.expect("a solution"), x2);
    }

    /// `SpectralSolver::solve_blended`: `x = w x_0 + (1 - w) x_1` for the coefficients `c`.
    pub(super) fn solve_blended(
        &mut self,
        grid: &Grid<T>,
        sigma: T,
        c: [T; 2],
        w: &[T],
        b: &[T],
        x: &mut [T],
    ) {
        gather(grid, &mut self.a, b, None);
        self.forward();
        self.b2.clone_from(&self.b);
        self.invert(false, sigma, c[0]);
        self.invert(true, sigma, c[1]);
        // x_0 + i x_1 (both real for a real right-hand side).
        for (v, v2) in self.b.iter_mut().zip(&self.b2) {
            *v = Complex::new(v.re - v2.im, v.im + v2.re);
        }
        let scale = self.inverse(false, false);
        let [nx, ny, _] = self.la.dims;
        for (j, k, base) in rows(grid) {
            let line = &self.a[(j + ny * k) * nx..][..nx];
            for (i, r) in line.iter().enumerate() {
                let wi = w[base + i];
                x[base + i] = scale * (wi * r.re + (T::one() - wi) * r.im);
            }
        }
    }

    /// `SpectralSolver::solve_pair_blended`.
    pub(super) fn solve_pair_blended(
        &mut self,
        grid: &Grid<T>,
        sigma: T,
        c: [T; 2],
        w: [&[T]; 2],
        b: [&[T]; 2],
        x: [&mut [T]; 2],
    ) {
        gather(grid, &mut self.a, b[0], Some(b[1]));
        self.forward();
        self.b2.clone_from(&self.b);
        self.invert(false, sigma, c[0]);
        self.invert(true, sigma, c[1]);
        let scale = self.inverse(true, true);
        self.inverse(false, false);
        let [nx, ny, _] = self.la.dims;
        let [x1, x2] = x;
        for (j, k, base) in rows(grid) {
            let range = (j + ny * k) * nx..(j + ny * k + 1) * nx;
            let (hi, lo) = (&self.a[range.clone()], &self.a2[range]);
            for i in 0..nx {
                let (u, v) = (w[0][base + i], w[1][base + i]);
                x1[base + i] = scale * (u * hi[i].re + (T::one() - u) * lo[i].re);
                x2[base + i] = scale * (v * hi[i].im + (T::one() - v) * lo[i].im);
            }
        }
    }

    /// Layout A's array to layout B's, transformed along every periodic axis.
    fn forward(&mut self) {
        let (s, dims) = (self.la.axis, self.la.dims);
        for ax in (0..3).filter(|&a| a != s && self.kinds[a] == AxisKind::Periodic) {
            fft(&mut self.a, &mut self.lines, dims, ax, &*self.modes.fwd[ax], &mut self.fft_scratch);
        }
        self.transpose(true);
        fft(&mut self.b, &mut self.lines, self.lb.dims, s, &*self.modes.fwd[s], &mut self.fft_scratch);
    }

    /// The inverse transforms of layout B's array (`b2` where `second`) into layout A's (`a2`
    /// where `into_second`); returns the normalisation still to apply.
    fn inverse(&mut self, second: bool, into_second: bool) -> T {
        let s = self.la.axis;
        if second {
            std::mem::swap(&mut self.b, &mut self.b2);
        }
        fft(&mut self.b, &mut self.lines, self.lb.dims, s, &*self.modes.inv[s], &mut self.fft_scratch);
        self.transpose(false);
        for ax in (0..3).filter(|&a| a != s && self.kinds[a] == AxisKind::Periodic) {
            fft(&mut self.a, &mut self.lines, self.la.dims, ax, &*self.modes.inv[ax], &mut self.fft_scratch);
        }
        if second {
            std::mem::swap(&mut self.b, &mut self.b2);
        }
        if into_second {
            self.a2.clone_from(&self.a);
        }
        let periodic = (0..3).filter(|&a| self.kinds[a] == AxisKind::Periodic);
        T::one() / periodic.map(|a| T::from_usize(self.n[a]).unwrap()).fold(T::one(), |p, q| p * q)
    }

    /// Moves layout A's array into layout B's (`to_b`) or back, through one all-to-all.
    fn transpose(&mut self, to_b: bool) {
        let (la, lb) = (&self.la, &self.lb);
        let me = self.exchange.part();
        let parts = self.exchange.parts();
        // The block part `p` holds in A and part `q` in B: A's slab of `p` along `s` crossed
        // with B's slab of `q` along `t`.
        let block = |p: usize, q: usize| -> ([usize; 3], [usize; 3]) {
            let (mut lo, mut hi) = ([0; 3], self.n);
            (lo[la.axis], hi[la.axis]) = (la.ranges[p].0, la.ranges[p].0 + la.ranges[p].1);
            (lo[lb.axis], hi[lb.axis]) = (lb.ranges[q].0, lb.ranges[q].0 + lb.ranges[q].1);
            (lo, hi)
        };
        let size = |(lo, hi): ([usize; 3], [usize; 3])| 2 * (0..3).map(|a| hi[a] - lo[a]).product::<usize>();
        let (from, from_layout, to_layout) = if to_b { (&self.a, la, lb) } else { (&self.b, lb, la) };
        // What this part sends to `q`, and receives from `p`, in the same cell order.
        let out_block = |q: usize| if to_b { block(me, q) } else { block(q, me) };
        let in_block = |p: usize| if to_b { block(p, me) } else { block(me, p) };
        self.send.clear();
        let mut send_counts = Vec::with_capacity(parts);
        for q in 0..parts {
            let (lo, hi) = out_block(q);
            send_counts.push(size((lo, hi)));
            for_runs(lo, hi, |g, len| {
                let at = index(from_layout, g);
                for v in &from[at..at + len] {
                    self.send.extend([v.re.f64(), v.im.f64()]);
                }
            });
        }
        let recv_counts: Vec<usize> = (0..parts).map(|p| size(in_block(p))).collect();
        let total: usize = recv_counts.iter().sum();
        self.exchange.all_to_all(&self.send, &send_counts, &mut self.recv[..total], &recv_counts);
        let to = if to_b { &mut self.b } else { &mut self.a };
        let mut at = 0;
        for p in 0..parts {
            let (lo, hi) = in_block(p);
            for_runs(lo, hi, |g, len| {
                let start = index(to_layout, g);
                for (v, pair) in
                    to[start..start + len].iter_mut().zip(self.recv[at..at + 2 * len].chunks_exact(2))
                {
                    *v = Complex::new(T::lit(pair[0]), T::lit(pair[1]));
                }
                at += 2 * len;
            });
        }
    }

    /// Inverts the operator on layout B's array (`b2` where `second`).
    fn invert(&mut self, second: bool, sigma: T, c: T) {
        let (lb, lam) = (&self.lb, &self.modes.lambda);
        let data = if second { &mut self.b2 } else { &mut self.b };
        let d = lb.dims;
        let shift = |g: [usize; 3], skip: Option<usize>| {
            sigma
                + c * (0..3).filter(|&a| Some(a) != skip).map(|a| lam[a][g[a]]).fold(T::zero(), |p, q| p + q)
        };
        match self.wall {
            None => {
                for_cells([0; 3], d, |l| {
                    let g = std::array::from_fn(|a| l[a] + lb.offset[a]);
                    let den = shift(g, None);
                    let v = &mut data[l[0] + d[0] * (l[1] + d[1] * l[2])];
                    *v = if den > T::zero() { *v / den } else { Complex::default() };
                });
            }
            Some(w) => {
                let closure = Closure { e: c / (self.h[w] * self.h[w]), kind: self.kinds[w] };
                let (o, cp) = (lb.offset, &mut self.cp);
                if w == 0 {
                    // Lines along x are contiguous: one Thomas solve per line.
                    for (row, line) in data.chunks_mut(d[0]).enumerate() {
                        let (j, k) = (row % d[1] + o[1], row / d[1] + o[2]);
                        solve_line(line, &mut cp[..d[0]], shift([0, j, k], Some(0)), closure);
                    }
                    return;
                }
                // A wall in y or z: the recurrence runs across x-rows, each row `d[0]`
                // independent systems (as the whole grid's solver does).
                let (other, st) = (3 - w, [1, d[0], d[0] * d[1]]);
                let (len, nx) = (d[w], d[0]);
                for q in 0..d[other] {
                    let row = |m: usize| q * st[other] + m * st[w];
                    let shift_row = |m: usize| {
                        let mut g = [0, 0, 0];
                        (g[other], g[w]) = (q + o[other], m + o[w]);
                        move |i: usize| shift([i + o[0], g[1], g[2]], Some(w))
                    };
                    for m in 0..len {
                        let base = row(m);
                        let (done, rest) = data.split_at_mut(base);
                        let (cdone, crest) = cp.split_at_mut(base);
                        let prev = (m > 0).then(|| {
                            let p = row(m - 1);
                            (&done[p..p + nx], &cdone[p..p + nx])
                        });
                        eliminate_row(&mut rest[..nx], &mut crest[..nx], prev, m, len, closure, shift_row(m));
                    }
                    for m in (0..len - 1).rev() {
                        let (base, next) = (row(m), row(m + 1));
                        let (head, tail) = data.split_at_mut(next);
                        substitute_row(&mut head[base..base + nx], &tail[..nx], &cp[base..base + nx]);
                    }
                }
            }
        }
    }
}

/// The index in a layout's array of global cell `g`.
fn index(l: &Layout, g: [usize; 3]) -> usize {
    let c: [usize; 3] = std::array::from_fn(|a| g[a] - l.offset[a]);
    c[0] + l.dims[0] * (c[1] + l.dims[1] * c[2])
}

/// Calls `f(first cell, length)` on every x-run of `[lo, hi)`, the runs in storage order.
fn for_runs(lo: [usize; 3], hi: [usize; 3], mut f: impl FnMut([usize; 3], usize)) {
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            f([lo[0], j, k], hi[0] - lo[0]);
        }
    }
}

/// Calls `f` on every cell of `[lo, hi)`, x fastest.
fn for_cells(lo: [usize; 3], hi: [usize; 3], mut f: impl FnMut([usize; 3])) {
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            for i in lo[0]..hi[0] {
                f([i, j, k]);
            }
        }
    }
}

/// Transforms `data` (of `dims`, x fastest) along `axis`, whole in it.
fn fft<T: Real>(
    data: &mut [Complex<T>],
    lines: &mut [Complex<T>],
    dims: [usize; 3],
    axis: usize,
    plan: &dyn Fft<T>,
    scratch: &mut [Complex<T>],
) {
    let len = data.len();
    if dims[axis] == 1 || len == 0 {
        return;
    }
    if axis == 0 {
        plan.process_with_scratch(data, scratch);
        return;
    }
    let lines = &mut lines[..len];
    to_lines(data, lines, dims, axis);
    plan.process_with_scratch(lines, scratch);
    from_lines(lines, data, dims, axis);
}

/// The interior rows of `grid`: `(j, k, storage index of cell (0, j, k))`.
fn rows<T: Real>(grid: &Grid<T>) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
    let [_, ny, nz] = grid.n();
    (0..nz).flat_map(move |k| (0..ny).map(move |j| (j, k, grid.idx_u(0, j, k))))
}
