//! The part of a refused plan the simulated rover drove well: where the
//! map ends in ground seen only from below (a garage ramp's upper half
//! from the level under it), the simulated rover stalls at the edge of
//! what the scans showed. Driving the plan up to a metre short of that
//! edge is validated by the same run, and from there the rover sees the
//! ground the plan went on over.

/// What makes a refused plan's prefix worth driving.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrefixRule {
    /// A plan pose counts as driven when the predicted track passed this
    /// near it (horizontally), m.
    pub pass_m: f64,
    /// The prefix ends at least this far (horizontally) from where the
    /// simulated rover failed, m.
    pub margin_m: f64,
    /// A prefix shorter than this along the plan is not worth a traverse, m.
    pub min_length_m: f64,
}

impl Default for PrefixRule {
    fn default() -> Self {
        PrefixRule {
            pass_m: 0.3,
            margin_m: 1.0,
            min_length_m: 2.0,
        }
    }
}

/// A driven prefix: the first `poses` of the plan, reached by the predicted
/// track's first `samples` samples, `length_m` long along the plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prefix {
    pub poses: usize,
    pub samples: usize,
    pub length_m: f64,
}

/// The longest prefix of `plan` (x, y, ground z, heading) that the
/// predicted track (`prediction`, the failed run's, ending where the
/// rover failed) passed pose by pose, in order, and that ends at least
/// `rule.margin_m` from the failure; `None` when it is shorter than
/// `rule.min_length_m`.
pub fn driven_prefix(
    plan: &[[f64; 4]],
    prediction: &[[f64; 3]],
    rule: PrefixRule,
) -> Option<Prefix> {
    let end = *prediction.last()?;
    let horizontal = |a: [f64; 3], q: &[f64; 4]| (a[0] - q[0]).hypot(a[1] - q[1]);
    let mut t = 0usize;
    let mut length = 0.0;
    let mut best: Option<Prefix> = None;
    for (j, q) in plan.iter().enumerate() {
        if j > 0 {
            let p = &plan[j - 1];
            length += (q[0] - p[0]).hypot(q[1] - p[1]);
        }
        let Some(dt) = prediction[t..]
            .iter()
            .position(|&a| horizontal(a, q) <= rule.pass_m)
        else {
            break;
        };
        t += dt;
        // The sample nearest the pose: the rover's time there.
        while t + 1 < prediction.len()
            && horizontal(prediction[t + 1], q) < horizontal(prediction[t], q)
        {
            t += 1;
        }
        if horizontal(end, q) >= rule.margin_m && length >= rule.min_length_m {
            best = Some(Prefix {
                poses: j + 1,
                samples: t + 1,
                length_m: length,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight plan along x, a pose every 0.5 m up to `to`.
    fn plan(to: f64) -> Vec<[f64; 4]> {
        (0..=(to / 0.5) as usize)
            .map(|i| [0.5 * i as f64, 0.0, 0.0, 0.0])
            .collect()
    }

    /// A track along x every 0.05 m up to `to`, then `stall` samples there.
    fn track(to: f64, stall: usize) -> Vec<[f64; 3]> {
        let mut v: Vec<[f64; 3]> = (0..=(to / 0.05) as usize)
            .map(|i| [0.05 * i as f64, 0.02, 0.3])
            .collect();
        v.extend(std::iter::repeat_n([to, 0.02, 0.3], stall));
        v
    }

    #[test]
    fn a_stall_halfway_leaves_the_plan_up_to_a_metre_short_of_it() {
        let p = driven_prefix(&plan(8.0), &track(4.6, 30), PrefixRule::default())
            .unwrap_or_else(|| panic!("no prefix"));
        // Poses at 0, 0.5, ..., 3.5: 3.5 is 1.1 m short of the stall.
        assert_eq!(p.poses, 8);
        assert!((p.length_m - 3.5).abs() < 1e-9, "{p:?}");
        let t = track(4.6, 30);
        assert!((t[p.samples - 1][0] - 3.5).abs() < 0.03, "{p:?}");
    }

    #[test]
    fn a_stall_near_the_start_leaves_nothing_worth_driving() {
        assert_eq!(
            driven_prefix(&plan(8.0), &track(2.5, 30), PrefixRule::default()),
            None
        );
        assert_eq!(driven_prefix(&plan(8.0), &[], PrefixRule::default()), None);
    }

    #[test]
    fn a_track_that_strayed_from_the_plan_ends_the_prefix_where_it_left() {
        // Along the plan to x = 3, then off sideways to (3, 3), stalled.
        let mut t = track(3.0, 0);
        t.extend((1..=60).map(|i| [3.0, 0.05 * i as f64, 0.3]));
        let p = driven_prefix(&plan(8.0), &t, PrefixRule::default())
            .unwrap_or_else(|| panic!("no prefix"));
        // Pose 3.0 was passed; 3.5 never: the prefix is the plan to 3.0
        // (3 m from the stall).
        assert_eq!(p.poses, 7, "{p:?}");
    }
}
