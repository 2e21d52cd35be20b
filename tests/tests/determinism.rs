//! Same inputs, bit-identical outputs; another seed, other outputs.

use speleo_tests::{read_json, sim, Scratch};

#[test]
fn the_same_seed_gives_the_same_output_hash() {
    let s = Scratch::new();
    let (a, b, c) = (s.path("a.json"), s.path("b.json"), s.path("c.json"));
    sim(7, 10.0, Some(&s.path("a.mcap")), Some(&a));
    sim(7, 10.0, None, Some(&b));
    sim(8, 10.0, None, Some(&c));
    let (a, b, c) = (read_json(&a), read_json(&b), read_json(&c));
    assert_eq!(a["frames"], 1000);
    assert_eq!(
        a["output_hash"], b["output_hash"],
        "recording must not change outputs"
    );
    assert_ne!(
        a["output_hash"], c["output_hash"],
        "another seed must give other outputs"
    );
}
