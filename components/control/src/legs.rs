//! A plan drives forward and backward: the lattice's primitives include
//! reversing (a three-point turn in a narrow tube). The follower takes it
//! leg by leg, a leg being a run of poses driven in one direction; a
//! backward leg is followed with pure pursuit on the rover turned about
//! (heading + pi) and the speed negated.

/// Most legs in one plan (cusps are rare; more are driven as one).
pub const MAX_LEGS: usize = 32;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Leg {
    /// First and last pose, inclusive.
    pub start: usize,
    pub end: usize,
    pub reverse: bool,
}

/// Split poses (x, y, heading) into legs at the changes of direction.
/// Poses that do not move (turns on the spot) join the leg they are in.
pub fn split_legs(poses: &[[f64; 3]], out: &mut heapless::Vec<Leg, MAX_LEGS>) {
    out.clear();
    let mut current: Option<Leg> = None;
    for i in 1..poses.len() {
        let (a, b) = (poses[i - 1], poses[i]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        if dx * dx + dy * dy < 1e-8 {
            if let Some(l) = &mut current {
                l.end = i;
            }
            continue;
        }
        // The direction of travel against the heading at both ends.
        let along =
            dx * (libm::cos(a[2]) + libm::cos(b[2])) + dy * (libm::sin(a[2]) + libm::sin(b[2]));
        let reverse = along < 0.0;
        match &mut current {
            Some(l) if l.reverse == reverse || out.is_full() => l.end = i,
            Some(l) => {
                let done = *l;
                let _ = out.push(done);
                current = Some(Leg {
                    start: done.end,
                    end: i,
                    reverse,
                });
            }
            None => {
                current = Some(Leg {
                    start: i - 1,
                    end: i,
                    reverse,
                })
            }
        }
    }
    if let Some(l) = current {
        if out.is_full() {
            if let Some(last) = out.last_mut() {
                last.end = l.end;
            }
        } else {
            let _ = out.push(l);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn a_three_point_turn_is_three_legs() {
        // Forward along +x, back up turning, then forward along -x.
        let poses = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [1.6, -0.3, 0.8],
            [1.6, -0.3, 1.6],
            [1.0, 0.0, PI],
            [0.0, 0.0, PI],
        ];
        let mut legs = heapless::Vec::new();
        split_legs(&poses, &mut legs);
        assert_eq!(
            legs.as_slice(),
            &[
                Leg {
                    start: 0,
                    end: 2,
                    reverse: false
                },
                Leg {
                    start: 2,
                    end: 4,
                    reverse: true
                },
                Leg {
                    start: 4,
                    end: 6,
                    reverse: false
                },
            ]
        );
    }

    #[test]
    fn one_direction_is_one_leg_and_nothing_is_none() {
        let mut legs = heapless::Vec::new();
        split_legs(
            &[[0.0, 0.0, PI], [-1.0, 0.0, PI], [-2.0, 0.1, PI]],
            &mut legs,
        );
        assert_eq!(
            legs.as_slice(),
            &[Leg {
                start: 0,
                end: 2,
                reverse: false
            }]
        );
        split_legs(&[[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], &mut legs);
        assert_eq!(
            legs.as_slice(),
            &[Leg {
                start: 0,
                end: 1,
                reverse: true
            }]
        );
        split_legs(&[[0.0, 0.0, 0.0]], &mut legs);
        assert!(legs.is_empty());
    }
}
