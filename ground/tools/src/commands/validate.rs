//! `speleo validate`: one validation of the internal simulator replayed
//! from its case file, and on the true world when asked.

use std::path::Path;
use std::process::ExitCode;

use speleo_firmware::config::Config;

use crate::args::ValidateArgs;
use crate::Error;

fn as_writer(w: &mut std::io::BufWriter<std::fs::File>) -> &mut dyn std::io::Write {
    w
}

pub fn validate(a: ValidateArgs) -> Result<ExitCode, Error> {
    use crate::validate as tv;
    let cfg = match &a.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    cfg.validate()?;
    let params = speleo_firmware::params::simulator(&cfg);
    let case = tv::read_case(&a.case)?;
    let create = |p: &Path| {
        std::fs::File::create(p)
            .map(std::io::BufWriter::new)
            .map_err(|e| format!("cannot create {}: {e}", p.display()))
    };
    if let Some(p) = &a.plan {
        let mut w = create(p)?;
        tv::write_plan(&case.plan, &mut w)?;
        std::io::Write::flush(&mut w)?;
    }
    let mut track = a.track.as_deref().map(create).transpose()?;
    let mut mesh = a.mesh.as_deref().map(create).transpose()?;
    let r = tv::replay(
        &case,
        params.clone(),
        track.as_mut().map(as_writer),
        mesh.as_mut().map(as_writer),
    )?;
    for w in [track.as_mut(), mesh.as_mut()].into_iter().flatten() {
        std::io::Write::flush(w)?;
    }
    let length: f64 = case
        .plan
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let [x, y, z, yaw] = case.start.xyz_yaw();
    println!(
        "case: at {:.1} s from ({x:.2}, {y:.2}, {z:.2}) heading {:.1} deg (pitch {:.1}, roll {:.1}), \
         plan {} poses {length:.2} m{}, {} keyframes, {} points read",
        case.began_ns as f64 * 1e-9,
        yaw.to_degrees(),
        case.start.pitch.to_degrees(),
        case.start.roll.to_degrees(),
        case.plan.len(),
        if case.way_back { " and back" } else { "" },
        case.keyframes.len(),
        case.points()
    );
    let show = |v: &speleo_simulator::Verdict| {
        format!(
            "{:?} after {:.2} s driving, {:.2} m from the goal",
            v.outcome, v.drive_s, v.goal_error_m
        )
    };
    let show_drive = |label: &str, d: &tv::Drive| {
        let [tx, ty, tz] = d.max_tilt_at;
        println!(
            "{label}: {} ({} physics steps, {} triangles, {:.0} ms; a step {:.0} us of CPU median, {:.0} p99, {:.0} max); most tilt {:.1} deg at ({tx:.2}, {ty:.2}, {tz:.2})",
            show(&d.verdict),
            d.physics_steps,
            d.triangles,
            d.wall_ms,
            d.step_us[0],
            d.step_us[1],
            d.step_us[2],
            d.max_tilt_deg
        );
    };
    println!(
        "on board: {}",
        case.verdict
            .as_ref()
            .map_or("no verdict recorded".into(), show)
    );
    show_drive("replayed", &r);
    if let Some(name) = &a.world {
        let truth_path = a
            .case
            .parent()
            .unwrap_or(Path::new("."))
            .join(speleo_firmware::validation_dump::TRUTH_FILE);
        let truth = std::fs::read_to_string(&truth_path).map_err(|e| {
            format!(
                "--world needs the true track the simulation wrote beside the cases, {}: {e}",
                truth_path.display()
            )
        })?;
        let (start, plan, err) = tv::in_world(&case, &truth)?;
        let world = speleo_twin::world::World::build(name, a.seed)?;
        let ground = tv::crop(&world.mesh, start.position, &plan, params.margin_m);
        let mut wt = a.world_track.as_deref().map(create).transpose()?;
        let t = tv::drive_on(
            ground,
            start,
            case.way_back,
            &plan,
            params,
            wt.as_mut().map(as_writer),
        )?;
        if let Some(w) = wt.as_mut() {
            std::io::Write::flush(w)?;
        }
        println!(
            "SLAM's error then: ({:.2}, {:.2}, {:.2}) m, {:.1} deg; in the world from ({:.2}, {:.2}, {:.2}), pitch {:.1} deg, roll {:.1} deg",
            err[0],
            err[1],
            err[2],
            err[3],
            start.position[0],
            start.position[1],
            start.position[2],
            start.pitch.to_degrees(),
            start.roll.to_degrees()
        );
        show_drive("true world", &t);
    }
    if tv::same_verdict(&case, &r.verdict) {
        println!("same verdict as on board");
        Ok(ExitCode::SUCCESS)
    } else {
        println!("the verdict differs from the mission's");
        Ok(ExitCode::from(1))
    }
}
