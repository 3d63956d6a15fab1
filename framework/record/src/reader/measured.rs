//! One joint's measured data, as `fit` and `identify` take it.

use std::path::Path;

use super::{ReadError, all_joint_series, config_attachment, joint_series, raw_samples};

/// One joint's measured data from a recording, as `fit` and `identify` take it: its observed
/// deflection against its F/T sensor's torque, only where both are known.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Measured {
    /// Time [s] from the cycle stamps.
    pub t_s: Vec<f64>,
    /// Observed deflection [rad].
    pub deflection_rad: Vec<f64>,
    /// The F/T sensor's torque [Nm].
    pub torque_nm: Vec<f64>,
    /// Pivot setting [mm] to 0.1 mm (a VSA), else empty.
    pub pivot_mm: Vec<f64>,
    /// Torque reference [Nm] (NaN outside torque modes), empty when never set.
    pub reference_torque_nm: Vec<f64>,
    /// The position of a 1-DOF joint's `motor` drive [rad] (its wiring from the attached arm
    /// description), empty when it has none.
    pub motor_position_rad: Vec<f64>,
    /// For a 2-DOF joint (the wrist, asked by its joint name): the direction of each sample's
    /// deflection [deg] (0 = the second DOF only, 90 = the first), the nearest of section
    /// 3.5.2's four (0, 45, 90, 135); deflection and torque are then along it. Else empty.
    pub angle_deg: Vec<f64>,
    /// Samples of the joint left out: deflection, F/T torque or (where it is recorded) the pivot
    /// unknown.
    pub left_out: usize,
    /// Samples of the joint in the recording.
    pub samples: usize,
    /// Samples with a usable F/T torque (0: the joint has no `torque_sensor`).
    pub ft_samples: usize,
}

/// `joint`'s measured data in the recording `path`.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let m = jointctl_record::reader::measured(std::path::Path::new("r.mcap"), "q2")?;
/// assert_eq!(m.t_s.len(), m.torque_nm.len());
/// # Ok(()) }
/// ```
pub fn measured(path: &Path, joint: &str) -> Result<Measured, ReadError> {
    if let Some((first, second)) = two_dofs(path, joint)? {
        return measured_along_directions(path, &first, &second);
    }
    let s = joint_series(path, joint)?;
    // A joint whose pivot is recorded needs it in every sample it gives (its model changes with
    // it): a cycle whose pivot reading was not usable is left out with the others, never read
    // as a setting.
    let has_pivot = s.pivot_mm.iter().any(|p| p.is_finite());
    let keep: Vec<usize> = (0..s.len()).filter(|&i| s.deflection_rad[i].is_finite() && s.sensor_torque_nm[i].is_finite() && (!has_pivot || s.pivot_mm[i].is_finite())).collect();
    let pick = |col: &[f64]| keep.iter().map(|&i| col[i]).collect::<Vec<f64>>();
    let mut m = Measured { t_s: pick(&s.t_s), deflection_rad: pick(&s.deflection_rad), torque_nm: pick(&s.sensor_torque_nm), left_out: s.len() - keep.len(), samples: s.len(), ft_samples: s.sensor_torque_nm.iter().filter(|t| t.is_finite()).count(), ..Measured::default() };
    // The observer's pivot carries its encoder's quantisation: settings are told apart to 0.1 mm.
    if s.pivot_mm.iter().any(|p| p.is_finite()) {
        m.pivot_mm = keep.iter().map(|&i| (s.pivot_mm[i] * 10.0).round() / 10.0).collect();
    }
    if s.reference_torque_nm.iter().any(|r| r.is_finite()) {
        m.reference_torque_nm = pick(&s.reference_torque_nm);
    }
    if let Some(drive) = motor_drive(path, joint)? {
        let by_cycle: std::collections::HashMap<u64, f64> = raw_samples(path)?
            .iter()
            .map(|f| (f.cycle, f.drives.iter().find(|(n, ..)| *n == drive).and_then(|(_, r, _)| r.position_rad.usable(f64::INFINITY)).unwrap_or(f64::NAN)))
            .collect();
        m.motor_position_rad = keep.iter().map(|&i| by_cycle.get(&s.cycle[i]).copied().unwrap_or(f64::NAN)).collect();
    }
    Ok(m)
}

/// A 2-DOF joint's data the way section 3.5.2 characterised the wrist: along the direction of
/// the deflection, the nearest of four (0, 45, 90, 135 deg), both DOFs' deflections and F/T
/// torques projected on it.
fn measured_along_directions(path: &Path, first: &str, second: &str) -> Result<Measured, ReadError> {
    let (mut all, known) = all_joint_series(path)?;
    let no = |j: &str| ReadError::NoJoint { file: path.into(), joint: j.into(), known: known.clone() };
    let a = all.remove(first).ok_or_else(|| no(first))?;
    let b = all.remove(second).ok_or_else(|| no(second))?;
    let mut m = Measured { samples: a.len().min(b.len()), ..Measured::default() };
    // As for one DOF: with the pivot recorded, a cycle without a usable reading of it is left
    // out (one such cycle used to drop the whole record's pivot column).
    let has_pivot = a.pivot_mm.iter().any(|p| p.is_finite());
    for i in 0..m.samples {
        let (d1, d2, t1, t2) = (a.deflection_rad[i], b.deflection_rad[i], a.sensor_torque_nm[i], b.sensor_torque_nm[i]);
        if t1.is_finite() && t2.is_finite() {
            m.ft_samples += 1;
        }
        if !(d1.is_finite() && d2.is_finite() && t1.is_finite() && t2.is_finite()) || (has_pivot && !a.pivot_mm[i].is_finite()) {
            m.left_out += 1;
            continue;
        }
        // Folded into [0, 180): a direction and its opposite are one line (the projection's sign
        // tells them apart).
        let direction = d1.atan2(d2).to_degrees().rem_euclid(180.0);
        let angle = ((direction / 45.0).round() * 45.0).rem_euclid(180.0);
        let (sa, ca) = (angle.to_radians().sin(), angle.to_radians().cos());
        m.t_s.push(a.t_s[i]);
        m.deflection_rad.push(d1 * sa + d2 * ca);
        m.torque_nm.push(t1 * sa + t2 * ca);
        m.angle_deg.push(angle);
        // Every sample kept has its pivot where the pivot is recorded (above): the column is
        // whole or empty.
        if has_pivot {
            m.pivot_mm.push((a.pivot_mm[i] * 10.0).round() / 10.0);
        }
    }
    Ok(m)
}

/// The two DOFs of 2-DOF joint `joint` in the attached arm description, if it is one.
fn two_dofs(path: &Path, joint: &str) -> Result<Option<(String, String)>, ReadError> {
    let Some((_, text)) = config_attachment(path)? else { return Ok(None) };
    let Ok(yaml) = serde_yaml::from_str::<serde_yaml::Value>(&text) else { return Ok(None) };
    let dofs = yaml["joints"].as_sequence().and_then(|joints| joints.iter().find(|j| j["name"].as_str() == Some(joint))).and_then(|j| j["dofs"].as_sequence());
    Ok(match dofs.map(|d| d.iter().filter_map(|x| x["name"].as_str()).collect::<Vec<_>>()).as_deref() {
        Some([first, second]) => Some((first.to_string(), second.to_string())),
        _ => None,
    })
}

/// The `motor` drive of 1-DOF joint `joint` in the attached arm description, if any.
fn motor_drive(path: &Path, joint: &str) -> Result<Option<String>, ReadError> {
    let Some((_, text)) = config_attachment(path)? else { return Ok(None) };
    let Ok(yaml) = serde_yaml::from_str::<serde_yaml::Value>(&text) else { return Ok(None) };
    let entry = yaml["joints"].as_sequence().and_then(|joints| joints.iter().find(|j| j["name"].as_str() == Some(joint) && j["dofs"].is_null()));
    Ok(entry.and_then(|j| j["drives"]["motor"].as_str()).map(str::to_string))
}
