//! The narrow phase's dispatcher with a cheap first test for the chassis
//! against the ground's triangles.
//!
//! Why: the chassis is a box. Pitched or yawed, its axis-aligned bounding
//! box reaches down into the ground on any slope, and parry runs its full
//! box–triangle separating-axis test on every triangle inside that bounding
//! box: about 450 a step on the lava tube's slopes, for no contact, two
//! thirds of the narrow phase and most of a heavy step's time.
//!
//! Here a triangle whose three corners all lie beyond one face of the box,
//! by more than the prediction distance and a margin, is found separate with
//! three point transforms and is given the empty manifold parry's own test
//! would give it. Everything else is parry's code, unchanged: which
//! triangles are tested, the manifolds, their order and their persistence.
//! The physics is the same to the bit, only cheaper.

use rapier3d::geometry::{ContactData, ContactManifoldData};
use rapier3d::math::{Pose, Real, Vector};
use rapier3d::parry::query::details::{contact_manifolds_trimesh_shape_shapes, NormalConstraints};
use rapier3d::parry::query::{
    ClosestPoints, Contact, ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher,
    NonlinearRigidMotion, PersistentQueryDispatcher, QueryDispatcher, ShapeCastHit,
    ShapeCastOptions, ShapeDistance, ShapeIntersection, Unsupported,
};
use rapier3d::parry::shape::{Cuboid, Shape, ShapeType, Triangle};

/// How much farther than the prediction distance a triangle must lie before
/// the cheap test calls it separate, m. Far above f32's rounding at the
/// world's coordinates (about 2e-5 m at 200 m), so whenever this test says
/// separate, parry's would have said so too.
const MARGIN_M: Real = 1.0e-3;

type Manifold = ContactManifold<ContactManifoldData, ContactData>;

/// parry's default dispatcher, with the chassis–triangle first test.
#[derive(Clone, Copy, Debug, Default)]
pub struct ChassisContacts;

/// How far the triangle `tri` lies outside the box of half extents `half`,
/// measured along the box's own axes (the largest of the six face
/// separations; negative when it reaches into every slab). `pose` places the
/// box in the triangle's frame.
pub fn face_separation(half: Vector, pose: &Pose, tri: &Triangle) -> Real {
    let corners = [tri.a, tri.b, tri.c].map(|p| pose.inverse_transform_point(p));
    let mut worst = Real::MIN;
    for axis in 0..3 {
        let (mut lo, mut hi) = (Real::MAX, Real::MIN);
        for c in &corners {
            lo = lo.min(c[axis]);
            hi = hi.max(c[axis]);
        }
        worst = worst.max(lo - half[axis]).max(-hi - half[axis]);
    }
    worst
}

/// The box and the triangle of a convex pair, and the box's pose in the
/// triangle's frame, when the pair is a box and a triangle.
fn cuboid_triangle<'a>(
    pos12: &Pose,
    g1: &'a dyn Shape,
    g2: &'a dyn Shape,
) -> Option<(&'a Cuboid, &'a Triangle, Pose)> {
    match (g1.shape_type(), g2.shape_type()) {
        (ShapeType::Triangle, ShapeType::Cuboid) => {
            Some((g2.as_cuboid()?, g1.as_triangle()?, *pos12))
        }
        (ShapeType::Cuboid, ShapeType::Triangle) => {
            Some((g1.as_cuboid()?, g2.as_triangle()?, pos12.inverse()))
        }
        _ => None,
    }
}

fn is_trimesh_and_cuboid(g1: &dyn Shape, g2: &dyn Shape) -> bool {
    matches!(
        (g1.shape_type(), g2.shape_type()),
        (ShapeType::TriMesh, ShapeType::Cuboid) | (ShapeType::Cuboid, ShapeType::TriMesh)
    )
}

impl PersistentQueryDispatcher<ContactManifoldData, ContactData> for ChassisContacts {
    fn contact_manifolds(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        prediction: Real,
        manifolds: &mut Vec<Manifold>,
        workspace: &mut Option<ContactManifoldsWorkspace>,
    ) -> Result<(), Unsupported> {
        if is_trimesh_and_cuboid(g1, g2) {
            // parry's own mesh–shape routine, calling back here for each
            // triangle it finds near the box.
            contact_manifolds_trimesh_shape_shapes(
                self, pos12, g1, g2, prediction, manifolds, workspace,
            );
            Ok(())
        } else {
            DefaultQueryDispatcher
                .contact_manifolds(pos12, g1, g2, prediction, manifolds, workspace)
        }
    }

    fn contact_manifold_convex_convex(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        normal_constraints1: Option<&dyn NormalConstraints>,
        normal_constraints2: Option<&dyn NormalConstraints>,
        prediction: Real,
        manifold: &mut Manifold,
    ) -> Result<(), Unsupported> {
        // A manifold with points may be carried over by parry without a
        // test; only an empty one is known to be tested afresh.
        if manifold.points.is_empty() {
            if let Some((cuboid, triangle, pose)) = cuboid_triangle(pos12, g1, g2) {
                if face_separation(cuboid.half_extents, &pose, triangle) > prediction + MARGIN_M {
                    manifold.clear();
                    return Ok(());
                }
            }
        }
        DefaultQueryDispatcher.contact_manifold_convex_convex(
            pos12,
            g1,
            g2,
            normal_constraints1,
            normal_constraints2,
            prediction,
            manifold,
        )
    }
}

/// Every other query is parry's default.
impl QueryDispatcher for ChassisContacts {
    fn intersection_test(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
    ) -> Result<ShapeIntersection, Unsupported> {
        DefaultQueryDispatcher.intersection_test(pos12, g1, g2)
    }

    fn distance(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
    ) -> Result<ShapeDistance, Unsupported> {
        DefaultQueryDispatcher.distance(pos12, g1, g2)
    }

    fn contact(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        prediction: Real,
    ) -> Result<Option<Contact>, Unsupported> {
        DefaultQueryDispatcher.contact(pos12, g1, g2, prediction)
    }

    fn closest_points(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        max_dist: Real,
    ) -> Result<ClosestPoints, Unsupported> {
        DefaultQueryDispatcher.closest_points(pos12, g1, g2, max_dist)
    }

    fn cast_shapes(
        &self,
        pos12: &Pose,
        local_vel12: Vector,
        g1: &dyn Shape,
        g2: &dyn Shape,
        options: ShapeCastOptions,
    ) -> Result<Option<ShapeCastHit>, Unsupported> {
        DefaultQueryDispatcher.cast_shapes(pos12, local_vel12, g1, g2, options)
    }

    fn cast_shapes_nonlinear(
        &self,
        motion1: &NonlinearRigidMotion,
        g1: &dyn Shape,
        motion2: &NonlinearRigidMotion,
        g2: &dyn Shape,
        start_time: Real,
        end_time: Real,
        stop_at_penetration: bool,
    ) -> Result<Option<ShapeCastHit>, Unsupported> {
        DefaultQueryDispatcher.cast_shapes_nonlinear(
            motion1,
            g1,
            motion2,
            g2,
            start_time,
            end_time,
            stop_at_penetration,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier3d::math::Rotation;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle::new(Vector::from(a), Vector::from(b), Vector::from(c))
    }

    const HALF: Vector = Vector::new(0.31, 0.16, 0.07);

    #[test]
    fn a_triangle_under_the_box_is_as_far_as_the_gap() {
        // Ground 5 cm under the box's underside, the box at the origin.
        let t = tri([-1.0, -1.0, -0.12], [1.0, -1.0, -0.12], [0.0, 1.0, -0.12]);
        let d = face_separation(HALF, &Pose::IDENTITY, &t);
        assert!((d - 0.05).abs() < 1e-6, "{d}");
    }

    #[test]
    fn a_triangle_through_the_box_is_not_separate() {
        let t = tri([-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.01]);
        assert!(face_separation(HALF, &Pose::IDENTITY, &t) < 0.0);
    }

    #[test]
    fn the_gap_is_measured_along_the_boxs_own_axes() {
        // The box yawed 90 degrees and lifted 1 m: its long side now lies
        // along y, so a triangle at x = 0.5 is 0.5 - 0.16 beyond its side.
        let pose = Pose::from_parts(
            Vector::new(0.0, 0.0, 1.0),
            Rotation::from_rotation_z(core::f32::consts::FRAC_PI_2),
        );
        let t = tri([0.5, -0.1, 0.9], [0.5, 0.1, 0.9], [0.5, 0.0, 1.1]);
        let d = face_separation(HALF, &pose, &t);
        assert!((d - 0.34).abs() < 1e-5, "{d}");
    }

    #[test]
    fn a_box_and_a_triangle_are_found_in_either_order() {
        let b = Cuboid::new(HALF);
        let t = tri([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let pose = Pose::from_translation(Vector::new(0.0, 0.0, 1.0));
        let (_, _, p12) = cuboid_triangle(&pose, &t, &b).expect("triangle, box");
        assert_eq!(p12, pose);
        let (_, _, p21) = cuboid_triangle(&pose, &b, &t).expect("box, triangle");
        assert_eq!(p21, pose.inverse());
        assert!(cuboid_triangle(&pose, &b, &b).is_none());
    }
}
