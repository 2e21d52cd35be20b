//! SBPL planning files on arbitrary text: the input up to its first NUL
//! byte is read as an EnvironmentNAVXYTHETALAT `.cfg`, the rest as `.mprim`
//! motion primitives, and a lattice is built when both parse.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_planner::{mprim, sbpl};

fuzz_target!(|data: &[u8]| {
    let (env_bytes, prim_bytes) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, data),
    };
    let env = std::str::from_utf8(env_bytes).ok().map(sbpl::parse_env);
    let prims = std::str::from_utf8(prim_bytes).ok().map(mprim::parse);
    if let (Some(Ok(env)), Some(Ok(prims))) = (env, prims) {
        // Small grids only: the heuristic visits every cell.
        if env.width * env.height <= 4096 {
            let _ = sbpl::SbplLattice::new(env, &prims);
        }
    }
});
