//! A world's named poses (`speleo world waypoints`): its start, the
//! entrance and every 10 m of its route, and a pose per level; and the
//! parsing of a pose given by name or as numbers.

use super::World;

/// Named poses of a world: x, y, ground z, yaw.
pub fn waypoints(w: &World) -> Vec<(String, [f64; 4])> {
    let mut out = vec![("start".to_string(), w.start)];
    out.extend(w.named.iter().cloned());
    let r = &w.route;
    if r.len() < 2 {
        return out;
    }
    let yaw_at = |i: usize| {
        let (a, b) = if i + 1 < r.len() {
            (r[i], r[i + 1])
        } else {
            (r[i - 1], r[i])
        };
        (b[1] - a[1]).atan2(b[0] - a[0])
    };
    let pose = |i: usize| [r[i][0], r[i][1], r[i][2], yaw_at(i)];
    out.push(("entrance".into(), pose(0)));
    // Every 10 m along the route.
    let mut along = 0.0;
    let mut next = 10.0;
    for i in 1..r.len() {
        along += ((r[i][0] - r[i - 1][0]).powi(2)
            + (r[i][1] - r[i - 1][1]).powi(2)
            + (r[i][2] - r[i - 1][2]).powi(2))
        .sqrt();
        if along >= next {
            out.push((format!("m{}", next as u32), pose(i)));
            next += 10.0;
        }
    }
    // A level wherever the route settles 1.5 m above or below the last
    // one, over or under another floor (a slope down a cave is no level).
    let stacked = |i: usize| floor_over_or_under(w, r[i]);
    let mut level_z = r[0][2];
    let mut levels = vec![("level0".to_string(), pose(0))];
    for i in 1..r.len() - 1 {
        let flat = (r[i + 1][2] - r[i][2]).abs() < 0.02;
        if flat && (r[i][2] - level_z).abs() > 1.5 && stacked(i) {
            level_z = r[i][2];
            levels.push((format!("level{}", levels.len()), pose(i)));
        }
    }
    if levels.len() > 1 {
        out.extend(levels);
    }
    out
}

/// Whether the world has a floor (a face within 20 degrees of level,
/// facing up) more than 1.5 m above or below `p`.
fn floor_over_or_under(w: &World, p: [f64; 3]) -> bool {
    let m = &w.mesh;
    (0..m.triangles.len()).any(|t| {
        let (_, n) = m.triangle_geometry(t);
        if n[2] < 20f64.to_radians().cos() {
            return false;
        }
        let v = m.triangles[t].map(|i| m.vertices[i as usize].map(f64::from));
        let inside = {
            // Same side of all three edges.
            let side = |a: [f64; 3], b: [f64; 3]| {
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let s = [side(v[0], v[1]), side(v[1], v[2]), side(v[2], v[0])];
            s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
        };
        inside && ((v[0][2] + v[1][2] + v[2][2]) / 3.0 - p[2]).abs() > 1.5
    })
}

/// A pose by name, or `x,y,z,yaw` (metres, degrees).
pub fn pose_of(spec: &str, named: &[(String, [f64; 4])]) -> Result<[f64; 4], String> {
    if let Some((_, p)) = named.iter().find(|(n, _)| n == spec) {
        return Ok(*p);
    }
    let v: Vec<f64> = spec
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            let names: Vec<&str> = named.iter().map(|(n, _)| n.as_str()).collect();
            format!(
                "\"{spec}\": not x,y,z,yaw nor a waypoint ({})",
                names.join(", ")
            )
        })?;
    match v[..] {
        [x, y, z, yaw] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z, yaw.to_radians()]),
        _ => Err(format!(
            "\"{spec}\": a pose is x,y,z,yaw (four finite numbers)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_garage_has_a_waypoint_per_level_and_poses_parse() {
        let w = World::build("garage", 1).unwrap_or_else(|e| panic!("{e}"));
        let named = waypoints(&w);
        let z = |n: &str| pose_of(n, &named).map(|p| p[2]).unwrap_or(f64::NAN);
        assert_eq!((z("level0"), z("level1"), z("level2")), (0.0, 3.0, 6.0));
        assert!(pose_of("level3", &named).is_err_and(|e| e.contains("level2")));
        let p = pose_of("1, 2, 3, 90", &named).unwrap_or_default();
        assert_eq!(p[..3], [1.0, 2.0, 3.0]);
        assert!((p[3] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(pose_of("1,2,3", &named).is_err_and(|e| e.contains("four")));
        assert!(pose_of("1,2,nan,0", &named).is_err());
    }

    #[test]
    fn a_cave_sloping_down_has_no_levels() {
        let w = World::build("lava-tube", 1).unwrap_or_else(|e| panic!("{e}"));
        let named = waypoints(&w);
        assert!(named.iter().all(|(n, _)| !n.starts_with("level")));
        assert!(named.iter().any(|(n, _)| n == "m200"));
    }
}
