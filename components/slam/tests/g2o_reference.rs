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
