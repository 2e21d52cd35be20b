//! PLY, OBJ and STL parsers and mesh cleaning on arbitrary bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_physics::terrain::{obj, ply, stl};

fuzz_target!(|data: &[u8]| {
    for parsed in [ply::parse(data), obj::parse(data), stl::parse(data)] {
        if let Ok(mut m) = parsed {
            m.clean(1e-5);
            for t in &m.triangles {
                assert!(t.iter().all(|&i| (i as usize) < m.vertices.len()));
            }
        }
    }
});
