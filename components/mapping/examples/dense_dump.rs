//! Writes the TSDF of a synthetic scene as a dense grid, with this crate's
//! marching-cubes counts for the same region, for an outside check
//! (`tools/skimage_check.py` runs scikit-image's marching cubes on it).
//!
//! `cargo run --release -p speleo-mapping --example dense_dump -- DIR [sphere|tube]`
//! writes `DIR/grid.f32` (the tsdf array then the weight array, C order,
//! little-endian f32) and `DIR/grid.json` (dims, origin, voxel size, the
//! vertex and triangle counts of `mesh_region` over the same box).

use std::io::Write;

#[path = "../tests/common/mod.rs"]
mod common;

use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = std::path::PathBuf::from(args.next().ok_or("usage: dense_dump DIR [sphere|tube]")?);
    let scene = args.next().unwrap_or_else(|| "sphere".into());
    let mut vol = TsdfVolume::new(TsdfParams::default())?;
    let (lo, hi) = match scene.as_str() {
        "sphere" => {
            for o in common::sphere_origins() {
                vol.integrate(o, &common::sphere_view(o, 150_000, 60.0));
            }
            let c = common::SPHERE_CENTER;
            (
                [c[0] - 1.3, c[1] - 1.3, c[2] - 1.3],
                [c[0] + 1.3, c[1] + 1.3, c[2] + 1.3],
            )
        }
        "tube" => {
            for (o, pts) in common::tube_scans_map(5, 0.02) {
                vol.integrate(o, &pts);
            }
            ([-2.0, -2.3, -1.5], [8.0, 2.3, 2.3])
        }
        other => return Err(format!("unknown scene {other}").into()),
    };
    let mut buf = MeshBuffers::new();
    let st = vol.mesh_region(lo, hi, &mut buf);
    let g = vol.dense_region(lo, hi).ok_or("region too large")?;
    std::fs::create_dir_all(&dir)?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(dir.join("grid.f32"))?);
    for v in g.tsdf.iter().chain(&g.weight) {
        f.write_all(&v.to_le_bytes())?;
    }
    f.flush()?;
    std::fs::write(
        dir.join("grid.json"),
        format!(
            "{{\"dims\": [{}, {}, {}], \"origin\": [{}, {}, {}], \"voxel_size\": {}, \
             \"vertices\": {}, \"triangles\": {}, \"truncation\": {}}}\n",
            g.dims[0],
            g.dims[1],
            g.dims[2],
            g.origin[0],
            g.origin[1],
            g.origin[2],
            g.voxel_size,
            st.vertices,
            st.triangles,
            vol.truncation()
        ),
    )?;
    println!(
        "{scene}: dims {:?}, {} vertices, {} triangles",
        g.dims, st.vertices, st.triangles
    );
    Ok(())
}
