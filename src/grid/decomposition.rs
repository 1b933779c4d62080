//! Domain decomposition: the grid's cells split into slabs along one axis, one slab per *part*
//! (an MPI rank, or a thread of one process), each part storing its slab with the usual ghost
//! layers.
//!
//! A part's grid ([`Grid::split`]) is a grid like any other, whose cells are its slab: kernels
//! run on it unchanged. What differs is where its ghost layers come from along the split axis:
//! the one ghost-filling routine ([`Field::fill_ghosts`](super::Field::fill_ghosts) and its
//! vector and tensor forms) takes them from the neighbouring parts through an [`Exchange`], so
//! that after a fill every value a stencil reads is the one the whole grid would hold there,
//! bit for bit (`tests/decomposition.rs`). Sums over the grid add each part's partial sums in
//! part order ([`Grid::sum_over_parts`]), so that a result does not depend on which part
//! finished first.
//!
//! Two exchanges: [`LocalParts`], the parts as threads of one process (no MPI: what the tests
//! and a single-machine study use), and, with the cargo feature `mpi`, `MpiExchange`
//! (`grid::MpiExchange`), the ranks of an MPI communicator through the `mpi` crate.
//!
//! Only a periodic axis is split for now; the flow solvers and capsules refuse a split grid
//! until they are decomposed themselves (docs/architecture.md, "Domain decomposition").

use super::{GHOST, Grid};
use crate::{Error, Real, Result};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

/// How the grid's cells are split: `parts` slabs along `axis`, the first `n % parts` slabs
/// one cell thicker than the others.
///
/// ```
/// use eulermembrane::grid::Decomposition;
///
/// let d = Decomposition::slabs(1, 3)?;
/// // 10 cells along y: slabs of 4, 3 and 3 cells.
/// assert_eq!((0..3).map(|p| d.range(10, p)).collect::<Vec<_>>(), [(0, 4), (4, 3), (7, 3)]);
/// assert!(Decomposition::slabs(3, 2).is_err());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decomposition {
    axis: usize,
    parts: usize,
}

impl Decomposition {
    /// `parts` slabs along `axis` (0, 1 or 2). Errors: another axis, no part.
    pub fn slabs(axis: usize, parts: usize) -> Result<Self> {
        if axis > 2 {
            return Err(Error::invalid("Decomposition axis", axis, "0, 1 or 2"));
        }
        if parts == 0 {
            return Err(Error::invalid("Decomposition parts", parts, "at least 1"));
        }
        Ok(Decomposition { axis, parts })
    }

    /// The split axis.
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// The number of parts.
    pub fn parts(&self) -> usize {
        self.parts
    }

    /// The first cell and the cell count of part `part` of `n` cells along the axis.
    pub fn range(&self, n: usize, part: usize) -> (usize, usize) {
        let (q, r) = (n / self.parts, n % self.parts);
        let first = part * q + part.min(r);
        (first, q + usize::from(part < r))
    }
}

/// What carries values between the parts of a decomposed grid. Every call is collective: all
/// parts make the same calls in the same order (as the ghost filling of a time step does).
/// Values travel as `f64` (exact for the crate's `f32` and `f64` fields).
pub trait Exchange: Send + Sync + std::fmt::Debug {
    /// This part's index, `0..parts()`.
    fn part(&self) -> usize;

    /// The number of parts.
    fn parts(&self) -> usize;

    /// Sends `to_lower` to part `lower` and `to_upper` to part `upper`, and receives into
    /// `from_lower` what part `lower` sent up and into `from_upper` what part `upper` sent
    /// down (a part may be its own neighbour, or both neighbours may be one part).
    fn swap(
        &self,
        lower: usize,
        upper: usize,
        to_lower: &[f64],
        to_upper: &[f64],
        from_lower: &mut [f64],
        from_upper: &mut [f64],
    );

    /// Every part's `mine` (one length on all parts) in part order: `all[p * mine.len()..]`
    /// is part `p`'s.
    fn all_gather(&self, mine: &[f64], all: &mut [f64]);

    /// A personalised exchange: `send` holds one block per part in part order, block `q`
    /// of `send_counts[q]` values for part `q`; `recv` receives one block from each part in
    /// part order, block `q` of `recv_counts[q]` values from part `q` (a transpose of a
    /// distributed array).
    fn all_to_all(&self, send: &[f64], send_counts: &[usize], recv: &mut [f64], recv_counts: &[usize]);
}

/// The parts of a decomposed grid as threads of one process: [`LocalParts::new`] makes one
/// exchange per part, each to be moved to its own thread.
///
/// ```
/// use eulermembrane::grid::{Decomposition, Field, Grid, LocalParts};
/// use std::sync::Arc;
///
/// let grid = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3])?;
/// let d = Decomposition::slabs(2, 2)?;
/// let sums: Vec<f64> = std::thread::scope(|s| {
///     let parts: Vec<_> = LocalParts::new(2)
///         .into_iter()
///         .map(|ex| {
///             let grid = &grid;
///             s.spawn(move || {
///                 let part = grid.split(d, Arc::new(ex)).unwrap();
///                 let mut f = Field::from_cell_fn(&part, |x| x[2]);
///                 f.fill_ghosts(&part); // the slab's z-ghosts come from the other part
///                 part.sum_over_parts([f.interior_sum(&part)])[0]
///             })
///         })
///         .collect();
///     parts.into_iter().map(|p| p.join().unwrap()).collect()
/// });
/// assert_eq!(sums[0], sums[1]); // every part gets the same total
/// assert!((sums[0] - 256.0).abs() < 1e-12); // 512 cells, mean z = 1/2
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug)]
pub struct LocalParts {
    part: usize,
    parts: usize,
    /// `down[q]`: to part `q`, a message sent downwards (its `from_upper`); `up[q]` upwards.
    down: Vec<Sender<Msg>>,
    up: Vec<Sender<Msg>>,
    gather: Vec<Sender<Msg>>,
    blocks: Vec<Sender<Msg>>,
    /// `from_*[q]`: what part `q` sent this part.
    from_down: Vec<Inbox>,
    from_up: Vec<Inbox>,
    from_gather: Vec<Inbox>,
    from_blocks: Vec<Inbox>,
}

impl LocalParts {
    /// One exchange per part, `parts` of them (at least 1), in part order.
    pub fn new(parts: usize) -> Vec<LocalParts> {
        let parts = parts.max(1);
        let [mut down, mut up, mut gather, mut blocks] = [(); 4].map(|_| mesh(parts));
        (0..parts)
            .map(|part| LocalParts {
                part,
                parts,
                down: std::mem::take(&mut down.0[part]),
                up: std::mem::take(&mut up.0[part]),
                gather: std::mem::take(&mut gather.0[part]),
                blocks: std::mem::take(&mut blocks.0[part]),
                from_down: std::mem::take(&mut down.1[part]),
                from_up: std::mem::take(&mut up.1[part]),
                from_gather: std::mem::take(&mut gather.1[part]),
                from_blocks: std::mem::take(&mut blocks.1[part]),
            })
            .collect()
    }
}

/// A message between two parts.
type Msg = Vec<f64>;

/// The receiving end of a channel, shareable between threads.
type Inbox = Mutex<Receiver<Msg>>;

/// A channel for every ordered pair of `parts` parts: `senders[from][to]` and
/// `receivers[to][from]`.
fn mesh(parts: usize) -> (Vec<Vec<Sender<Msg>>>, Vec<Vec<Inbox>>) {
    let mut senders: Vec<Vec<Sender<Msg>>> = (0..parts).map(|_| Vec::with_capacity(parts)).collect();
    let mut receivers: Vec<Vec<Inbox>> = (0..parts).map(|_| Vec::with_capacity(parts)).collect();
    for from in senders.iter_mut() {
        for to in receivers.iter_mut() {
            let (s, r) = channel();
            from.push(s);
            to.push(Mutex::new(r));
        }
    }
    (senders, receivers)
}

/// Takes the next message from `rx` into `out`.
///
/// # Panics
/// If the other part's thread has ended (a part that stopped making the collective calls).
fn receive(rx: &Inbox, out: &mut [f64]) {
    let msg = rx.lock().expect("a part's receiver").recv().expect("the sending part is alive");
    out.copy_from_slice(&msg);
}

impl Exchange for LocalParts {
    fn part(&self) -> usize {
        self.part
    }

    fn parts(&self) -> usize {
        self.parts
    }

    fn swap(
        &self,
        lower: usize,
        upper: usize,
        to_lower: &[f64],
        to_upper: &[f64],
        from_lower: &mut [f64],
        from_upper: &mut [f64],
    ) {
        // Unbounded channels: the sends never block, so the order of the two parts' calls does
        // not matter.
        self.down[lower].send(to_lower.to_vec()).expect("the lower part is alive");
        self.up[upper].send(to_upper.to_vec()).expect("the upper part is alive");
        receive(&self.from_up[lower], from_lower);
        receive(&self.from_down[upper], from_upper);
    }

    fn all_gather(&self, mine: &[f64], all: &mut [f64]) {
        for tx in &self.gather {
            tx.send(mine.to_vec()).expect("every part is alive");
        }
        for (q, rx) in self.from_gather.iter().enumerate() {
            receive(rx, &mut all[q * mine.len()..(q + 1) * mine.len()]);
        }
    }

    fn all_to_all(&self, send: &[f64], send_counts: &[usize], recv: &mut [f64], recv_counts: &[usize]) {
        let mut at = 0;
        for (tx, &count) in self.blocks.iter().zip(send_counts) {
            tx.send(send[at..at + count].to_vec()).expect("every part is alive");
            at += count;
        }
        let mut at = 0;
        for (rx, &count) in self.from_blocks.iter().zip(recv_counts) {
            receive(rx, &mut recv[at..at + count]);
            at += count;
        }
    }
}

/// A part's place in a decomposed grid (held by its [`Grid`]).
#[derive(Debug, Clone)]
pub(crate) struct Part {
    pub(crate) axis: usize,
    /// The global index of the slab's cell 0 along `axis`.
    pub(crate) first: usize,
    /// The global cell count along `axis`.
    pub(crate) global_n: usize,
    pub(crate) exchange: Arc<dyn Exchange>,
}

impl PartialEq for Part {
    fn eq(&self, other: &Self) -> bool {
        self.axis == other.axis
            && self.first == other.first
            && self.global_n == other.global_n
            && Arc::ptr_eq(&self.exchange, &other.exchange)
    }
}

impl Part {
    /// The neighbours `[lower, upper]` along the (periodic) split axis.
    pub(crate) fn neighbours(&self) -> [usize; 2] {
        let (p, n) = (self.exchange.part(), self.exchange.parts());
        [(p + n - 1) % n, (p + 1) % n]
    }
}

impl<T: Real> Grid<T> {
    /// This part's slab of the grid decomposed by `decomposition`, the part being
    /// `exchange.part()`: the cells of the slab, the same spacing bit for bit, and ghost layers
    /// along the split axis that [`Field::fill_ghosts`](super::Field::fill_ghosts) (and the
    /// vector and tensor forms) fill from the neighbouring parts through `exchange`.
    ///
    /// Errors: a decomposition of another number of parts than `exchange`'s, a split axis that
    /// is not periodic (walls are not split yet), a slab of fewer than 4 cells, a grid that is
    /// itself a part or a capsule's box.
    pub fn split(&self, decomposition: Decomposition, exchange: Arc<dyn Exchange>) -> Result<Grid<T>> {
        let axis = decomposition.axis();
        if decomposition.parts() != exchange.parts() {
            return Err(Error::invalid(
                "Decomposition parts",
                format!("{} (the exchange has {})", decomposition.parts(), exchange.parts()),
                "the exchange's part count",
            ));
        }
        if !self.is_periodic(axis) {
            return Err(Error::invalid("Decomposition axis", axis, "a periodic axis of the grid"));
        }
        if self.part.is_some() || self.seams().iter().any(|&s| s) {
            return Err(Error::invalid("Grid::split grid", "a part or a capsule box", "a whole grid"));
        }
        let n = self.n()[axis];
        let (first, count) = decomposition.range(n, exchange.part());
        // The thinnest slab decides, so that every part refuses alike.
        if n / decomposition.parts() < 4 {
            return Err(Error::invalid(
                "Decomposition parts",
                format!("{} along an axis of {n} cells", decomposition.parts()),
                "slabs of at least 4 cells (at most n / 4 parts)",
            ));
        }
        let mut g = self.clone();
        let at = |c: usize| self.lower()[axis] + T::from_usize(c).unwrap_or(T::zero()) * self.h()[axis];
        g.lower[axis] = at(first);
        g.upper[axis] = at(first + count);
        g.n[axis] = count;
        g.dims[axis] = count + 2 * GHOST;
        g.part = Some(Part { axis, first, global_n: n, exchange });
        Ok(g)
    }

    /// The global index of this grid's cell `(0, 0, 0)` (zero but along the split axis of a
    /// part of a decomposed grid).
    pub fn offset(&self) -> [usize; 3] {
        let mut o = [0; 3];
        if let Some(p) = &self.part {
            o[p.axis] = p.first;
        }
        o
    }

    /// The cells of the whole grid this grid is a part of (its own cells if it is not a part).
    pub fn global_cells(&self) -> [usize; 3] {
        let mut n = self.n();
        if let Some(p) = &self.part {
            n[p.axis] = p.global_n;
        }
        n
    }

    /// Whether this grid is a part of a decomposed grid with more than one part.
    pub fn is_split(&self) -> bool {
        self.part.as_ref().is_some_and(|p| p.exchange.parts() > 1)
    }

    /// Sums over all parts: each part's `partial`, added in part order (every part gets the
    /// same result, whichever part finished first); `partial` itself where the grid is not
    /// split.
    pub fn sum_over_parts<const K: usize>(&self, partial: [T; K]) -> [T; K] {
        let Some(p) = self.part.as_ref().filter(|p| p.exchange.parts() > 1) else { return partial };
        let parts = p.exchange.parts();
        let mine = partial.map(|x| x.f64());
        let mut all = vec![0.0; K * parts];
        p.exchange.all_gather(&mine, &mut all);
        std::array::from_fn(|k| (0..parts).fold(T::zero(), |acc, q| acc + T::lit(all[q * K + k])))
    }

    /// The largest of the parts' values, per entry (`x` itself where the grid is not split):
    /// every part gets the same result.
    pub fn max_over_parts<const K: usize>(&self, x: [T; K]) -> [T; K] {
        let Some(p) = self.part.as_ref().filter(|p| p.exchange.parts() > 1) else { return x };
        let parts = p.exchange.parts();
        let mut all = vec![0.0; K * parts];
        p.exchange.all_gather(&x.map(|v| v.f64()), &mut all);
        std::array::from_fn(|k| (0..parts).fold(T::lit(all[k]), |m, q| m.max(T::lit(all[q * K + k]))))
    }

    /// The part's place, for the ghost filling.
    pub(crate) fn part(&self) -> Option<&Part> {
        self.part.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slabs_cover_the_axis_once() {
        for parts in 1..6 {
            let d = Decomposition::slabs(0, parts).unwrap();
            for n in parts..40 {
                let mut next = 0;
                for p in 0..parts {
                    let (first, count) = d.range(n, p);
                    assert_eq!(first, next);
                    assert!(count == n / parts || count == n / parts + 1);
                    next += count;
                }
                assert_eq!(next, n);
            }
        }
        assert!(Decomposition::slabs(0, 0).is_err());
    }

    #[test]
    fn local_parts_swap_with_their_neighbours() {
        for parts in 1..5 {
            let got: Vec<[f64; 2]> = std::thread::scope(|s| {
                let handles: Vec<_> = LocalParts::new(parts)
                    .into_iter()
                    .map(|ex| {
                        s.spawn(move || {
                            let p = ex.part();
                            let (lo, hi) = ((p + parts - 1) % parts, (p + 1) % parts);
                            let (mut a, mut b) = ([0.0], [0.0]);
                            // Send down -p, up +p; twice, to check that messages keep their order.
                            for round in 0..2 {
                                let r = round as f64 * 100.0;
                                ex.swap(lo, hi, &[-(p as f64) - r], &[p as f64 + r], &mut a, &mut b);
                            }
                            [a[0], b[0]]
                        })
                    })
                    .collect();
                handles.into_iter().map(|h| h.join().unwrap()).collect()
            });
            for (p, [from_lower, from_upper]) in got.into_iter().enumerate() {
                let (lo, hi) = ((p + parts - 1) % parts, (p + 1) % parts);
                assert_eq!(from_lower, lo as f64 + 100.0);
                assert_eq!(from_upper, -(hi as f64) - 100.0);
            }
        }
    }

    #[test]
    fn split_refuses_what_it_cannot_decompose() {
        let bc = crate::grid::Boundary::<f64>::walls_on(Some(2));
        let g = Grid::new([16, 16, 16], [0.0; 3], [1.0; 3], bc).unwrap();
        let one = || -> Arc<dyn Exchange> { Arc::new(LocalParts::new(2).remove(0)) };
        let e = g.split(Decomposition::slabs(2, 2).unwrap(), one()).unwrap_err();
        assert!(e.to_string().contains("periodic"), "{e}");
        let e = g.split(Decomposition::slabs(0, 3).unwrap(), one()).unwrap_err();
        assert!(e.to_string().contains("the exchange has 2"), "{e}");
        let small = Grid::<f64>::periodic([16, 7, 16], [0.0; 3], [1.0; 3]).unwrap();
        let e = small.split(Decomposition::slabs(1, 2).unwrap(), one()).unwrap_err();
        assert!(e.to_string().contains("at least 4 cells"), "{e}");
        let part = g.split(Decomposition::slabs(0, 2).unwrap(), one()).unwrap();
        assert_eq!(part.n(), [8, 16, 16]);
        assert_eq!(part.offset(), [0, 0, 0]);
        assert_eq!(part.global_cells(), [16, 16, 16]);
        assert_eq!(part.h(), g.h());
        assert!(part.split(Decomposition::slabs(1, 2).unwrap(), one()).is_err());
    }
}
