//! The ground's grip read from its returns: each TSDF voxel keeps its
//! brightest return and the direction that ray came from, and a surface's
//! reflectance is that intensity with the incidence taken out.

/// A return's intensity at incidence angle `a` is its surface's
/// reflectance times `GRAZING + (1 - GRAZING) cos a`: the HDL-32E's
/// response as the sensor twin models it.
pub(crate) const GRAZING: f64 = 0.2;

/// The brightest return of each voxel slot and the ray it came along.
pub(crate) struct ReturnsBySlot {
    /// 0: no intensity measured.
    brightest: Vec<u8>,
    /// The unit ray from the sensor to that return, times 127.
    ray: Vec<[i8; 3]>,
}

impl ReturnsBySlot {
    /// Room for `slots` voxels (0: nothing is kept).
    pub fn new(slots: usize) -> Self {
        ReturnsBySlot {
            brightest: vec![0; slots],
            ray: vec![[0; 3]; slots],
        }
    }

    pub fn is_empty(&self) -> bool {
        self.brightest.is_empty()
    }

    /// Forget the first `used` slots' returns.
    pub fn clear(&mut self, used: usize) {
        let used = used.min(self.brightest.len());
        self.brightest[..used].fill(0);
        self.ray[..used].fill([0; 3]);
    }

    /// A return of `intensity` at `point` seen from `origin`, in `slot`.
    pub fn record(&mut self, slot: usize, origin: [f64; 3], point: [f64; 3], intensity: u8) {
        if slot >= self.brightest.len() || intensity <= self.brightest[slot] {
            return;
        }
        let d = [0, 1, 2].map(|k| point[k] - origin[k]);
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if n <= 0.0 || !n.is_finite() {
            return;
        }
        self.brightest[slot] = intensity;
        self.ray[slot] = d.map(|c| (c / n * 127.0).round().clamp(-127.0, 127.0) as i8);
    }

    /// The reflectance of the surface of unit normal `normal` read from
    /// `slot`'s brightest return (`None`: nothing measured there).
    pub fn reflectance(&self, slot: usize, normal: [f64; 3]) -> Option<f64> {
        let b = *self.brightest.get(slot)?;
        if b == 0 {
            return None;
        }
        let r = self.ray[slot].map(|c| f64::from(c) / 127.0);
        let cos = (r[0] * normal[0] + r[1] * normal[1] + r[2] * normal[2])
            .abs()
            .min(1.0);
        Some(f64::from(b) / (GRAZING + (1.0 - GRAZING) * cos))
    }

    pub fn memory_bytes(&self) -> usize {
        self.brightest.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_incidence_is_taken_out_of_a_grazing_return() {
        let mut r = ReturnsBySlot::new(4);
        // Rock (60) seen at 58 degrees off its normal reads 60 * (0.2 +
        // 0.8 cos 58) = 37, darker than it reads seen square on.
        let a = 58f64.to_radians();
        let grazing = (60.0 * (GRAZING + (1.0 - GRAZING) * a.cos())).round() as u8;
        assert_eq!(grazing, 37);
        r.record(1, [0.0, 0.0, 1.0], [a.tan(), 0.0, 0.0], grazing);
        let rock = r.reflectance(1, [0.0, 0.0, 1.0]).expect("measured");
        assert!((rock - 60.0).abs() < 3.0, "{rock}");
        assert_eq!(r.reflectance(0, [0.0, 0.0, 1.0]), None);
        assert_eq!(r.reflectance(9, [0.0, 0.0, 1.0]), None);
        // A dimmer return later does not replace the brightest.
        r.record(1, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 5);
        assert!((r.reflectance(1, [0.0, 0.0, 1.0]).expect("kept") - rock).abs() < 1e-9);
        r.clear(4);
        assert_eq!(r.reflectance(1, [0.0, 0.0, 1.0]), None);
    }
}
