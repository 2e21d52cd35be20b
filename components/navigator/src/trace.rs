//! Trace lines of the graph and the map near the rover where a query
//! found no candidate: where the graph ends and why.

use speleo_mapping::mls::MlsMap;

/// was found, m.
pub(crate) const GRAPH_TRACE_RADIUS_M: f64 = 8.0;

/// Every node within `radius_m` of `rover` as a trace line (target
/// `speleo::graph`): where the graph ends and why, to look at after a
/// mission (`RUST_LOG=debug,speleo::graph=trace`). Nothing is done
/// unless that target traces.
pub(crate) fn trace_graph_near(
    trav: &speleo_traversability::TravMap,
    rover: [f64; 3],
    radius_m: f64,
) {
    if !tracing::enabled!(target: "speleo::graph", tracing::Level::TRACE) {
        return;
    }
    for n in trav.nodes() {
        let [x, y, z] = trav.position(n);
        if (x - rover[0]).hypot(y - rover[1]) > radius_m {
            continue;
        }
        tracing::trace!(
            target: "speleo::graph",
            x,
            y,
            z,
            patch_z = n.patch_z,
            slope_deg = n.slope_deg,
            class = ?n.class,
            blocked = ?n.blocked,
            cut = n.cut,
            window_edge = n.window_edge,
            "node"
        );
    }
}

/// Every MLS patch within `radius_m` of `rover` as a trace line (target
/// `speleo::cells`), beside the graph's nodes where no candidate was
/// found: what the map holds where the graph ends (on the garage's roof
/// ramp, a slab's top and underside both seen from below, or only its
/// underside). Nothing is done unless that target traces.
pub(crate) fn trace_cells_near(mls: &MlsMap, rover: [f64; 3], radius_m: f64) {
    if !tracing::enabled!(target: "speleo::cells", tracing::Level::TRACE) {
        return;
    }
    let (lo, hi) = (
        [rover[0] - radius_m, rover[1] - radius_m],
        [rover[0] + radius_m, rover[1] + radius_m],
    );
    mls.for_each_in_region(lo, hi, |ix, iy, patches| {
        let [x, y] = mls.cell_center(ix, iy);
        if (x - rover[0]).hypot(y - rover[1]) > radius_m {
            return;
        }
        for p in patches {
            tracing::trace!(
                target: "speleo::cells",
                x,
                y,
                mean = p.mean,
                min = p.min,
                max = p.max,
                top = p.top,
                under = (p.under > f32::MIN).then_some(p.under),
                count = p.count,
                top_count = p.top_count,
                kind = ?p.kind,
                seen_from_above = p.seen_from_above,
                top_seen_from_above = p.top_seen_from_above,
                under_seen_from_above = p.under_seen_from_above,
                ground = p.ground(),
                "patch"
            );
        }
    });
}
