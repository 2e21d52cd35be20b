//! Directions an alignment's surfaces do not hold, and what to do there
//! (after Zhang, Kaess and Singh, "On degeneracy of optimization-based
//! state estimation problems", ICRA 2016): keep the guess, and claim no
//! information.
//!
//! Why: on a bare plane (a garage's roof) every LiDAR ring pairs with
//! itself in the next scan, and GICP, whose patches keep a weight in their
//! own plane, reads two scans a metre apart as no motion at all, with the
//! information of a well-held direction. Where a little structure is in
//! view (a ramp's opening, a rim) the normals hold a direction weakly and
//! the rings still pull it toward no motion. So the test is relative: the
//! share of each direction's information that the surfaces' normals carry
//! ([`Alignment::plane_information`] against [`Alignment::hessian`]), a
//! generalised eigenproblem, free of the units that mix metres and
//! radians.

use nalgebra::{Isometry3, Matrix6, Vector6};

use super::gicp::{perturb, Alignment};

/// Each direction's share of the information carried by the normals:
/// the generalised eigenpairs `N v = s H v` of `plane_information` (`N`)
/// against `hessian` (`H`), with `v^T H v = 1`, smallest share first.
/// `None` when `H` is not positive definite (no inliers) or `N` was not
/// summed (`GicpParams::surface_information`).
pub fn surface_shares(a: &Alignment) -> Option<(Vector6<f64>, Matrix6<f64>)> {
    let n = a.plane_information?;
    let l = a.hessian.cholesky()?.l();
    let l_inv = l.try_inverse()?;
    let m = l_inv * n * l_inv.transpose();
    let e = (0.5 * (m + m.transpose())).symmetric_eigen();
    // Fixed order (smallest first) so that callers and logs read the same.
    let mut order = [0usize, 1, 2, 3, 4, 5];
    order.sort_by(|&i, &j| e.eigenvalues[i].total_cmp(&e.eigenvalues[j]));
    let vs = l_inv.transpose() * e.eigenvectors;
    let mut shares = Vector6::zeros();
    let mut dirs = Matrix6::zeros();
    for (c, &k) in order.iter().enumerate() {
        shares[c] = e.eigenvalues[k];
        dirs.set_column(c, &vs.column(k));
    }
    Some((shares, dirs))
}

/// Removes from `a` what its surfaces do not hold: along each direction
/// whose share of information carried by the normals ([`surface_shares`])
/// is under `min_share`, the transform keeps `init`'s value and the
/// Hessian has no information; the other directions are untouched.
/// Returns the number of such directions (0: `a` is unchanged, bit for
/// bit) and the smallest share (NaN when off or without a Hessian).
pub fn keep_guess_where_unheld(
    a: &mut Alignment,
    init: &Isometry3<f64>,
    min_share: f64,
) -> (usize, f64) {
    if min_share.is_nan() || min_share <= 0.0 {
        return (0, f64::NAN);
    }
    let Some((shares, dirs)) = surface_shares(a) else {
        return (0, f64::NAN);
    };
    let n = shares.iter().take_while(|&&s| s < min_share).count();
    if n == 0 {
        return (0, shares[0]);
    }
    // The alignment's step from the guess, as `perturb` takes it.
    let d = init.inverse() * a.transform;
    let dt = d.translation.vector;
    let phi = d.rotation.scaled_axis();
    let mut delta = Vector6::new(dt.x, dt.y, dt.z, phi.x, phi.y, phi.z);
    let mut hessian = a.hessian;
    for c in 0..n {
        // The directions are H-orthonormal: the step's coordinate along
        // `v` is `v^T H delta`, and `H v` is all the information along it.
        let v = dirs.column(c).into_owned();
        let hv = a.hessian * v;
        delta -= v * hv.dot(&delta);
        hessian -= hv * hv.transpose();
    }
    a.transform = perturb(init, &delta);
    a.hessian = 0.5 * (hessian + hessian.transpose());
    (n, shares[0])
}
