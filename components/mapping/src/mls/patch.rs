//! Surface patches and the update of one cell's patch list.

/// What a patch stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u8)]
pub enum PatchKind {
    /// A surface one could stand on: its points span little height.
    #[default]
    Horizontal,
    /// A wall, or any surface whose points span more height than
    /// `vertical_threshold_m` within the cell: an obstacle, unless it is a
    /// slab seen from above and below, whose top is ground
    /// ([`Patch::ground`]).
    Vertical,
}

/// Points within this height of a patch's top cluster belong to it (m):
/// a slab's top over a 0.1 m cell spans its slope and the range noise,
/// while its underside lies a slab's thickness lower.
pub const TOP_BAND_M: f32 = 0.1;

/// Empty height between a patch's top cluster and the highest point under
/// it that makes the top a surface of its own (m): a slab's top over its
/// underside (0.25 m lower, less noise and slope), not a rock's top over
/// its flanks, whose points fill the height between.
pub const SLAB_GAP_M: f32 = 0.12;

/// One surface in a cell: the points within `gap_m` of one another in
/// height, summarised.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Patch {
    /// Variance-weighted mean height of the points (m, map frame).
    pub mean: f32,
    /// Variance of `mean` (m^2): the point variance over the point count
    /// for equal points.
    pub variance: f32,
    /// Lowest point height (m).
    pub min: f32,
    /// Highest point height (m).
    pub max: f32,
    /// Mean height of the highest cluster of points (those within
    /// [`TOP_BAND_M`] of it): the surface on top of a tall patch, such as
    /// a ramp's slab whose underside the LiDAR saw too.
    pub top: f32,
    /// Points merged into the patch.
    pub count: u32,
    /// The highest point under the top cluster (`f32::MIN` when none).
    pub under: f32,
    /// Points in the top cluster (saturates).
    pub top_count: u16,
    pub kind: PatchKind,
    /// Some point of it was seen from a sensor at or over its height. A
    /// patch only ever seen from below may be the underside of a slab whose
    /// top was not seen: under a height where one stands, it is neither
    /// ground nor a drop (see [`Patch::underside_for`]).
    pub seen_from_above: bool,
    /// Some point of the top cluster was seen from above: the top is a
    /// surface seen from where one stands on it (a garage slab's top from
    /// the level it floors), not the highest part of something seen from
    /// below.
    pub top_seen_from_above: bool,
    /// Some point under the top cluster was seen from above.
    pub under_seen_from_above: bool,
}

impl Patch {
    /// A patch of one point, seen from above or below.
    pub fn new(z: f32, variance: f32, from_above: bool) -> Patch {
        Patch {
            mean: z,
            variance,
            min: z,
            max: z,
            top: z,
            under: f32::MIN,
            count: 1,
            top_count: 1,
            kind: PatchKind::Horizontal,
            seen_from_above: from_above,
            top_seen_from_above: from_above,
            under_seen_from_above: false,
        }
    }

    /// A single return seen only from a sensor under it: a stray, not an
    /// obstacle one could meet. Climbing a ramp, the rays that reach the
    /// slope ahead travel upward, and one such return 0.33 m over a garage
    /// ramp stopped the rover halfway up for good; a real obstacle returns
    /// more points as the rover nears it.
    pub fn stray_from_below(&self) -> bool {
        self.count <= 1 && !self.seen_from_above
    }

    /// Whether this patch, only ever seen from below and wholly more than
    /// [`TOP_BAND_M`] under height `z`, says nothing of what is at `z`: a
    /// slab's underside seen from the floor beside it, whose top the rings
    /// missed. One cannot see a drop from below.
    pub fn underside_for(&self, z: f32) -> bool {
        !self.seen_from_above && self.max < z - TOP_BAND_M
    }

    /// The height one would stand at on this patch, if any: a horizontal
    /// patch's mean, or the top of a tall one that is a slab (its top
    /// cluster [`SLAB_GAP_M`] clear of the points under it, such as a ramp
    /// seen from above and below, whose underside may outnumber its top).
    /// A tall patch whose points fill its height (a wall, a rock, a ledge's
    /// face) is no ground. A thin slab, under the vertical threshold,
    /// stands at its top when what lies under its top was only ever seen
    /// from below, and at its mean otherwise:
    /// - Never seen from above, the top cluster is the slab's top glimpsed
    ///   at a grazing angle: a ray from below cannot reach a surface over
    ///   the slab's underside through it (a garage ramp seen from the
    ///   level under it, whose 0.25 m slab straddles the vertical
    ///   threshold; its mean, pulled down by the underside, cut the ramp
    ///   into steps the planner refused).
    /// - Its top seen from above and its underside from below, it is a
    ///   floor over a room (a garage level's slab: at its mean, level 1 was
    ///   a patchwork of steps no graph crossed).
    /// - Points under the top seen from above too are a floor with
    ///   something low on it, such as a wall's foot under a lip: reading
    ///   the lip as ground narrowed the lava tube's squeeze until the
    ///   mission ended there.
    #[inline]
    pub fn ground(&self) -> Option<f32> {
        self.grounds().0
    }

    /// The other height one may stand at on a thin slab that
    /// [`Patch::ground`] puts at its mean because points under its top were
    /// seen from above too: its top. Which of the two is ground, the
    /// ground around says ([`ground_near`] takes the one nearer the height
    /// asked for). Up a garage ramp seen from the floor before it, cells
    /// held the slope's top with points a fifth of a metre under it, also
    /// seen from above; at their mean they stood a step under their
    /// neighbours, and the rover never left the ground floor. From the
    /// floor beside a lip, the mean is still the nearer.
    #[inline]
    pub fn other_ground(&self) -> Option<f32> {
        self.grounds().1
    }

    /// [`Patch::ground`] and [`Patch::other_ground`] at once (the one
    /// place their rules are written).
    #[inline]
    pub fn grounds(&self) -> (Option<f32>, Option<f32>) {
        let slab = self.slab();
        match self.kind {
            PatchKind::Horizontal if slab && self.top_over_underside() => (Some(self.top), None),
            PatchKind::Horizontal if slab => (Some(self.mean), Some(self.top)),
            PatchKind::Horizontal => (Some(self.mean), None),
            PatchKind::Vertical if slab => (Some(self.top), None),
            PatchKind::Vertical => (None, None),
        }
    }

    /// A top cluster [`SLAB_GAP_M`] clear of the points under it.
    fn slab(&self) -> bool {
        self.under > f32::MIN && self.top - self.under > SLAB_GAP_M
    }

    /// The top was seen from above, or nothing was, and nothing under it
    /// was seen from above.
    fn top_over_underside(&self) -> bool {
        !self.under_seen_from_above && (self.top_seen_from_above || !self.seen_from_above)
    }

    /// Adds `n` points of mean `z` and highest `z_hi` to the top cluster:
    /// points over the cluster's band start a new one (a higher surface)
    /// and the old one, up to the patch's `max` so far, is under it; points
    /// under the band are under it too. Call before updating `max`.
    #[inline(always)]
    fn add_top(&mut self, z: f32, z_hi: f32, n: u16, from_above: bool) {
        if z > self.top + TOP_BAND_M {
            self.under = self.under.max(self.max);
            self.under_seen_from_above |= self.top_seen_from_above;
            self.top = z;
            self.top_count = n;
            self.top_seen_from_above = from_above;
        } else if z >= self.top - TOP_BAND_M {
            let total = self.top_count.saturating_add(n);
            self.top += (z - self.top) * (n as f32 / total as f32);
            self.top_count = total;
            self.top_seen_from_above |= from_above;
        } else {
            self.under = self.under.max(z_hi);
            self.under_seen_from_above |= from_above;
        }
    }

    /// The highest point but a lone stray one: when the top cluster is a
    /// single point over the rest (a return off the scan's noise or a
    /// misregistered scan), the highest of the rest. A rock's top is seen
    /// by several points and stays.
    pub fn solid_max(&self) -> f32 {
        if self.top_count <= 1 && self.under > f32::MIN {
            self.under
        } else {
            self.max
        }
    }

    /// Height span of the points (m).
    pub fn extent(&self) -> f32 {
        self.max - self.min
    }

    /// Distance from `z` to the patch's height interval (0 inside), without
    /// branches: `min - z` and `z - max` are not both positive.
    #[inline(always)]
    fn distance(&self, z: f32) -> f32 {
        let below = self.min - z;
        let above = z - self.max;
        let d = if below > above { below } else { above };
        if d > 0.0 {
            d
        } else {
            0.0
        }
    }

    /// Kalman update of the mean with a measurement `z` of variance `var`.
    #[inline(always)]
    fn add(&mut self, z: f32, var: f32, from_above: bool) {
        let s = self.variance + var;
        // s > 0 unless both variances are zero: then plain averaging.
        let k = if s > 0.0 {
            self.variance / s
        } else {
            1.0 / (self.count as f32 + 1.0)
        };
        self.mean += k * (z - self.mean);
        self.variance -= k * self.variance;
        self.add_top(z, z, 1, from_above);
        self.seen_from_above |= from_above;
        // Heights are finite: plain comparisons (no NaN handling).
        if z < self.min {
            self.min = z;
        }
        if z > self.max {
            self.max = z;
        }
        self.count = self.count.saturating_add(1);
    }

    /// Fuses `other` into `self` (two estimates of one surface).
    fn absorb(&mut self, other: &Patch) {
        let s = self.variance + other.variance;
        let k = if s > 0.0 {
            self.variance / s
        } else {
            other.count as f32 / (self.count as f32 + other.count as f32).max(1.0)
        };
        self.mean += k * (other.mean - self.mean);
        self.variance -= k * self.variance;
        self.under = self.under.max(other.under);
        self.under_seen_from_above |= other.under_seen_from_above;
        self.add_top(
            other.top,
            other.max,
            other.top_count,
            other.top_seen_from_above,
        );
        self.seen_from_above |= other.seen_from_above;
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
        self.count = self.count.saturating_add(other.count);
        if other.kind == PatchKind::Vertical {
            self.kind = PatchKind::Vertical;
        }
    }
}

/// The parameters a cell update needs, in the storage precision.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellRule {
    pub gap: f32,
    pub vertical_threshold: f32,
    pub point_variance: f32,
}

/// What happened to a point offered to a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CellUpdate {
    /// Merged into an existing patch; `merged` patches were fused into it
    /// (the cell lost that many).
    Updated { merged: u32 },
    /// Started a new patch.
    Added,
    /// No patch within the gap and no room for another one.
    Full,
}

/// Offers height `z` to a cell holding `patches[..*len]` (sorted by height,
/// each separated from the next by more than `rule.gap`), of capacity
/// `patches.len()`. Keeps the invariant.
#[inline(always)]
pub(crate) fn insert(
    patches: &mut [Patch],
    len: &mut usize,
    z: f32,
    from_above: bool,
    rule: &CellRule,
) -> CellUpdate {
    let n = (*len).min(patches.len());
    // The nearest patch within the gap; ties (a point exactly between two
    // patches) go to the lower one.
    let mut best = usize::MAX;
    let mut best_d = f32::INFINITY;
    for (i, p) in patches[..n].iter().enumerate() {
        let d = p.distance(z);
        if d <= rule.gap && d < best_d {
            best = i;
            best_d = d;
        }
    }
    if best == usize::MAX {
        return add_level(patches, len, z, from_above, rule);
    }
    let p = &mut patches[best];
    p.add(z, rule.point_variance, from_above);
    if p.extent() > rule.vertical_threshold {
        p.kind = PatchKind::Vertical;
    }
    // A grown patch rarely reaches a neighbour: test before fusing.
    let reaches_up = best + 1 < n && patches[best + 1].min - patches[best].max <= rule.gap;
    let reaches_down = best > 0 && patches[best].min - patches[best - 1].max <= rule.gap;
    let merged = if reaches_up || reaches_down {
        merge_around(patches, len, best, rule)
    } else {
        0
    };
    CellUpdate::Updated { merged }
}

/// A new patch of `z` in its place by height, or `Full`.
#[inline(never)]
fn add_level(
    patches: &mut [Patch],
    len: &mut usize,
    z: f32,
    from_above: bool,
    rule: &CellRule,
) -> CellUpdate {
    let n = (*len).min(patches.len());
    if n == patches.len() {
        return CellUpdate::Full;
    }
    let insert_at = patches[..n].iter().position(|p| z < p.min).unwrap_or(n);
    // Shift the higher patches up to keep the list sorted.
    let mut i = n;
    while i > insert_at {
        patches[i] = patches[i - 1];
        i -= 1;
    }
    patches[insert_at] = Patch::new(z, rule.point_variance, from_above);
    *len = n + 1;
    CellUpdate::Added
}

/// Fuses patch `i` with its neighbours while they are within the gap of it
/// (a grown patch can close the gap to the next level); returns how many
/// were fused.
#[cold]
#[inline(never)]
fn merge_around(patches: &mut [Patch], len: &mut usize, mut i: usize, rule: &CellRule) -> u32 {
    let mut merged = 0;
    while i + 1 < *len && patches[i + 1].min - patches[i].max <= rule.gap {
        let upper = patches[i + 1];
        patches[i].absorb(&upper);
        remove(patches, len, i + 1);
        merged += 1;
    }
    while i > 0 && patches[i].min - patches[i - 1].max <= rule.gap {
        let upper = patches[i];
        patches[i - 1].absorb(&upper);
        remove(patches, len, i);
        i -= 1;
        merged += 1;
    }
    if merged > 0 && patches[i].extent() > rule.vertical_threshold {
        patches[i].kind = PatchKind::Vertical;
    }
    merged
}

/// The ground height of `cell` nearest `z` within `tol` (the lower on a
/// tie): see [`Patch::ground`] and [`Patch::other_ground`]; an underside
/// under `z` is not ground ([`Patch::underside_for`]).
pub fn ground_near(cell: &[Patch], z: f32, tol: f32) -> Option<f32> {
    // One pass, each patch's slab test made once: on the graph's growth
    // path, for every footprint cell (the first ties kept, as before).
    let mut best = None;
    let mut best_d = f32::INFINITY;
    for q in cell {
        if q.underside_for(z) {
            continue;
        }
        let (g, other) = q.grounds();
        for c in [g, other].into_iter().flatten() {
            let d = (c - z).abs();
            if d <= tol && d < best_d {
                best = Some(c);
                best_d = d;
            }
        }
    }
    best
}

/// Whether `cell` shows a drop at height `z`: nothing within `tol` of it,
/// but a surface more than `tol` under it. Not seen at all is a ring gap,
/// an underside seen from below is no drop (one cannot see a drop from
/// below), and a slab whose top the rings missed has its underside near.
pub fn drop_at(cell: &[Patch], z: f32, tol: f32) -> bool {
    let lo = z - tol;
    let near = cell.iter().any(|q| q.max >= lo && q.min <= z + tol);
    !near && cell.iter().any(|q| q.max < lo && !q.underside_for(z))
}

fn remove(patches: &mut [Patch], len: &mut usize, at: usize) {
    patches.copy_within(at + 1..*len, at);
    *len -= 1;
}

#[cfg(test)]
mod tests {
    use super::*;

    const RULE: CellRule = CellRule {
        gap: 0.3,
        vertical_threshold: 0.25,
        point_variance: 4e-4,
    };

    fn offer(patches: &mut [Patch], len: &mut usize, zs: &[f32]) {
        for &z in zs {
            insert(patches, len, z, true, &RULE);
        }
    }

    #[test]
    fn points_within_the_gap_share_a_patch_with_their_mean() {
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[0.0, 0.02, -0.02, 0.01, -0.01]);
        assert_eq!(n, 1);
        assert!(p[0].mean.abs() < 1e-6, "{:?}", p[0]);
        assert_eq!(p[0].count, 5);
        assert!((p[0].variance - 4e-4 / 5.0).abs() < 1e-9);
        assert_eq!((p[0].min, p[0].max), (-0.02, 0.02));
        assert_eq!(p[0].kind, PatchKind::Horizontal);
    }

    #[test]
    fn levels_apart_stay_sorted_and_fuse_when_the_gap_closes() {
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[2.0, 0.0, 1.0]);
        assert_eq!(n, 3);
        assert_eq!([p[0].min, p[1].min, p[2].min], [0.0, 1.0, 2.0]);
        // 0.7 and 0.4 extend the middle level down to 0.4, still more
        // than the gap above the floor; 0.2 joins the floor and closes it.
        offer(&mut p, &mut n, &[0.7, 0.4]);
        assert_eq!(n, 3, "{:?}", &p[..n]);
        offer(&mut p, &mut n, &[0.2]);
        assert_eq!(n, 2, "{:?}", &p[..n]);
        assert_eq!((p[0].min, p[0].max), (0.0, 1.0));
        assert_eq!(p[0].count, 5);
        assert_eq!(p[0].kind, PatchKind::Vertical);
        assert_eq!(p[1].min, 2.0);
    }

    #[test]
    fn a_slab_seen_from_both_sides_is_tall_with_its_top_as_ground() {
        // A 0.25 m slab at 1.0: top and underside points in either order.
        let top = [1.0, 1.02, 0.98, 1.01, 0.99];
        let under = [0.75, 0.77, 0.74, 0.76];
        for (first, then) in [(&top[..], &under[..]), (&under[..], &top[..])] {
            let mut p = [Patch::default(); 4];
            let mut n = 0;
            offer(&mut p, &mut n, first);
            offer(&mut p, &mut n, then);
            assert_eq!(n, 1);
            assert_eq!(p[0].kind, PatchKind::Vertical);
            assert!(
                p[0].ground().is_some_and(|g| (g - 1.0).abs() < 0.01),
                "{:?}",
                p[0]
            );
            assert_eq!(p[0].top_count, 5);
            assert_eq!(ground_near(&p[..n], 0.95, 0.1), Some(p[0].top));
            assert_eq!(ground_near(&p[..n], 0.75, 0.1), None);
        }
        // Fused from two patches: the higher one's top.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[1.0, 0.5, 0.8]);
        assert_eq!(n, 1, "{:?}", &p[..n]);
        assert_eq!(p[0].ground(), Some(1.0));
        // A horizontal patch stands at its mean...
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[0.0, 0.1]);
        assert!(p[0].ground().is_some_and(|g| (g - 0.05).abs() < 1e-6));
        assert!((p[0].top - 0.05).abs() < 1e-6);
        // ...and so does a rock's: its flanks fill the height under its top.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[0.0, 0.05, 0.1, 0.15, 0.2, 0.2, 0.2]);
        assert_eq!(p[0].kind, PatchKind::Horizontal);
        assert_eq!(p[0].ground(), Some(p[0].mean));
        // A tall rock or a wall, its points filling its height: no ground.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        let wall: Vec<f32> = (0..=20).map(|k| k as f32 * 0.05).collect();
        offer(&mut p, &mut n, &wall);
        assert_eq!(p[0].kind, PatchKind::Vertical);
        assert_eq!(p[0].ground(), None);
        // A thin slab (0.2 m, under the vertical threshold) stands at its
        // mean, whatever its top cluster.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[0.8, 0.81, 0.79, 0.8, 1.0, 0.8, 1.01]);
        assert_eq!(p[0].kind, PatchKind::Horizontal);
        assert!((p[0].top - 1.005).abs() < 1e-3, "{:?}", p[0]);
        assert_eq!(p[0].ground(), Some(p[0].mean));
        // Seen only from below, the same slab stands at its top.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        for z in [0.8, 0.81, 0.79, 0.8, 1.0, 0.8, 1.01] {
            insert(&mut p, &mut n, z, false, &RULE);
        }
        assert_eq!(p[0].kind, PatchKind::Horizontal);
        assert_eq!(p[0].ground(), Some(p[0].top));
        // One stray point over a floor is no solid top; two are.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        offer(&mut p, &mut n, &[0.0, 0.01, -0.01, 0.0, 0.15]);
        assert_eq!((p[0].max, p[0].solid_max()), (0.15, 0.01));
        offer(&mut p, &mut n, &[0.16]);
        assert_eq!(p[0].solid_max(), 0.16);
        // Without a top cluster clear of the rest, at its mean still.
        let mut p = [Patch::default(); 4];
        let mut n = 0;
        for z in [0.8, 0.85, 0.9, 0.95, 1.0] {
            insert(&mut p, &mut n, z, false, &RULE);
        }
        assert_eq!(p[0].ground(), Some(p[0].mean));
    }

    /// The update as first written (branching distance, fusion tried on
    /// every update, insertion place found in the same pass), kept to check
    /// the faster one against.
    fn reference_insert(
        patches: &mut [Patch],
        len: &mut usize,
        z: f32,
        rule: &CellRule,
    ) -> CellUpdate {
        let dist = |p: &Patch| {
            if z < p.min {
                p.min - z
            } else if z > p.max {
                z - p.max
            } else {
                0.0
            }
        };
        let n = (*len).min(patches.len());
        let (mut best, mut best_d, mut insert_at) = (usize::MAX, f32::INFINITY, n);
        for (i, p) in patches[..n].iter().enumerate() {
            let d = dist(p);
            if d <= rule.gap && d < best_d {
                best = i;
                best_d = d;
            }
            if insert_at == n && z < p.min {
                insert_at = i;
            }
        }
        if best != usize::MAX {
            let p = &mut patches[best];
            p.add(z, rule.point_variance, true);
            if p.extent() > rule.vertical_threshold {
                p.kind = PatchKind::Vertical;
            }
            let merged = merge_around(patches, len, best, rule);
            return CellUpdate::Updated { merged };
        }
        if n == patches.len() {
            return CellUpdate::Full;
        }
        patches.copy_within(insert_at..n, insert_at + 1);
        patches[insert_at] = Patch::new(z, rule.point_variance, true);
        *len = n + 1;
        CellUpdate::Added
    }

    #[test]
    fn the_update_matches_the_reference_bit_for_bit() {
        // SplitMix64 heights: levels that grow into each other and fuse,
        // points between two levels, full cells; zero and equal heights.
        let mut state = 5u64;
        let mut next = || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut x = state;
            x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((x ^ (x >> 31)) >> 40) as f32 / (1u32 << 24) as f32
        };
        let (mut merges, mut fulls) = (0, 0);
        for cap in 1..=5 {
            for round in 0..200 {
                let mut a = [Patch::default(); 5];
                let mut b = a;
                let (mut na, mut nb) = (0, 0);
                for k in 0..60 {
                    let u = next();
                    let z = match (round + k) % 4 {
                        0 => (u * 8.0).floor() * 0.6,
                        1 => u * 5.0 - 1.0,
                        2 => 0.0,
                        _ => (u * 16.0).floor() * 0.3 + 0.15,
                    };
                    let ra = insert(&mut a[..cap], &mut na, z, true, &RULE);
                    let rb = reference_insert(&mut b[..cap], &mut nb, z, &RULE);
                    assert_eq!(ra, rb, "cap {cap} round {round} k {k} z {z}");
                    assert_eq!(na, nb);
                    for (p, q) in a[..na].iter().zip(&b[..nb]) {
                        assert_eq!(p.mean.to_bits(), q.mean.to_bits());
                        assert_eq!(p.variance.to_bits(), q.variance.to_bits());
                        assert_eq!(
                            (p.min, p.max, p.count, p.kind),
                            (q.min, q.max, q.count, q.kind)
                        );
                    }
                    merges += matches!(ra, CellUpdate::Updated { merged } if merged > 0) as u32;
                    fulls += (ra == CellUpdate::Full) as u32;
                }
            }
        }
        assert!(merges > 100 && fulls > 100, "{merges} merges, {fulls} full");
    }

    #[test]
    fn a_full_cell_refuses_a_new_level() {
        let mut p = [Patch::default(); 2];
        let mut n = 0;
        assert_eq!(insert(&mut p, &mut n, 0.0, true, &RULE), CellUpdate::Added);
        assert_eq!(insert(&mut p, &mut n, 5.0, true, &RULE), CellUpdate::Added);
        assert_eq!(insert(&mut p, &mut n, 2.0, true, &RULE), CellUpdate::Full);
        assert_eq!(
            insert(&mut p, &mut n, 5.1, true, &RULE),
            CellUpdate::Updated { merged: 0 }
        );
        assert_eq!(n, 2);
        let mut none: [Patch; 0] = [];
        let mut zero = 0;
        assert_eq!(
            insert(&mut none, &mut zero, 0.0, true, &RULE),
            CellUpdate::Full
        );
    }

    #[test]
    fn a_drop_is_ground_seen_from_above_far_below_and_nothing_near() {
        let floor = Patch::new(-1.0, 4e-4, true);
        let underside = Patch::new(-1.0, 4e-4, false);
        let here = Patch::new(0.05, 4e-4, true);
        assert!(drop_at(&[floor], 0.0, 0.3));
        assert!(!drop_at(&[floor, here], 0.0, 0.3), "ground near the height");
        assert!(
            !drop_at(&[underside], 0.0, 0.3),
            "a drop is not seen from below"
        );
        assert!(!drop_at(&[], 0.0, 0.3), "unobserved is a ring gap");
        assert!(
            !drop_at(&[Patch::new(-0.2, 4e-4, true)], 0.0, 0.3),
            "a step"
        );
    }
}
