//! Where the rover stands as a validation begins.

use speleo_physics::quat;

/// base_link's position and attitude in the map frame when a validation
/// begins. The attitude matters: a rover standing tilted on a wall's foot
/// was put down level in the simulation, which then passed plans that
/// rolled the real rover on toward the wall (42° on the garage's ramp).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stance {
    pub position: [f64; 3],
    /// Z-Y-X Euler angles, rad.
    pub yaw: f64,
    pub pitch: f64,
    pub roll: f64,
}

impl Stance {
    /// Standing level at `x, y, z` heading `yaw`.
    pub fn level(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        Stance {
            position: [x, y, z],
            yaw,
            pitch: 0.0,
            roll: 0.0,
        }
    }

    /// At `position` with the attitude `q` (w, x, y, z).
    pub fn from_quat(position: [f64; 3], q: [f64; 4]) -> Self {
        let (yaw, pitch, roll) = quat::to_ypr(&quat::normalise(&q));
        Stance {
            position,
            yaw,
            pitch,
            roll,
        }
    }

    /// x, y, z, yaw.
    pub fn xyz_yaw(&self) -> [f64; 4] {
        let [x, y, z] = self.position;
        [x, y, z, self.yaw]
    }

    /// The body's up axis in the map frame.
    pub fn up(&self) -> [f64; 3] {
        let q = quat::from_ypr(self.yaw, self.pitch, self.roll);
        quat::rotate(&q, [0.0, 0.0, 1.0])
    }

    /// The rise per metre (dz/dx, dz/dy) of the plane the wheels stand
    /// on, taken square to the body's up axis; zero beyond 60° of tilt,
    /// where no plane the rover stands on is that steep.
    pub fn ground_gradient(&self) -> [f64; 2] {
        if self.pitch == 0.0 && self.roll == 0.0 {
            return [0.0; 2];
        }
        let u = self.up();
        if u[2] < 0.5 {
            return [0.0; 2];
        }
        [-u[0] / u[2], -u[1] / u[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rover_pitched_nose_down_stands_on_ground_falling_ahead() {
        // Pitch is positive nose down about y (Z-Y-X): heading +x, the
        // ground falls along x.
        let s = Stance {
            position: [0.0; 3],
            yaw: 0.0,
            pitch: 0.2,
            roll: 0.0,
        };
        let g = s.ground_gradient();
        assert!((g[0] + 0.2f64.tan()).abs() < 1e-9, "{g:?}");
        assert!(g[1].abs() < 1e-12);
        let back = Stance::from_quat([1.0, 2.0, 3.0], quat::from_ypr(0.5, 0.2, -0.1));
        assert!((back.yaw - 0.5).abs() < 1e-9);
        assert!((back.pitch - 0.2).abs() < 1e-9);
        assert!((back.roll + 0.1).abs() < 1e-9);
    }

    #[test]
    fn a_level_stance_stands_on_flat_ground() {
        let g = Stance::level(1.0, 2.0, 3.0, 0.7).ground_gradient();
        assert!(g[0].abs() < 1e-12 && g[1].abs() < 1e-12, "{g:?}");
    }
}
