//! `speleo world`: a world's mesh exported, its named poses listed.

use std::io::Write;
use std::process::ExitCode;

use crate::args::{WorldExportArgs, WorldWaypointsArgs};
use crate::Error;

pub fn world_export(a: WorldExportArgs) -> Result<ExitCode, Error> {
    let w = speleo_twin::world::World::build(&a.world, a.seed)?;
    let f = std::fs::File::create(&a.out)
        .map_err(|e| format!("cannot create {}: {e}", a.out.display()))?;
    let mut out = std::io::BufWriter::new(f);
    w.mesh.write_ply(&mut out)?;
    out.flush()?;
    let (lo, hi) = w.mesh.bounds();
    println!(
        "{}: {} triangles, {} vertices, bounds ({:.1}, {:.1}, {:.1}) to ({:.1}, {:.1}, {:.1}) m, \
         reachable floor {:.0} m2, start ({:.2}, {:.2}, {:.2}) heading {:.1} deg",
        a.out.display(),
        w.mesh.triangle_count(),
        w.mesh.vertices.len(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        w.floor_area_m2,
        w.start[0],
        w.start[1],
        w.start[2],
        w.start[3].to_degrees()
    );
    Ok(ExitCode::SUCCESS)
}

pub fn world_waypoints(a: WorldWaypointsArgs) -> Result<ExitCode, Error> {
    let w = speleo_twin::world::World::build(&a.world, a.seed)?;
    // Written, not printed: a reader that goes away (`| head`) ends the
    // listing with an error the caller takes for success, not a panic.
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for (name, p) in speleo_twin::world::waypoints::waypoints(&w) {
        writeln!(
            out,
            "{name:10} {:8.2} {:8.2} {:7.2} {:7.1}",
            p[0],
            p[1],
            p[2],
            p[3].to_degrees()
        )?;
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
