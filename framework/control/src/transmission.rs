/// A 1-DOF transmission `joint = joint_origin + ratio * (motor - motor_origin)`, anchored at the
/// positions read when the joint was activated (the thesis subtracts the initial angle, section
/// 3.4.1, so that the arm may start anywhere).
///
/// ```
/// use jointctl_control::LinearTransmission;
/// // Elbow, eq. 3.1 in the ideal case: theta_out = 2 * theta_motor.
/// let t = LinearTransmission::new(2.0).anchored(0.1, 5.0);
/// assert_eq!(t.joint_for(5.5), 1.1);
/// assert!((t.motor_for(t.joint_for(7.25)) - 7.25).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearTransmission {
    ratio: f64,
    joint_origin: f64,
    motor_origin: f64,
}

impl LinearTransmission {
    /// A transmission with `ratio` joint rad per motor rad (must be non-zero and finite).
    pub const fn new(ratio: f64) -> Self {
        LinearTransmission { ratio, joint_origin: 0.0, motor_origin: 0.0 }
    }

    /// The same transmission anchored at a simultaneous joint and motor reading.
    pub const fn anchored(self, joint_rad: f64, motor_rad: f64) -> Self {
        LinearTransmission { joint_origin: joint_rad, motor_origin: motor_rad, ..self }
    }

    /// Joint rad per motor rad.
    pub const fn ratio(&self) -> f64 {
        self.ratio
    }

    /// Joint position that a motor position gives with an undeflected elastic element [rad].
    pub fn joint_for(&self, motor_rad: f64) -> f64 {
        self.joint_origin + self.ratio * (motor_rad - self.motor_origin)
    }

    /// Motor position that puts the joint at `joint_rad` with an undeflected element [rad].
    pub fn motor_for(&self, joint_rad: f64) -> f64 {
        self.motor_origin + (joint_rad - self.joint_origin) / self.ratio
    }
}
