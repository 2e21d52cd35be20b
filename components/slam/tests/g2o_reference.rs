//! The back end on the SE-Sync benchmark graphs in ../shared/data: each
//! reaches the published optimum of the SE-Sync objective to 4 significant
//! digits (skipped, with a message, when the data is absent).

use speleo_slam::batch::{optimize, Init};
use speleo_slam::g2o::G2o;

fn check(file: &str, published: f64) {
    let Some(path) = speleo_hal::shared_data::path(&format!("posegraph/{file}")) else {
        return;
    };
    let text = std::fs::read_to_string(&path).expect("read");
    let g = G2o::parse(&text).expect("parse");
    let r = optimize(&g, Init::Chordal, 100).expect("optimise");
    let digits = |v: f64| {
        let scale = 10f64.powi(3 - v.abs().log10().floor() as i32);
        (v * scale).round() / scale
    };
    assert_eq!(
        digits(r.final_objective),
        digits(published),
        "{file}: {} after {} iterations",
        r.final_objective,
        r.iterations
    );
}

#[test]
fn intel_reaches_the_published_optimum() {
    check("intel.g2o", 52.35);
}

#[test]
fn parking_garage_reaches_the_published_optimum() {
    check("parking-garage.g2o", 1.263);
}

#[test]
fn sphere2500_reaches_the_published_optimum() {
    check("sphere2500.g2o", 1687.0);
}

#[test]
fn a_graph_without_edges_or_with_an_unjoined_vertex_is_refused_by_name() {
    use speleo_slam::batch::BatchError;
    let edge = "1 0 0 1 0 0 1 0 1";
    let g = G2o::parse("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n").expect("parse");
    let e = optimize(&g, Init::Chordal, 10).expect_err("no edges");
    assert!(matches!(e, BatchError::NoEdges), "{e}");
    let g = G2o::parse(&format!(
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 7 2 0 0\nEDGE_SE2 0 1 {edge}\n"
    ))
    .expect("parse");
    for init in [Init::Chordal, Init::SpanningTree, Init::File] {
        let e = optimize(&g, init, 10).expect_err("unjoined");
        assert!(e.to_string().contains("vertex 7"), "{e}");
    }
    // A FIX vertex holds its own part for the solver, not for the chordal start.
    let g = G2o::parse(&format!(
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 7 2 0 0\nVERTEX_SE2 8 3 0 0\nEDGE_SE2 0 1 {edge}\nEDGE_SE2 7 8 {edge}\nFIX 0\nFIX 7\n"
    ))
    .expect("parse");
    assert!(optimize(&g, Init::File, 10).is_ok());
    assert!(matches!(
        optimize(&g, Init::Chordal, 10),
        Err(BatchError::Unjoined { id: 7, anchor: 0 })
    ));
}
