//! The keyframe clouds, at their optimised poses, as the internal
//! simulator's source of the world.

use nalgebra::Vector3;
use speleo_simulator::CloudSource;
use speleo_slam::lie::Pose;

use speleo_mapping::KeyframeClouds;

pub struct MapClouds<'a> {
    pub clouds: &'a KeyframeClouds,
    /// base <- sensor.
    pub mount: &'a Pose,
}

impl CloudSource for MapClouds<'_> {
    fn keyframes(&self) -> usize {
        self.clouds.ready()
    }

    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        let p = self.clouds.pose(k)?;
        Some(p.transform(&self.mount.t).into())
    }

    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let Some(pose) = self.clouds.pose(k) else {
            return false;
        };
        let (part, total) = self.clouds.cloud_part(k, from, n);
        for q in part {
            out.push(pose.transform(&Vector3::from(q)).into());
        }
        from + n < total
    }

    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        out.clear();
        if self.clouds.pose(k).is_some() {
            out.extend_from_slice(self.clouds.intensity_part(k, from, n));
        }
    }
}
