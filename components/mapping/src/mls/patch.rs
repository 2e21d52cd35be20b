//! Surface patches and the update of one cell's patch list.

/// What a patch stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u8)]
pub enum PatchKind {
    /// A surface one could stand on: its points span little height.
    #[default]
    Horizontal,
    /// A wall, or any surface whose points span more height than
    /// `vertical_threshold_m` within the cell: an obstacle.
    Vertical,
}

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
    /// Points merged into the patch.
    pub count: u32,
    pub kind: PatchKind,
}

impl Patch {
    /// A patch of one point.
    pub fn new(z: f32, variance: f32) -> Patch {
        Patch {
            mean: z,
            variance,
            min: z,
            max: z,
            count: 1,
            kind: PatchKind::Horizontal,
        }
    }

    /// Height span of the points (m).
    pub fn extent(&self) -> f32 {
        self.max - self.min
    }

    /// Distance from `z` to the patch's height interval (0 inside).
    #[inline(always)]
    fn distance(&self, z: f32) -> f32 {
        if z < self.min {
            self.min - z
        } else if z > self.max {
            z - self.max
        } else {
            0.0
        }
    }

    /// Kalman update of the mean with a measurement `z` of variance `var`.
    #[inline(always)]
    fn add(&mut self, z: f32, var: f32) {
        let s = self.variance + var;
        // s > 0 unless both variances are zero: then plain averaging.
        let k = if s > 0.0 {
            self.variance / s
        } else {
            1.0 / (self.count as f32 + 1.0)
        };
        self.mean += k * (z - self.mean);
        self.variance -= k * self.variance;
        self.min = self.min.min(z);
        self.max = self.max.max(z);
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
#[inline]
pub(crate) fn insert(
    patches: &mut [Patch],
    len: &mut usize,
    z: f32,
    rule: &CellRule,
) -> CellUpdate {
    let n = (*len).min(patches.len());
    // The nearest patch within the gap; ties (a point exactly between two
    // patches) go to the lower one.
    let mut best = usize::MAX;
    let mut best_d = f32::INFINITY;
    let mut insert_at = n;
    for (i, p) in patches[..n].iter().enumerate() {
        let d = p.distance(z);
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
        p.add(z, rule.point_variance);
        if p.extent() > rule.vertical_threshold {
            p.kind = PatchKind::Vertical;
        }
        let merged = merge_around(patches, len, best, rule);
        return CellUpdate::Updated { merged };
    }
    if n == patches.len() {
        return CellUpdate::Full;
    }
    // Shift the higher patches up to keep the list sorted.
    let mut i = n;
    while i > insert_at {
        patches[i] = patches[i - 1];
        i -= 1;
    }
    patches[insert_at] = Patch::new(z, rule.point_variance);
    *len = n + 1;
    CellUpdate::Added
}

/// Fuses patch `i` with its neighbours while they are within the gap of it
/// (a grown patch can close the gap to the next level); returns how many
/// were fused.
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
            insert(patches, len, z, &RULE);
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
    fn a_full_cell_refuses_a_new_level() {
        let mut p = [Patch::default(); 2];
        let mut n = 0;
        assert_eq!(insert(&mut p, &mut n, 0.0, &RULE), CellUpdate::Added);
        assert_eq!(insert(&mut p, &mut n, 5.0, &RULE), CellUpdate::Added);
        assert_eq!(insert(&mut p, &mut n, 2.0, &RULE), CellUpdate::Full);
        assert_eq!(
            insert(&mut p, &mut n, 5.1, &RULE),
            CellUpdate::Updated { merged: 0 }
        );
        assert_eq!(n, 2);
        let mut none: [Patch; 0] = [];
        let mut zero = 0;
        assert_eq!(insert(&mut none, &mut zero, 0.0, &RULE), CellUpdate::Full);
    }
}
