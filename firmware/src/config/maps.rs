//! `[maps]`: the multi-level surface map kept by the `maps` task, the
//! keyframe clouds it is built from, and the TSDF mesh made on request.

use serde::{Deserialize, Serialize};

use super::{range, ConfigError};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapsConfig {
    /// Keep the maps (needs SLAM).
    pub enabled: bool,
    /// Points kept per keyframe for mapping (2 mm integers and the
    /// return's intensity, 7 bytes each);
    /// a denser revolution is thinned evenly.
    pub keyframe_points: usize,
    /// Returns farther than this from the sensor are not mapped.
    pub range_m: f64,
    /// MLS cell size.
    pub mls_resolution_m: f64,
    /// Cells the MLS map holds (two maps: one is rebuilt while the other
    /// serves).
    pub mls_max_cells: usize,
    /// Material levels a cell holds; a point of one more is dropped and
    /// counted. Eight: with four, a garage mission dropped 96,727 points,
    /// and 7 m up the roof ramp the cell its safety monitor stopped for
    /// (a drop ahead) held four patches, the floor to the level under,
    /// and none at the ramp's height. A lava tube mission dropped 732
    /// points at four and one at eight, its outputs bit-identical.
    pub mls_patches_per_cell: usize,
    /// When the serving MLS map is full, it is rebuilt from the points
    /// within this distance of the rover (in the plane).
    pub mls_keep_radius_m: f64,
    /// Points farther apart in height are different levels.
    pub mls_gap_m: f64,
    /// A patch spanning more than this in height is vertical (a wall).
    pub mls_vertical_threshold_m: f64,
    /// Re-project every keyframe once one has moved this much since it
    /// was inserted (a loop closure)...
    pub reproject_m: f64,
    /// ...or turned this much.
    pub reproject_deg: f64,
    /// Points one step of the `maps` task inserts (its work quantum).
    pub points_per_step: usize,
    /// Where a keyframe's downward rings should have met the ground the
    /// rover stood on within this distance of the sensor and met nothing,
    /// the MLS cell is marked (an open edge with nothing seen under it: a
    /// roof's rim); 0, the default, marks nothing. Off until measured
    /// on every world: at 1.6 m, beside a drop rule since dropped, the
    /// lava tube's rover was stranded 38 m in (coverage 0.28).
    pub unseen_ground_reach_m: f64,
    /// TSDF voxel size and truncation (in voxels) of the mesh.
    pub tsdf_voxel_m: f64,
    pub tsdf_truncation_voxels: f64,
    /// Voxel blocks (8^3 voxels, 4 KiB) the mesh's TSDF may use.
    pub tsdf_max_blocks: usize,
}

impl Default for MapsConfig {
    fn default() -> Self {
        MapsConfig {
            enabled: true,
            keyframe_points: 32_768,
            range_m: 20.0,
            mls_resolution_m: 0.1,
            mls_max_cells: 1 << 18,
            mls_patches_per_cell: 8,
            mls_keep_radius_m: 20.0,
            mls_gap_m: 0.3,
            mls_vertical_threshold_m: 0.25,
            reproject_m: 0.05,
            reproject_deg: 0.5,
            points_per_step: 4_000,
            unseen_ground_reach_m: 0.0,
            tsdf_voxel_m: 0.05,
            tsdf_truncation_voxels: 3.0,
            tsdf_max_blocks: 1 << 16,
        }
    }
}

impl MapsConfig {
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        range(
            "maps.keyframe_points",
            self.keyframe_points,
            1,
            1 << 20,
            "1..=1048576",
        )?;
        range(
            "maps.range_m",
            self.range_m,
            1.0,
            65.0,
            "1..=65 (2 mm integers)",
        )?;
        range(
            "maps.mls_resolution_m",
            self.mls_resolution_m,
            0.01,
            10.0,
            "0.01..=10",
        )?;
        range(
            "maps.mls_max_cells",
            self.mls_max_cells,
            1,
            speleo_mapping::mls::MAX_CELLS,
            "1..=MAX_CELLS of speleo-mapping",
        )?;
        range(
            "maps.mls_patches_per_cell",
            self.mls_patches_per_cell,
            1,
            speleo_mapping::mls::MAX_PATCHES_PER_CELL,
            "1..=MAX_PATCHES_PER_CELL of speleo-mapping",
        )?;
        // The kept disc must fit in half the map, or keeping it makes no
        // room.
        let disc_cells =
            std::f64::consts::PI * (self.mls_keep_radius_m / self.mls_resolution_m + 1.0).powi(2);
        if !(self.mls_keep_radius_m > 0.0 && disc_cells <= self.mls_max_cells as f64 / 2.0) {
            return Err(ConfigError::Invalid {
                key: "maps.mls_keep_radius_m".into(),
                why: format!(
                    "the kept disc ({disc_cells:.0} cells of {} m) must be positive and fit in half of maps.mls_max_cells ({})",
                    self.mls_resolution_m, self.mls_max_cells
                ),
            });
        }
        range("maps.mls_gap_m", self.mls_gap_m, 0.01, 10.0, "0.01..=10")?;
        range(
            "maps.unseen_ground_reach_m",
            self.unseen_ground_reach_m,
            0.0,
            5.0,
            "0..=5",
        )?;
        range(
            "maps.mls_vertical_threshold_m",
            self.mls_vertical_threshold_m,
            0.01,
            10.0,
            "0.01..=10",
        )?;
        range(
            "maps.reproject_m",
            self.reproject_m,
            0.001,
            10.0,
            "0.001..=10",
        )?;
        range(
            "maps.reproject_deg",
            self.reproject_deg,
            0.01,
            90.0,
            "0.01..=90",
        )?;
        range(
            "maps.points_per_step",
            self.points_per_step,
            100,
            1_000_000,
            "100..=1000000",
        )?;
        range(
            "maps.tsdf_voxel_m",
            self.tsdf_voxel_m,
            0.005,
            1.0,
            "0.005..=1",
        )?;
        range(
            "maps.tsdf_truncation_voxels",
            self.tsdf_truncation_voxels,
            1.0,
            speleo_mapping::tsdf::MAX_TRUNCATION_VOXELS,
            "1..=MAX_TRUNCATION_VOXELS of speleo-mapping",
        )?;
        range(
            "maps.tsdf_max_blocks",
            self.tsdf_max_blocks,
            1,
            speleo_mapping::tsdf::MAX_BLOCKS,
            "1..=MAX_BLOCKS of speleo-mapping",
        )
    }

    pub fn mls_params(&self) -> speleo_mapping::mls::MlsParams {
        speleo_mapping::mls::MlsParams {
            resolution_m: self.mls_resolution_m,
            max_cells: self.mls_max_cells,
            max_patches_per_cell: self.mls_patches_per_cell,
            gap_m: self.mls_gap_m as f32,
            vertical_threshold_m: self.mls_vertical_threshold_m as f32,
            ..speleo_mapping::mls::MlsParams::default()
        }
    }

    pub fn tsdf_params(&self) -> speleo_mapping::tsdf::TsdfParams {
        speleo_mapping::tsdf::TsdfParams {
            voxel_size_m: self.tsdf_voxel_m,
            truncation_voxels: self.tsdf_truncation_voxels,
            max_blocks: self.tsdf_max_blocks,
            ..speleo_mapping::tsdf::TsdfParams::default()
        }
    }
}
