//! `speleo g2o`, `register`, `plan` and `primitives`: the back ends run
//! alone on standard inputs (pose graphs, point clouds, SBPL lattices).

use std::process::ExitCode;

use crate::args::{G2oArgs, PlanArgs, PrimitivesArgs, RegisterArgs};
use crate::Error;

pub fn g2o(a: G2oArgs) -> Result<ExitCode, Error> {
    let r = crate::g2o::run(&a.file, &a.init, a.max_iterations, a.out.as_deref())?;
    println!("{r}");
    if let Some(path) = &a.report {
        speleo_firmware::report::write_json(path, &r)?;
    }
    Ok(ExitCode::SUCCESS)
}

pub fn register(a: RegisterArgs) -> Result<ExitCode, Error> {
    let r = crate::register::register(&a.source, &a.target, a.init.as_deref(), a.voxel)?;
    println!("{r}");
    if let Some(path) = &a.report {
        speleo_firmware::report::write_json(path, &r)?;
    }
    // A transform that did not converge is printed for inspection but is
    // no answer: scripts see it in the status.
    Ok(if r.converged {
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "error: GICP did not converge in {} iterations",
            r.iterations
        );
        ExitCode::from(1)
    })
}

pub fn plan(a: PlanArgs) -> Result<ExitCode, Error> {
    check_search(&a)?;
    let planned = if let Some(world) = &a.world {
        let (Some(start), Some(goal)) = (&a.start, &a.goal) else {
            return Err("--world needs --start and --goal".into());
        };
        let r = crate::plan_world::plan_world(&crate::plan_world::WorldPlanArgs {
            world,
            seed: a.seed,
            start,
            goal,
            mprim: a.mprim.as_deref(),
            eps: a.eps,
            eps_step: a.eps_step,
            quantum: a.quantum,
        })?;
        println!("{r}");
        if let Some(path) = &a.report {
            speleo_firmware::report::write_json(path, &r)?;
        }
        r.cost_ms.is_some()
    } else {
        let r = crate::plan::plan_sbpl(&a)?;
        println!("{r}");
        if let Some(path) = &a.report {
            speleo_firmware::report::write_json(path, &r)?;
        }
        r.cost.is_some()
    };
    Ok(if planned {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

pub fn primitives(a: PrimitivesArgs) -> Result<ExitCode, Error> {
    use speleo_planner::primitives::{generate, to_mprim_text, PrimitiveSpec};
    let ok = |v: f64| v > 0.0 && v.is_finite();
    if !ok(a.resolution) || !ok(a.min_turn_radius) || !(1..=1024).contains(&a.angles) {
        return Err(
            "--resolution and --min-turn-radius must be positive, --angles 1..=1024".into(),
        );
    }
    let f = generate(&PrimitiveSpec {
        resolution_m: a.resolution,
        angles: a.angles,
        min_turn_radius_m: a.min_turn_radius,
        ..PrimitiveSpec::default()
    });
    std::fs::write(&a.out, to_mprim_text(&f))
        .map_err(|e| format!("cannot write {}: {e}", a.out.display()))?;
    println!(
        "{} primitives ({} headings) written to {}",
        f.primitives.len(),
        f.angles,
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// ARA*'s settings as the command line gives them: an inflation below 1
/// would make the search inadmissible, a zero quantum would never stop it.
fn check_search(a: &PlanArgs) -> Result<(), Error> {
    if !(a.eps.is_finite() && a.eps >= 1.0) {
        return Err(format!("--eps {}: must be a finite number >= 1", a.eps).into());
    }
    if !(a.eps_step.is_finite() && a.eps_step > 0.0) {
        return Err(format!("--eps-step {}: must be a finite number > 0", a.eps_step).into());
    }
    if a.quantum == 0 {
        return Err("--quantum 0: must be at least 1 expansion".into());
    }
    Ok(())
}
