//! The predicted trajectory, and its comparison with the executed one at
//! equal times since the start of motion (the paper's distance function:
//! its RMSE was 0.419 m on the path it analysed).

/// Samples kept (10 Hz: over 6 minutes of traverse).
pub const PREDICTION_POINTS: usize = 4096;

/// Positions every 0.1 s since the start of motion.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    pub points: Vec<[f64; 3]>,
}

impl Prediction {
    pub fn with_capacity() -> Self {
        Prediction {
            points: Vec::with_capacity(PREDICTION_POINTS),
        }
    }

    pub fn clear(&mut self) {
        self.points.clear();
    }

    pub fn push(&mut self, p: [f64; 3]) {
        if self.points.len() < PREDICTION_POINTS {
            self.points.push(p);
        }
    }
}

/// RMSE of the horizontal distance between two tracks sampled at the same
/// times since the start of motion, over their common length; a track
/// that ended early is held at its last position (the rover stands
/// there). `None` when either is empty.
pub fn rmse_at_equal_times(predicted: &[[f64; 3]], executed: &[[f64; 3]]) -> Option<f64> {
    let n = predicted.len().max(executed.len());
    if predicted.is_empty() || executed.is_empty() {
        return None;
    }
    let at = |v: &[[f64; 3]], i: usize| v[i.min(v.len() - 1)];
    let sum: f64 = (0..n)
        .map(|i| {
            let (a, b) = (at(predicted, i), at(executed, i));
            (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
        })
        .sum();
    Some((sum / n as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_tracks_agree_and_a_lagging_one_does_not() {
        let a: Vec<[f64; 3]> = (0..50).map(|i| [0.1 * i as f64, 0.0, 0.0]).collect();
        assert_eq!(rmse_at_equal_times(&a, &a), Some(0.0));
        // Half a metre behind all the way.
        let b: Vec<[f64; 3]> = a.iter().map(|p| [p[0] - 0.5, 0.0, 0.0]).collect();
        let e = rmse_at_equal_times(&a, &b).expect("rmse");
        assert!((e - 0.5).abs() < 1e-12, "{e}");
        // An early stop is held where it stopped.
        let c = &a[..10];
        let e = rmse_at_equal_times(&a, c).expect("rmse");
        assert!(e > 1.5, "{e}");
        assert_eq!(rmse_at_equal_times(&a, &[]), None);
    }
}
