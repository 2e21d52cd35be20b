//! A static 3D kd-tree in flat arrays, built into buffers reserved once.
//!
//! The tree stores its own copy of the points in tree order (the points of
//! a leaf are contiguous, so a leaf scan reads consecutive memory); query
//! results are positions in that order ([`KdTree::points`]), and
//! [`KdTree::input_index`] maps them back to the order given to `build`.
//! Splits are at the median along the axis of widest spread of the node's
//! points, so the depth is at most log2(n) + 1 and recursion is bounded.

/// One query result: a position in [`KdTree::points`] and its squared
/// distance to the query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub index: u32,
    pub dist_sq: f64,
}

/// The most neighbours [`KdTree::knn`] returns per query.
pub const MAX_K: usize = 64;

const LEAF: u32 = 3;

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Split coordinate (internal nodes).
    split: f64,
    /// 0, 1, 2: the split axis of an internal node; `LEAF` for a leaf.
    axis: u32,
    /// Internal: index of the right child (the left one follows the node).
    /// Leaf: first point.
    a: u32,
    /// Leaf: one past the last point.
    b: u32,
}

/// A static kd-tree over at most `capacity` points.
#[derive(Clone, Debug)]
pub struct KdTree {
    capacity: usize,
    leaf_size: usize,
    points: Vec<[f64; 3]>,
    input_index: Vec<u32>,
    nodes: Vec<Node>,
}

impl KdTree {
    /// Leaf size used by [`with_capacity`](Self::with_capacity): among 4 to
    /// 32, the fewest instructions for k=10 and nearest-neighbour queries
    /// on HDL-32E scans downsampled to 0.25 m.
    pub const DEFAULT_LEAF_SIZE: usize = 16;

    /// A tree for up to `max_points` points, every buffer reserved here.
    pub fn with_capacity(max_points: usize) -> Self {
        Self::with_capacity_and_leaf_size(max_points, Self::DEFAULT_LEAF_SIZE)
    }

    /// As [`with_capacity`](Self::with_capacity), with leaves of at most
    /// `leaf_size` points (at least 1).
    pub fn with_capacity_and_leaf_size(max_points: usize, leaf_size: usize) -> Self {
        let max_points = max_points.min(u32::MAX as usize / 2);
        let leaf_size = leaf_size.max(1);
        // A node of c > leaf_size points splits into halves of at least
        // floor((leaf_size + 1) / 2) points: that bounds the leaves, and a
        // binary tree has fewer than twice as many nodes as leaves.
        let min_leaf = leaf_size.div_ceil(2).max(1);
        let nodes = 2 * (max_points / min_leaf + 1);
        KdTree {
            capacity: max_points,
            leaf_size,
            points: Vec::with_capacity(max_points),
            input_index: Vec::with_capacity(max_points),
            nodes: Vec::with_capacity(nodes),
        }
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points in tree order: query results index this slice.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Position in the slice given to [`build`](Self::build) of tree point `i`.
    pub fn input_index(&self, i: usize) -> Option<usize> {
        self.input_index.get(i).map(|&j| j as usize)
    }

    /// Rebuild over `points`. Non-finite points and points beyond the
    /// capacity are skipped; returns how many were skipped.
    pub fn build(&mut self, points: &[[f64; 3]]) -> usize {
        self.points.clear();
        self.input_index.clear();
        self.nodes.clear();
        let mut skipped = 0;
        for (i, p) in points.iter().enumerate() {
            if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite())
                || self.input_index.len() == self.capacity
            {
                skipped += 1;
                continue;
            }
            self.input_index.push(i as u32);
        }
        if self.input_index.is_empty() {
            return skipped;
        }
        // The tree is built by permuting indices; the points are then copied
        // in tree order so that a leaf reads contiguous memory.
        let n = self.input_index.len();
        self.build_node(points, 0, n);
        self.points
            .extend(self.input_index.iter().map(|&i| points[i as usize]));
        skipped
    }

    /// Build the subtree over `input_index[start..end]`, split at the median
    /// along the axis of widest spread of those points. Why the points' own
    /// extent and not the cell's: LiDAR points lie on surfaces, and a cell
    /// that is tall over flat ground would be cut along z into slabs every
    /// query has to visit on both sides.
    fn build_node(&mut self, input: &[[f64; 3]], start: usize, end: usize) {
        let me = self.nodes.len();
        if end - start <= self.leaf_size {
            self.nodes.push(Node {
                split: 0.0,
                axis: LEAF,
                a: start as u32,
                b: end as u32,
            });
            return;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &i in &self.input_index[start..end] {
            let p = &input[i as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
            0
        } else if ext[1] >= ext[2] {
            1
        } else {
            2
        };
        let mid = start + (end - start) / 2;
        // std's selection: deterministic, no allocation, linear in the worst
        // case (bounded build time whatever the data).
        self.input_index[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            input[a as usize][axis].total_cmp(&input[b as usize][axis])
        });
        let split = input[self.input_index[mid] as usize][axis];
        self.nodes.push(Node {
            split,
            axis: axis as u32,
            a: 0,
            b: 0,
        });
        self.build_node(input, start, mid);
        self.nodes[me].a = self.nodes.len() as u32;
        self.build_node(input, mid, end);
    }

    /// The nearest point within `max_dist_sq` (squared distance) of `q`.
    /// Among equally near points the first one met wins; the traversal
    /// order is fixed, so results repeat.
    #[inline]
    pub fn nearest(&self, q: &[f64; 3], max_dist_sq: f64) -> Option<Neighbor> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best = Neighbor {
            index: u32::MAX,
            dist_sq: max_dist_sq,
        };
        self.search(0, q, 0.0, &mut [0.0; 3], &mut best);
        (best.index != u32::MAX).then_some(best)
    }

    /// The `out.len()` (at most [`MAX_K`]) nearest points within
    /// `max_dist_sq` of `q`, closest first, written to the front of `out`;
    /// returns how many were found.
    pub fn knn(&self, q: &[f64; 3], max_dist_sq: f64, out: &mut [Neighbor]) -> usize {
        let k = out.len().min(MAX_K);
        if k == 0 || self.nodes.is_empty() {
            return 0;
        }
        let mut heap = Knn {
            found: 0,
            items: &mut out[..k],
            bound: max_dist_sq,
        };
        self.search(0, q, 0.0, &mut [0.0; 3], &mut heap);
        heap.found
    }

    /// The traversal shared by both queries: leaves offer their points to
    /// `c`, and a far child is visited only when its cell can still hold a
    /// point within `c.bound()`. `rd` is the squared distance from `q` to
    /// the node's cell along the axes recorded in `off` (nanoflann's
    /// incremental distance), which prunes better than the distance to the
    /// splitting plane alone.
    fn search<C: Collector>(&self, n: usize, q: &[f64; 3], rd: f64, off: &mut [f64; 3], c: &mut C) {
        let node = self.nodes[n];
        if node.axis == LEAF {
            let (a, b) = (node.a as usize, node.b as usize);
            for (i, p) in (a..b).zip(&self.points[a..b]) {
                c.offer(i as u32, dist_sq(p, q));
            }
            return;
        }
        let ax = node.axis as usize;
        let diff = q[ax] - node.split;
        let (near, far) = if diff < 0.0 {
            (n + 1, node.a as usize)
        } else {
            (node.a as usize, n + 1)
        };
        self.search(near, q, rd, off, c);
        let old = off[ax];
        let rd_far = rd - old * old + diff * diff;
        if rd_far <= c.bound() {
            off[ax] = diff;
            self.search(far, q, rd_far, off, c);
            off[ax] = old;
        }
    }
}

/// What a query keeps of the points the traversal meets.
trait Collector {
    /// Squared distance beyond which nothing is wanted any more.
    fn bound(&self) -> f64;
    fn offer(&mut self, index: u32, dist_sq: f64);
}

/// The nearest point: among equally near ones the first met wins.
impl Collector for Neighbor {
    #[inline(always)]
    fn bound(&self) -> f64 {
        self.dist_sq
    }
    #[inline(always)]
    fn offer(&mut self, index: u32, dist_sq: f64) {
        if dist_sq < self.dist_sq || (dist_sq == self.dist_sq && self.index == u32::MAX) {
            *self = Neighbor { index, dist_sq };
        }
    }
}

impl Collector for Knn<'_> {
    #[inline(always)]
    fn bound(&self) -> f64 {
        self.bound
    }
    #[inline(always)]
    fn offer(&mut self, index: u32, dist_sq: f64) {
        if dist_sq <= self.bound {
            self.insert(index, dist_sq);
        }
    }
}

/// A sorted array of the k best so far; `bound` is the k-th distance once
/// full (the search radius before).
struct Knn<'a> {
    found: usize,
    items: &'a mut [Neighbor],
    bound: f64,
}

impl Knn<'_> {
    /// Called only with `dist_sq <= bound`. Equal distances keep the point
    /// found first: the traversal order is fixed, so results repeat.
    #[inline(always)]
    fn insert(&mut self, index: u32, dist_sq: f64) {
        let k = self.items.len();
        if self.found == k && dist_sq >= self.items[k - 1].dist_sq {
            return;
        }
        // Shift worse items right (dropping the last one when full).
        let mut j = self.found.min(k - 1);
        while j > 0 && dist_sq < self.items[j - 1].dist_sq {
            self.items[j] = self.items[j - 1];
            j -= 1;
        }
        self.items[j] = Neighbor { index, dist_sq };
        if self.found < k {
            self.found += 1;
        }
        if self.found == k {
            self.bound = self.items[k - 1].dist_sq;
        }
    }
}

#[inline(always)]
fn dist_sq(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (x, y, z) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    x * x + y * y + z * z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_and_duplicate_points() {
        let mut t = KdTree::with_capacity(100);
        assert_eq!(t.build(&[]), 0);
        assert!(t.nearest(&[0.0; 3], 1.0).is_none());
        assert_eq!(
            t.knn(
                &[0.0; 3],
                f64::INFINITY,
                &mut [Neighbor {
                    index: 0,
                    dist_sq: 0.0
                }; 4]
            ),
            0
        );
        let same = vec![[1.0, 2.0, 3.0]; 50];
        t.build(&same);
        let mut out = [Neighbor {
            index: 0,
            dist_sq: 0.0,
        }; 10];
        assert_eq!(t.knn(&[1.0, 2.0, 3.0], f64::INFINITY, &mut out), 10);
        assert_eq!(
            t.nearest(&[1.0, 2.0, 3.5], 1.0).map(|n| n.dist_sq),
            Some(0.25)
        );
    }
}
