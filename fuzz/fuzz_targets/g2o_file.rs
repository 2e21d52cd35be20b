//! g2o pose-graph files on arbitrary text: parsed, and when they parse,
//! initialised (spanning tree and chordal), written back and read again,
//! and their chi2 and SE-Sync objective evaluated. Small graphs only: the
//! chordal initialisation factors a dense-ish system.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_slam::g2o::G2o;
use speleo_slam::initialize::{chordal, spanning_tree};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(g) = G2o::parse(text) else {
        return;
    };
    if g.poses.len() > 256 || g.edges.len() > 1024 {
        return;
    }
    let tree = spanning_tree(&g);
    assert_eq!(tree.len(), g.poses.len());
    let _ = g.chi2(&tree);
    let _ = g.sesync_objective(&tree);
    let _ = chordal(&g);
    let mut out = Vec::new();
    if g.write(&g.poses, &mut out).is_ok() {
        let again = std::str::from_utf8(&out).expect("g2o writes text");
        assert!(G2o::parse(again).is_ok(), "written g2o does not parse:\n{again}");
    }
});
